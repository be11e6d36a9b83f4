"""`fetchAsset` from an allow-list: files under the folders given with `--asset-dir`.

A URI `package://<folder name>/<relative path>` names a file of the configured folder with
that name; the file must lie inside the folder (no `..`, no symlink out), have a mesh, texture
or robot-description suffix and be at most `MAX_ASSET_BYTES`. Anything else is an error
answer naming the URI, never a read outside the list.
"""

from __future__ import annotations

import urllib.parse
from collections.abc import Iterable
from pathlib import Path

from bridge.foxglove import wire
from schemas.safety import echo

SCHEME = "package://"
SUFFIXES = frozenset(
    [
        ".dae",
        ".fbx",
        ".glb",
        ".gltf",
        ".jpeg",
        ".jpg",
        ".mtl",
        ".obj",
        ".png",
        ".stl",
        ".tif",
        ".tiff",
        ".urdf",
        ".webp",
        ".xacro",
        ".bin",
    ]
)
MAX_ASSET_BYTES = 64 * 1024 * 1024  # the bridge's inbound frame limit: a whole terrain mesh


class AssetDirectory:
    """The allow-listed folders by name."""

    def __init__(self, folders: Iterable[Path]) -> None:
        self.roots = {folder.resolve().name: folder.resolve() for folder in folders}

    def resolve(self, uri: str) -> Path | str:
        """The file `uri` names, or why it may not be read."""
        if not uri.startswith(SCHEME):
            return f"only {SCHEME}<folder>/<path> URIs are served"
        folder, _, relative = urllib.parse.unquote(uri[len(SCHEME) :]).partition("/")
        root = self.roots.get(folder)
        if root is None:
            return f"{echo(folder, 60)} is not an asset folder of this bridge (--asset-dir)"
        if "\x00" in relative or "\\" in relative:
            return "bad characters in the path"
        path = (root / relative).resolve()
        if not path.is_relative_to(root) or path.suffix.lower() not in SUFFIXES:
            return "not an allowed asset"
        if not path.is_file():
            return "no such asset"
        if path.stat().st_size > MAX_ASSET_BYTES:
            return f"larger than {MAX_ASSET_BYTES} bytes"
        return path

    def answer(self, request: wire.FetchAsset) -> bytes:
        """The `FetchAssetResponse` frame for `request`."""
        found = self.resolve(request.uri)
        if isinstance(found, str):
            return wire.fetch_asset_response(
                request.request_id, None, f"{echo(request.uri, 120)}: {found}"
            )
        try:
            return wire.fetch_asset_response(request.request_id, found.read_bytes())
        except OSError as exc:
            return wire.fetch_asset_response(request.request_id, None, f"unreadable: {exc}")
