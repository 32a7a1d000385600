"""Entities named by a VLM server from their mask crops (a scripted server on loopback)."""

from __future__ import annotations

import base64
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from causalsplat import open_store
from causalsplat.build import BuildConfig, build_scene
from causalsplat.field import FieldConfig
from causalsplat.graph.labeling import GREY, crop_masked
from causalsplat.openai_compat import ChatClient, VLMConfig, VLMLabeler
from causalsplat.openai_compat.errors import VLMError
from graph_store import AttributeSource
from tests.causalsplat.reason.vlm_server import Reply, ScriptedServer, Status

FAST = BuildConfig(field=FieldConfig(iterations=20))
LABEL = json.dumps({"category": "Armchair", "color": "green", "material": "", "state": "",
                    "affordances": ["sit"]})  # fmt: skip


def test_crop_is_the_padded_box_with_the_outside_grey() -> None:
    image = np.full((10, 12, 3), 200, dtype=np.uint8)
    mask = np.zeros((10, 12), dtype=bool)
    mask[4:6, 5:8] = True
    crop = crop_masked(image, mask, pad=1)
    assert crop.shape == (4, 5, 3)
    assert (crop[1:3, 1:4] == 200).all() and (crop[0] == GREY).all()
    with pytest.raises(ValueError, match="empty"):
        crop_masked(image, np.zeros((10, 12), dtype=bool))


def test_build_with_a_vlm_labeler(tiny_folder: Path, tmp_path: Path) -> None:
    with ScriptedServer() as server:
        server.script.extend([Reply(LABEL)] * 64)
        client = ChatClient(VLMConfig(base_url=server.base_url, model="vlm-test"))
        result = build_scene(tiny_folder, config=FAST, cache_dir=False,
                             labeler=VLMLabeler(client))  # fmt: skip
    entities = result.graph.entities
    assert len(server.requests) == len(entities) > 0
    for e in entities:
        assert e.category == "armchair" and e.confidence is None
        sources = {(a.key, a.source) for a in e.attributes}
        assert ("affordance", AttributeSource.VLM) in sources
        assert ("color", AttributeSource.GEOMETRY) in sources  # geometry attributes stay
    first = server.requests[0]["body"]["messages"][1]["content"]
    assert "It may be a" in first[0]["text"]  # the mask vote goes along as a hint
    png = base64.b64decode(first[1]["image_url"]["url"].split(",", 1)[1])
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_failing_server_stores_nothing(
    tiny_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = dataclasses.replace(FAST, labeler="vlm")
    with ScriptedServer() as server, open_store(f"sqlite:///{tmp_path / 'v.db'}") as store:
        server.script.extend([Status(500)] * 16)
        monkeypatch.setenv("CAUSALSPLAT_VLM_BASE_URL", server.base_url)
        monkeypatch.setenv("CAUSALSPLAT_VLM_MODEL", "vlm-test")
        with pytest.raises(VLMError):
            store.build(tiny_folder, config=config, cache_dir=False)
        assert store.scenes() == []
