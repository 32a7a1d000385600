"""A store with the shipped demo kitchen (and a copy with per-Gaussian labels), served by a
real HTTP server on 127.0.0.1 for the tests of this folder."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
import pytest

import causalsplat
from causalsplat import open_store
from causalsplat.serve import App, Server

DEMO_OBJECTS = Path(causalsplat.__file__).parent / "data" / "demo_kitchen.json"
#: The labelled copy's entity id per Gaussian: every entity id, -1 (none) between them.
LABELS = np.array([-1, 0, 0, 3, 5, -1, 11, 2, 2, 2], dtype=np.int32)


@pytest.fixture(scope="session")
def store_url(tmp_path_factory: pytest.TempPathFactory) -> str:
    url = f"sqlite:///{tmp_path_factory.mktemp('serve') / 'store.db'}"
    with open_store(url) as store:
        graph = store.ingest_objects(DEMO_OBJECTS).graph
        meta = dataclasses.replace(graph.meta, scene_id="labelled kitchen")
        store.save_scene(dataclasses.replace(graph, meta=meta), gaussian_labels=LABELS)
    return url


@pytest.fixture(scope="session")
def server(store_url: str) -> Iterator[Server]:
    """The app on 127.0.0.1, a port the system picked; a SPARQL limit of 50 rows."""
    with open_store(store_url, create=False) as store:
        server = Server(App(store, limit=50, timeout_s=20.0), "127.0.0.1", 0).start()
        try:
            yield server
        finally:
            server.shutdown()


@pytest.fixture(scope="session")
def base_url(server: Server) -> str:
    return server.url.rstrip("/")


#: The browser the page tests drive (Debian's ``chromium``; skipped without it).
CHROMIUM = os.environ.get("CAUSALSPLAT_TEST_CHROMIUM", "/usr/bin/chromium")


def _missing(reason: str) -> NoReturn:
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"{reason}: CI must run the browser tests")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if not Path(CHROMIUM).is_file():
        _missing(f"no Chromium at {CHROMIUM} (apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _missing("playwright is not installed (pip install -e '.[dev]')")
    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=CHROMIUM,
            args=[
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--disable-dev-shm-usage",
            ],
        )
        try:
            yield browser
        finally:
            browser.close()
