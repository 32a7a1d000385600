"""The viewer page in a real headless Chromium (Debian's ``chromium``, driven by Playwright)
against a real server on 127.0.0.1: a small synthetic scene built from Gaussians and the
demo kitchen (objects only, no Gaussians).

Skipped when Chromium or Playwright is missing; under CI (``CI=true``) that fails instead,
so CI cannot pass without running them. Chromium draws WebGL2 with SwiftShader here.
"""

from __future__ import annotations

import base64
import hashlib
import io
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import causalsplat
from causalsplat import open_store
from causalsplat.io import Camera, GaussianScene, write_ply
from causalsplat.serve import App, Server
from causalsplat.serve.splats import HIGHLIGHT_COLOR, entity_palette
from graph_store import Entity, SceneGraph, SceneMeta
from tests.causalsplat.serve.conftest import CHROMIUM
from tests.conftest import COMMAND_TIMEOUT_S, REPO_ROOT

DEMO_KITCHEN = Path(causalsplat.__file__).parent / "data" / "demo_kitchen.json"
QUESTION = "where can I wash my hands?"
BACKGROUND = np.array([21, 23, 28])  # the page's clear colour (0.082, 0.09, 0.11)
STRUCTURE = ("wall", "floor", "ceiling")  # not labelled unless selected or an answer


@pytest.fixture(scope="module")
def store_url(tmp_path_factory: pytest.TempPathFactory) -> str:
    pytest.importorskip("torch", reason="building a scene needs the field extra")
    from causalsplat.build import BuildConfig
    from causalsplat.field import FieldConfig
    from causalsplat.synth import synth_scene

    work = tmp_path_factory.mktemp("viewer")
    synth_scene("tiny", 0, work / "room")
    url = f"sqlite:///{work / 'store.db'}"
    with open_store(url) as store:
        config = BuildConfig(field=FieldConfig(iterations=30))
        store.build(work / "room", scene_id="room", config=config, cache_dir=False)
        store.ingest_objects(DEMO_KITCHEN, scene_id="kitchen")
        graph, labels = _one_gaussian(work / "one")
        store.save_scene(graph, gaussian_labels=labels)
    return url


#: One anisotropic, rotated Gaussian; an opacity under exp(4.5)/255 keeps its footprint
#: inside the 3 standard deviations both renderers draw, so they must agree pixel for pixel.
ONE = GaussianScene(
    means=[[0.3, -0.25, 0.65]],
    quats=[[0.9, 0.2, -0.3, 0.25]],
    log_scales=np.log([[0.35, 0.12, 0.05]]),
    opacity_logits=[np.log(0.3 / 0.7)],
    sh=[[[0.8, -0.4, 0.1]]],
)


def _one_gaussian(folder: Path) -> tuple[SceneGraph, np.ndarray]:
    folder.mkdir()
    ply = folder / "point_cloud.ply"
    write_ply(ply, ONE)
    meta = SceneMeta(
        scene_id="one", source="build",
        provenance=(("point_cloud.ply", hashlib.sha256(ply.read_bytes()).hexdigest()),
                    ("source_dir", str(folder))),
    )  # fmt: skip
    vase = Entity(0, "vase", (0.3, -0.25, 0.65), (-0.5, -0.5, 0.0), (0.5, 0.5, 1.0))
    return SceneGraph(meta=meta, entities=(vase,)), np.zeros(1, dtype=np.int32)


@pytest.fixture(scope="module")
def base_url(store_url: str) -> Iterator[str]:
    with open_store(store_url, create=False) as store:
        server = Server(App(store), "127.0.0.1", 0).start()
        try:
            yield server.url.rstrip("/")
        finally:
            server.shutdown()


class Page:
    """A page of the viewer, with every console error, page error and off-origin request."""

    def __init__(self, browser: Any, base_url: str) -> None:
        self.page = browser.new_page(viewport={"width": 1100, "height": 700})
        self.page.set_default_timeout(COMMAND_TIMEOUT_S * 1000)
        self.base_url = base_url
        self.errors: list[str] = []
        self.foreign: list[str] = []
        self.page.on("console", self._console)
        self.page.on("pageerror", lambda exc: self.errors.append(f"page error: {exc}"))
        self.page.on("request", self._request)

    def _console(self, message: Any) -> None:
        if message.type == "error":
            self.errors.append(f"console error: {message.text}")

    def _request(self, request: Any) -> None:
        if not request.url.startswith((self.base_url + "/", "data:")):
            self.foreign.append(request.url)

    def open(self, scene: str) -> None:
        self.page.goto(f"{self.base_url}/#scene={scene}")
        self.wait_ready(scene)

    def wait_ready(self, scene: str) -> None:
        self.page.wait_for_function(
            "s => document.body.dataset.ready === '1' && document.body.dataset.scene === s",
            arg=scene,
        )

    def data(self, name: str) -> str:
        return str(self.page.evaluate(f"document.body.dataset.{name}"))

    def canvas(self, selector: str) -> np.ndarray:
        """The pixels (H, W, 3) of a canvas of the page, after the next frame."""
        from PIL import Image

        url = self.page.evaluate(
            """sel => new Promise(done => requestAnimationFrame(() => requestAnimationFrame(
                 () => done(document.querySelector(sel).toDataURL('image/png')))))""",
            selector,
        )
        raw = base64.b64decode(url.split(",", 1)[1])
        return np.asarray(Image.open(io.BytesIO(raw)).convert("RGB")).astype(np.int32)

    def check_clean(self) -> None:
        assert self.errors == []
        assert self.foreign == [], "the page fetched something from elsewhere"


