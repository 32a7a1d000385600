"""Writing a file atomically: a temporary file beside it, renamed over it on success.

A crash or an error leaves either the old file or the new one, never half of one, and the
temporary is removed. An error opening or renaming names the file the user asked for, not
the temporary (``export -o /proc/x.ttl`` reports ``/proc/x.ttl``).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_target(path: Path) -> Iterator[Path]:
    """``with atomic_target(path) as tmp``: write ``tmp``; it replaces ``path`` when the
    block succeeds (module docstring)."""
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        if exc.filename is not None and Path(exc.filename) == tmp:
            raise type(exc)(exc.errno, exc.strerror, str(path)) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)
