"""The query path stays light: importing it (and using the store) never imports torch."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.conftest import REPO_ROOT

SCRIPT = """
import sys
import graph_store, queries, causalsplat
import causalsplat.api, causalsplat.cli, causalsplat.objects, graph_store.repository
import causalsplat.build, causalsplat.field, causalsplat.instances, causalsplat.graph.nodes
from causalsplat import open_store
with open_store("sqlite://") as store:
    store.scenes()
heavy = sorted(
    m for m in ("torch", "hdbscan", "plyfile", "openai", "numba") if m in sys.modules
)
print(",".join(heavy))
"""


def test_light_packages_do_not_import_torch() -> None:
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, cwd=REPO_ROOT, check=True
    )
    assert proc.stdout.strip() == "", f"heavy modules imported: {proc.stdout.strip()}"


ASK = """
import sys
from causalsplat.cli import main
for text in sys.argv[1:]:
    sys.argv = ["causalsplat", "ask", text, "--scene", "kitchen", "--db", DB, "--json", *EXTRA]
    try:
        main()
    except SystemExit as exc:
        assert not exc.code, exc.code
heavy = ("torch", "networkx", "sqlalchemy.orm", "tomllib", "safetensors", "scipy",
         "rdflib", "pyoxigraph")
print(",".join(sorted(m for m in heavy if m in sys.modules)), file=sys.stderr)
"""


def test_a_cold_ask_imports_only_what_it_uses(tmp_path: Path) -> None:
    """``causalsplat ask`` in a fresh interpreter, lexical and with embeddings: no torch,
    no networkx (the reference executor walks plain dicts), no ORM (Core tables), no TOML
    parser (the knowledge table ships as JSON), no safetensors (weights are memory-mapped),
    no RDF library (the programs run on the memory executor, not SPARQL)."""
    from causalsplat.objects import objects_to_scene_graph, parse_objects
    from causalsplat.reason.embed import embeddings_available
    from graph_store import open_store
    from tests.causalsplat.test_objects import KITCHEN

    db = f"sqlite:///{tmp_path / 'store.db'}"
    with open_store(db) as store:
        store.save_scene(objects_to_scene_graph(parse_objects(KITCHEN, source="kitchen")))
    texts = ["where can I wash my hands?", "the towel next to the sink",
             "if the sink is removed, what falls?"]  # fmt: skip
    for extra in (["--no-embeddings"], [] if embeddings_available() else None):
        if extra is None:
            continue
        code = f"DB = {db!r}\nEXTRA = {extra!r}\n" + ASK
        proc = subprocess.run(
            [sys.executable, "-c", code, *texts],
            capture_output=True, text=True, cwd=REPO_ROOT, check=True,
        )  # fmt: skip
        assert proc.stderr.strip() == "", f"{extra}: imported {proc.stderr.strip()}"
        assert proc.stdout.count('"query":') == len(texts)


BUILD = """
import sys
from causalsplat.build.pipeline import build_scene
result = build_scene(sys.argv[1], cache_dir=False)
assert result.graph.entities
print("torch" in sys.modules)
"""


def test_a_build_does_not_import_torch(tmp_path: Path) -> None:
    """The feature field trains with numpy and compiled row kernels (its gradient is
    written out; tests/causalsplat/field holds it to torch's autograd), so a build never
    pays torch's import."""
    from causalsplat.synth import SynthConfig, generate_scene, write_synth_scene

    folder = tmp_path / "scene"
    write_synth_scene(generate_scene(SynthConfig.preset("tiny", seed=0)), folder)
    proc = subprocess.run(
        [sys.executable, "-c", BUILD, str(folder)],
        capture_output=True, text=True, cwd=REPO_ROOT, check=True,
    )  # fmt: skip
    assert proc.stdout.strip() == "False"