@pytest.fixture
def page(browser: Any, base_url: str) -> Iterator[Page]:
    p = Page(browser, base_url)
    try:
        yield p
        p.check_clean()
    finally:
        p.page.close()


def _near(pixels: np.ndarray, hex_color: str, tol: int = 10) -> int:
    rgb = np.array([int(hex_color[i : i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(pixels - rgb).max(axis=2) <= tol).sum())


def _graph(store_url: str, scene: str) -> Any:
    with open_store(store_url, create=False) as store:
        return store.scene(scene).graph


def test_the_scene_renders_as_gaussians_in_entity_colours(page: Page, store_url: str) -> None:
    page.open("room")
    graph = _graph(store_url, "room")
    count = int(page.data("splats"))
    assert count > 1000
    pixels = page.canvas("#gl")
    drawn = int((np.abs(pixels - BACKGROUND).max(axis=2) > 12).sum())
    # Footprints, not points: far more pixels are covered than there are Gaussians.
    assert drawn > 5 * count, (drawn, count)
    palette = entity_palette(e.id for e in graph.entities)
    objects = [e for e in graph.entities if e.category not in STRUCTURE]
    seen = {e.id: _near(pixels, palette[e.id]) for e in objects}
    assert sum(n > 20 for n in seen.values()) >= len(objects) // 2, seen
    assert _near(pixels, HIGHLIGHT_COLOR, tol=40) == 0
    # every object gets its label, and the picker lists both scenes
    labels = page.page.locator("#labels .label:not([hidden])")
    names = set(labels.all_inner_texts())
    assert {f"{e.category} {e.id}" for e in objects} <= names
    options = page.page.locator("#scene-picker option").evaluate_all("os => os.map(o => o.value)")
    assert sorted(options) == ["kitchen", "one", "room"]


def test_an_answer_is_highlighted_in_3d(page: Page, store_url: str) -> None:
    with open_store(store_url, create=False) as store:
        expected = store.scene("room").ask(QUESTION)
    assert expected.entity_ids and set(expected.categories) == {"sink"}
    page.open("room")
    page.page.fill("#ask-input", QUESTION)
    page.page.click("#ask-button")
    page.page.wait_for_function("document.body.dataset.ask === 'done'")
    ids = [int(t) for t in page.data("highlighted").split()]
    assert ids == list(expected.entity_ids)
    assert _near(page.canvas("#gl"), HIGHLIGHT_COLOR, tol=40) > 200
    assert page.page.inner_text("#answer-program") == expected.program.to_text()
    assert "sink" in page.page.inner_text("#answer-summary")
    hot = page.page.locator("#labels .label.hot").all_inner_texts()
    assert sorted(hot) == sorted(f"sink {i}" for i in ids)
    page.page.click("#clear-answer")
    assert page.data("highlighted") == ""
    assert _near(page.canvas("#gl"), HIGHLIGHT_COLOR, tol=40) == 0


def test_clicking_an_entity_shows_its_attributes_and_relations(page: Page, store_url: str) -> None:
    graph = _graph(store_url, "room")
    page.open("room")
    target = next(e for e in graph.entities if e.category == "table")
    page.page.click(f'#labels .label[data-entity="{target.id}"]')
    assert page.data("selected") == str(target.id)
    assert page.page.is_visible("#entity-card")
    assert page.page.inner_text("#card-title").strip() == f"table {target.id}"
    related = [r for r in graph.relations if target.id in (r.src, r.dst)]
    assert page.page.locator("#card-relations li").count() == len(related) > 0
    # a relation's other entity is a link to that entity
    other = related[0].dst if related[0].src == target.id else related[0].src
    page.page.locator("#card-relations a", has_text=f" {other}").first.click()
    assert page.data("selected") == str(other)


def test_edges_are_toggled_per_relation_type(page: Page, store_url: str) -> None:
    graph = _graph(store_url, "room")
    page.open("room")
    types = {r.type.value for r in graph.relations}
    toggles = page.page.locator("#relation-toggles input")
    assert sorted(toggles.evaluate_all("xs => xs.map(x => x.dataset.relation)")) == sorted(types)
    for t in types:  # every edge off: only the centroid dots remain
        page.page.set_checked(f'#relation-toggles input[data-relation="{t}"]', False)
    base = page.canvas("#overlay")
    page.page.set_checked('#relation-toggles input[data-relation="near"]', True)
    with_near = page.canvas("#overlay")
    changed = int((np.abs(with_near - base).max(axis=2) > 0).sum())
    assert changed > 500, changed


def test_a_scene_without_gaussians_shows_its_entities(page: Page, store_url: str) -> None:
    page.open("room")
    page.page.select_option("#scene-picker", "kitchen")
    page.wait_ready("kitchen")
    assert page.data("splats") == "0"
    assert "not built from a scene folder" in page.page.inner_text("#status")
    graph = _graph(store_url, "kitchen")
    names = set(page.page.locator("#labels .label:not([hidden])").all_inner_texts())
    objects = [e for e in graph.entities if e.category not in STRUCTURE]
    assert {f"{e.category} {e.id}" for e in objects} <= names
    palette = entity_palette(e.id for e in graph.entities)
    assert page.page.is_checked("#show-boxes")  # boxes stand in for the Gaussians
    page.page.uncheck("#show-boxes")
    before = page.canvas("#overlay")
    page.page.check("#show-boxes")
    boxes = page.canvas("#overlay")
    found = [
        e.id for e in objects if _near(boxes, palette[e.id], 40) > _near(before, palette[e.id], 40)
    ]
    assert len(found) >= len(objects) // 2, found
    assert page.page.evaluate("location.hash") == "#scene=kitchen"


def test_the_screenshot_command(browser: Any, store_url: str, tmp_path: Path) -> None:
    """``scripts/viewer_screenshot.py`` (docs/viewer.md) writes the page with the answer."""
    from PIL import Image

    with open_store(store_url, create=False) as store:
        expected = store.scene("room").ask(QUESTION).entity_ids
    out = tmp_path / "shot.png"
    proc = subprocess.run(
        [sys.executable, str(REPO_ROOT / "scripts" / "viewer_screenshot.py"), "--db", store_url,
         "--scene", "room", "--ask", QUESTION, "-o", str(out), "--width", "900", "--height",
         "600", "--relations", "supported_by,near", "--chromium", CHROMIUM],
        capture_output=True, text=True, timeout=COMMAND_TIMEOUT_S, cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert f"highlighted [{' '.join(map(str, expected))}]" in proc.stdout
    with Image.open(out) as image:
        assert image.size == (900, 600)
        pixels = np.asarray(image.convert("RGB")).astype(np.int32)
    assert _near(pixels, HIGHLIGHT_COLOR, tol=40) > 100


def test_a_gaussian_is_drawn_as_the_project_rasterizer_draws_it(page: Page) -> None:
    """The page's footprint of one Gaussian against :func:`causalsplat.render.render_alpha`
    from the same camera (the page's OpenGL view turned into OpenCV's: y and z flipped)."""
    from causalsplat.render import RasterConfig, render_alpha

    page.open("one")
    cam = page.page.evaluate(
        """() => { const c = window.causalsplatViewer.camera;
                   return {view: Array.from(c.view()), focal: c.focal()[0],
                           width: c.width, height: c.height, dpr: devicePixelRatio}; }"""
    )
    pixels = page.canvas("#gl")
    height, width, _ = pixels.shape
    assert (width, height) == (round(cam["width"] * cam["dpr"]), round(cam["height"] * cam["dpr"]))
    view = np.array(cam["view"], dtype=np.float64).reshape(4, 4).T  # column-major
    camera = Camera(
        "page", width, height, fx=cam["focal"] * cam["dpr"], fy=cam["focal"] * cam["dpr"],
        cx=width / 2, cy=height / 2, T_cam_world=np.diag([1.0, -1.0, -1.0, 1.0]) @ view,
    )  # fmt: skip
    expected = render_alpha(ONE, camera, config=RasterConfig(backend="numpy"))
    color = np.array([int(entity_palette([0])[0][i : i + 2], 16) for i in (1, 3, 5)])
    alpha = (pixels[..., 0] - BACKGROUND[0]) / (color[0] - BACKGROUND[0])
    assert expected.max() > 0.25 and (expected > 0.01).sum() > 2000  # a big footprint
    assert np.abs(alpha - expected).max() < 0.02
    np.testing.assert_allclose(
        pixels, BACKGROUND + expected[..., None] * (color - BACKGROUND), atol=5
    )
