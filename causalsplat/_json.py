"""Decoding JSON files that users hand in, with one message per way they can be wrong.

Every reader of a user's JSON file (objects, queries, transforms, build configs) decodes
through :func:`decode_json` and wraps :class:`JSONInputError` in its own typed error, so
that a binary file, a truncated file or a document nested a hundred thousand levels deep
(which exhausts Python's recursion limit in :mod:`json`) is one line, never a traceback.

>>> decode_json(b'{"a": [1, 2]}')
{'a': [1, 2]}
>>> decode_json(b"[" * 100_000)
Traceback (most recent call last):
    ...
causalsplat._json.JSONInputError: not valid JSON: nested too deeply for Python's JSON reader
>>> decode_json(b'{"a": 5, "a": 6}')
Traceback (most recent call last):
    ...
causalsplat._json.JSONInputError: not valid JSON here: the key 'a' appears twice in one object

A key given twice is refused rather than resolved (Python keeps the last, other readers the
first): the file does not say which value it means.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any


class JSONInputError(ValueError):
    """The bytes are not a JSON document this library can read (the message says why)."""


def utf8_text(data: bytes) -> str:
    """``data`` as UTF-8 text (a leading byte-order mark dropped), or :class:`ValueError`
    naming the first byte that is not.

    >>> utf8_text(b"ab\\xff")
    Traceback (most recent call last):
    ...
    ValueError: not UTF-8 text (byte 2 is 0xff)
    """
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text (byte {exc.start} is 0x{data[exc.start]:02x})") from None


def decode_json(data: bytes | str, *, parse_constant: Callable[[str], Any] | None = None) -> Any:
    """The decoded document, or :class:`JSONInputError` naming the problem."""
    if isinstance(data, bytes):
        try:
            data = utf8_text(data)
        except ValueError as exc:
            raise JSONInputError(f"not valid JSON: {exc}") from None
    try:
        return json.loads(data, parse_constant=parse_constant, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as exc:
        raise JSONInputError(f"not valid JSON: {exc}") from None
    except RecursionError:
        raise JSONInputError("not valid JSON: nested too deeply for Python's JSON reader") from None
    except ValueError as exc:  # an integer past Python's digit limit, or a repeated key
        if isinstance(exc, JSONInputError):
            raise
        raise JSONInputError(f"not valid JSON here: {str(exc).split(';')[0]}") from None


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise JSONInputError(
                f"not valid JSON here: the key {key!r} appears twice in one object"
            )
        out[key] = value
    return out
