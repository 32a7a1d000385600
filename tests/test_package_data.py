"""Every data file the code reads is declared as package data, so a wheel carries it (an
editable install would hide a missing one)."""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA_SUFFIXES = (
    ".json",
    ".gz",
    ".toml",
    ".npz",
    ".txt",
    ".ttl",
    ".mako",
    ".typed",
    ".html",
    ".js",
    ".css",
    ".wasm",
)


def test_every_data_file_matches_a_package_data_glob() -> None:
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    declared = pyproject["tool"]["setuptools"]["package-data"]
    missing = []
    for package, globs in declared.items():
        base = ROOT / package
        for path in base.rglob("*"):
            if not path.is_file() or "__pycache__" in path.parts:
                continue
            if not path.name.endswith(DATA_SUFFIXES):
                continue
            relative = path.relative_to(base).as_posix()
            if not any(fnmatch.fnmatch(relative, g) for g in globs):
                missing.append(f"{package}/{relative}")
    assert not missing, f"data files not declared as package data: {missing}"
    assert {"causalsplat", "graph_store", "queries", "migrations"} <= set(declared)
