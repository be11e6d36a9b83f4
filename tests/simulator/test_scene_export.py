"""The simulator's scene as a glTF file, served to a Foxglove client by the bridge's
`--asset-dir` (simulator/scene_export.py, bridge/foxglove/assets.py)."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import trimesh
import websockets

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from simulator.config import SimConfig
from simulator.scene import build_scene
from simulator.scene_export import main

LIGHT = {"scene": {"terrain_cells": 60, "trees": 0, "houses": 0}}


async def test_the_exported_scene_is_the_simulated_one_and_a_foxglove_client_fetches_it(
    tmp_path: Path,
) -> None:
    config_path = tmp_path / "sim.toml"
    config_path.write_text("[scene]\nterrain_cells = 60\ntrees = 0\nhouses = 0\n")
    folder = tmp_path / "scene"
    assert main(["--config", str(config_path), "--output", str(folder)]) == 0
    written = (folder / "scene.glb").read_bytes()
    mesh = trimesh.load(folder / "scene.glb", force="mesh")
    scene = build_scene(SimConfig.model_validate(LIGHT).scene, seed=7)
    assert len(mesh.faces) == len(scene.faces)
    assert mesh.bounds.tolist() == [scene.vertices.min(0).tolist(), scene.vertices.max(0).tolist()]

    async with (
        run_bridge(BridgeConfig(port=0, asset_dirs=(folder,))) as bridge,
        websockets.connect(bridge.url, subprotocols=["foxglove.websocket.v1"], max_size=None) as ws,
    ):
        await ws.send(
            json.dumps({"op": "fetchAsset", "uri": "package://scene/scene.glb", "requestId": 3})
        )
        while isinstance(answer := await ws.recv(), str):
            pass
    opcode, request_id, status, error_length = struct.unpack_from("<BIBI", answer)
    assert (opcode, request_id, status, error_length) == (4, 3, 0, 0)
    assert answer[10:] == written


def test_a_bad_configuration_exits_2(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[scene]\nterrain_cells = 'many'\n")
    assert main(["--config", str(bad), "--output", str(tmp_path / "out")]) == 2
