"""`python -m simulator.scene_export`: write the simulated scene as a mesh file for viewers.

The simulator builds its river valley in memory (terrain, water, landing stages, vessels,
trees, houses); this writes the same triangles, coloured per face by material, as one binary
glTF (`scene.glb`) into a folder, so that the bridge can serve it to Foxglove clients
(`riverbridge bridge --asset-dir FOLDER`, then `package://<folder name>/scene.glb`) and 3D
panels can show the scene the sensors see. Same configuration and seed, same triangles.

    python -m simulator.scene_export --config config/sim.toml --output scene

Exit codes: 0 written; 2 bad options or configuration.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import trimesh

from simulator.config import SimConfig, load_config
from simulator.scene import Scene, build_scene

FILE_NAME = "scene.glb"


def scene_mesh(scene: Scene) -> trimesh.Trimesh:
    """The scene's triangles (map frame, metres) with each face's material colour (RGBA)."""
    alpha = np.full((len(scene.faces), 1), 255, np.uint8)
    return trimesh.Trimesh(
        vertices=scene.vertices,
        faces=scene.faces,
        face_colors=np.hstack([scene.colour_rgb, alpha]),
        process=False,
    )


def export_scene(config: SimConfig, folder: Path) -> Path:
    """Build the scene of `config` and write it to `folder`/scene.glb; the file's path."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / FILE_NAME
    scene_mesh(build_scene(config.scene, seed=config.seed)).export(path, file_type="glb")
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m simulator.scene_export",
        description="Write the simulator's scene as a binary glTF (scene.glb) into a folder "
        "the bridge serves to Foxglove clients (--asset-dir).",
    )
    parser.add_argument("--config", help="simulator TOML ([scene] table and seed)")
    parser.add_argument("--output", required=True, type=Path, help="folder to write into")
    args = parser.parse_args(argv)
    try:
        config = load_config(args.config) if args.config else SimConfig()
    except (OSError, ValueError) as exc:  # pydantic's ValidationError is a ValueError
        print(f"python -m simulator.scene_export: {exc}", file=sys.stderr)
        return 2
    path = export_scene(config, args.output)
    print(f"wrote {path} ({path.stat().st_size} bytes): serve it with --asset-dir {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
