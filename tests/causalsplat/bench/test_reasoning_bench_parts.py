"""Parts of the reasoning benchmark: phenomena, "none" variants, absent placements."""

from __future__ import annotations

from pathlib import Path

import pytest

from causalsplat.bench import _reasoning_ddn as ddn
from causalsplat.bench import _reasoning_referit as ref
from causalsplat.colors import hex_to_rgb, names_of


def test_phenomena_are_read_from_the_words() -> None:
    assert ref.phenomena("facing the bed, the second brown chair from the left") == (
        "colour", "left / right", "viewpoint", "ordinal")  # fmt: skip
    assert ref.phenomena("the box that is not next to the armchair") == ("negation / exclusion",)
    assert ref.phenomena("the lamp on the desk") == ()


@pytest.mark.shared_data
def test_absent_placements_hold_no_acceptable_label() -> None:
    if not ddn.available():
        pytest.skip("DDN data not present")
    rows = ddn.absent_placements("train")[:50]
    labels = ddn.scan_labels()
    assert rows and all(not labels[r.scan] & r.acceptable for r in rows)


@pytest.mark.parametrize(
    ("text", "command"),
    [
        ("I want to heat up my lunch.", "heat up my lunch"),
        ("I'd like to sit down!", "sit down"),
        ("Let me dry my hair", "dry my hair"),
        ("I am thirsty", None),
        ("I want a drink", None),  # a want of a thing, not of a deed
    ],
)
def test_an_instruction_is_said_as_a_command(text: str, command: str | None) -> None:
    assert ddn.as_command(text) == command


@pytest.mark.shared_data
def test_command_placements_keep_the_placement(tmp_path: Path) -> None:
    if not ddn.available():
        pytest.skip("DDN data not present")
    pairs = ddn.command_placements("train")
    assert len(pairs) > 100
    for want, command in pairs:
        assert (want.scan, want.acceptable) == (command.scan, command.acceptable)
        assert want.text.lower().rstrip(".!").endswith(command.text.lower())


@pytest.mark.shared_data
def test_contradicted_variants_fit_no_object_of_the_target_label(tmp_path: Path) -> None:
    if not ref.DATA.exists():
        pytest.skip("ReferIt3D data not present")
    rows = ref.scanrefer_rows("val_sampled1000")[:120]
    graphs = ref.ScanGraphs(f"sqlite:///{tmp_path / 'r.db'}")
    try:
        pairs = ref.contradicted_rows(rows, graphs)
        assert pairs
        for original, variant in pairs:
            assert original.target == variant.target and original.text != variant.text
            ctx = graphs.context(variant.scan)
            label = ctx.by_id[variant.target].category
            before, after = original.text.lower().split(), variant.text.lower().split()
            (old, new), *_ = [(a, b) for a, b in zip(before, after, strict=True) if a != b]
            assert ref.OPPOSITE_COLOURS[old.strip(".,")] == new.strip(".,")
            new = new.strip(".,")
            for e in ctx.graph.entities:
                if e.category != label:
                    continue
                rgb = hex_to_rgb(next(a.value for a in e.attributes if a.key == "rgb"))
                assert rgb is not None and names_of(rgb)[0] != ("gray" if new == "grey" else new)
    finally:
        graphs.close()


def test_built_scenes_sit_beside_the_same_questions_on_their_gt_objects(tmp_path: Path) -> None:
    from causalsplat.bench.reasoning import _built

    lines, data = _built(tmp_path, quick=True)
    built = data["built/synthetic tiny (seed 0)"]
    truth = data["built/synthetic tiny (seed 0)/gt-objects"]
    assert built["n"] == truth["n"] > 0
    assert truth["accuracy"] >= built["accuracy"] - 0.2
    text = "\n".join(lines)
    assert "| synthetic tiny (seed 0), GT objects (same questions) | **all** |" in text
    gap = 100 * (truth["accuracy"] - built["accuracy"])
    assert f"a fidelity gap of {gap:.1f} points" in text
