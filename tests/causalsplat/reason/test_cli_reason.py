"""The ask and eval commands, invoked for real."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from click.testing import CliRunner

from causalsplat import Store
from causalsplat.cli import cli
from tests.conftest import REPO_ROOT


def test_ask_json(tiny_store: Store) -> None:
    url = tiny_store.graph_store.url
    result = CliRunner().invoke(
        cli, ["ask", "if the table is removed, what falls?", "--scene", "synth-tiny-0",
              "--db", url, "--json"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert {"query", "program", "answer", "entities", "explanation", "reasoner"} <= set(doc)
    assert doc["reasoner"] == "offline" and doc["query_type"] == "counterfactual"
    assert [e["id"] for e in doc["entities"]] == doc["answer"]
    assert {"id", "external_id", "category"} <= set(doc["entities"][0])


def test_eval_json_and_text(tiny_store: Store, tiny_dir: Path) -> None:
    url = tiny_store.graph_store.url
    args = ["eval", str(tiny_dir / "queries.json"), "--scene", "synth-tiny-0", "--db", url]
    result = CliRunner().invoke(cli, [*args, "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert {"n", "accuracy", "miou", "by_type", "per_query"} <= set(doc)
    assert doc["n"] == len(doc["per_query"]) and doc["accuracy"] >= 16 / 18
    text = CliRunner().invoke(cli, args)
    assert text.exit_code == 0 and "accuracy" in text.output


def test_errors_are_one_line(tiny_store: Store) -> None:
    url = tiny_store.graph_store.url
    runner = CliRunner()
    missing = runner.invoke(cli, ["ask", "the cup", "--scene", "nope", "--db", url])
    assert missing.exit_code == 1 and "nope" in missing.output
    blank = runner.invoke(cli, ["ask", "  ", "--scene", "synth-tiny-0", "--db", url])
    assert blank.exit_code == 1 and "no words" in blank.output
    assert len(blank.output.strip().splitlines()) == 1
    # a well-formed sentence naming nothing here is an answer, not an error
    unknown = runner.invoke(cli, ["ask", "the piano", "--scene", "synth-tiny-0", "--db", url])
    assert unknown.exit_code == 0 and "nothing here fits" in unknown.output


def test_cold_ask_imports_neither_torch_nor_networkx(tiny_store: Store) -> None:
    """The reasoner runs its programs on the memory executor (no networkx import)."""
    script = (
        "import sys\n"
        "from causalsplat.cli import main\n"
        f"sys.argv = ['causalsplat', 'ask', 'the blue stool', '--scene', 'synth-tiny-0',"
        f" '--db', {tiny_store.graph_store.url!r}, '--json']\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "print(*(m.upper() for m in ('torch', 'networkx') if m in sys.modules), 'LIGHT')\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=REPO_ROOT, check=True)  # fmt: skip
    document, _, marker = proc.stdout.strip().rpartition("\n")
    assert marker == "LIGHT"
    assert json.loads(document)["answer"] == [9]


def test_ask_shows_the_ranked_candidates(tiny_store: Store) -> None:
    url = tiny_store.graph_store.url
    runner = CliRunner()
    args = ["ask", "I need to dry my hands", "--scene", "synth-tiny-0", "--db", url]
    doc = json.loads(runner.invoke(cli, [*args, "--json"]).output)
    assert doc["query_type"] == "commonsense" and doc["answer"]
    ranked = doc["candidates"]
    assert ranked and ranked[0]["category"] == "towel" and ranked[0]["chosen"] is True
    assert [c["score"] for c in ranked] == sorted((c["score"] for c in ranked), reverse=True)
    assert set(ranked[0]) == {"category", "score", "entities", "chosen", "evidence"}
    text = runner.invoke(cli, [*args, "--no-embeddings"])
    assert text.exit_code == 0 and "candidates (best first):" in text.output
    assert " *1. towel" in text.output


def test_ask_says_when_nothing_fits(tiny_store: Store) -> None:
    url = tiny_store.graph_store.url
    runner = CliRunner()
    args = ["ask", "the purple table", "--scene", "synth-tiny-0", "--db", url, "--no-embeddings"]
    text = runner.invoke(cli, args)
    assert text.exit_code == 0, text.output
    assert "nothing here fits" in text.output and "contradicts 'purple'" in text.output
    doc = json.loads(runner.invoke(cli, [*args, "--json"]).output)
    assert doc["answer"] == [] and doc["nothing_fits"] is True
    # a counterfactual where nothing falls is an answer, not "nothing fits"
    doc = json.loads(runner.invoke(cli, ["ask", "what falls if the floor is removed?",
                                         "--scene", "synth-tiny-0", "--db", url,
                                         "--json"]).output)  # fmt: skip
    assert doc["query_type"] == "counterfactual" and doc["nothing_fits"] is False
