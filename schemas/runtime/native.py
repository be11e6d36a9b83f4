"""The relay's hot path compiled by mypyc, run in place of its Python source when a build matches.

Most of the bridge's time per small message is Python's own cost per call and attribute, not
any one step (issue 21: ~160 calls per publish, none above 3 % of the time). mypyc compiles the
modules in `MODULES`, unchanged and type-checked, to C extensions (`scripts/build_native.py`,
run by `scripts/setup.sh`); measured in `benchmarks/relay.py`, the bridge then spends about a
third less CPU per relayed small message, less than a bare websockets relay spends.

The build lives in `build/native/` beside the packages, never next to the sources, where a
stale extension would shadow an edited module. Each package holding one of the modules asks
`native_first` for its search path: while the build's manifest names this interpreter and the
same hash of every listed source, the build's directory is searched before the sources;
otherwise (no build, any listed module edited, another Python, ``RIVERBRIDGE_PURE=1``) the
sources run as they always did, and that pure path is the reference the tests compare against.
It is all or nothing: the compiled modules call one another's classes directly.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.machinery
import json
import logging
import os
import sys
import sysconfig
from pathlib import Path
from types import ModuleType

logger = logging.getLogger("schemas.runtime.native")

#: What mypyc compiles: everything a small publish passes through, from the frame's bytes to
#: the subscribers' frames (the websocket reader subclasses websockets' class and stays Python).
MODULES: tuple[str, ...] = (
    "bridge.context",
    "bridge.core",
    "bridge.frame_scan",
    "bridge.inbound",
    "bridge.intake",
    "bridge.link",
    "bridge.ops.topics",
    "bridge.outgoing",
    "bridge.sendqueue",
    "bridge.sinks",
    "bridge.subscription",
    "bridge.tracing",
    "bridge.validation",
    "schemas.frames",
    "schemas.message",
    "schemas.safety",
    "schemas.tracing",
)

ROOT = Path(__file__).resolve().parents[2]  # the directory holding the packages
BUILD_DIR = ROOT / "build" / "native"
MANIFEST = "manifest.json"
PURE_ENV = "RIVERBRIDGE_PURE"
CHANGED = "sources changed since the build"  # the one reason worth a warning: a stale build


def source_path(module: str, root: Path = ROOT) -> Path:
    return root.joinpath(*module.split(".")).with_suffix(".py")


def source_hashes(root: Path = ROOT) -> dict[str, str]:
    """sha256 of each listed module's source, by module name."""
    return {m: hashlib.sha256(source_path(m, root).read_bytes()).hexdigest() for m in MODULES}


def interpreter_tag() -> str:
    """What an extension is built for: this Python's ABI and platform."""
    return f"{sys.implementation.cache_tag}-{sysconfig.get_platform()}"


def stale_reason(build_dir: Path = BUILD_DIR, root: Path = ROOT) -> str | None:
    """None if the build in `build_dir` may run in place of the sources; else why not."""
    try:
        manifest = json.loads((build_dir / MANIFEST).read_text())
    except FileNotFoundError:
        return "not built"
    except (OSError, ValueError) as exc:
        return f"unreadable manifest ({exc})"
    if not isinstance(manifest, dict) or manifest.get("interpreter") != interpreter_tag():
        return f"built for another interpreter (this one is {interpreter_tag()})"
    try:
        current = source_hashes(root)
    except OSError as exc:  # an installed copy without its sources
        return f"sources unreadable ({exc})"
    built = manifest.get("sources")
    if built != current:
        changed = sorted(
            m for m in MODULES if not isinstance(built, dict) or built.get(m) != current[m]
        )
        return f"{CHANGED}: {', '.join(changed) or 'the module list'}"
    return None


@functools.cache
def active_build() -> Path | None:
    """The build to run, or None for the pure-Python modules (the reason is logged once)."""
    if os.environ.get(PURE_ENV, "") not in ("", "0"):
        return None
    reason = stale_reason()
    if reason is not None:
        # No build, or one for another Python (a venv, an image), is a normal install; a
        # build older than the sources is news to whoever edited them.
        log = logger.warning if reason.startswith(CHANGED) else logger.debug
        log(
            "compiled hot path not used: %s; running the Python sources "
            "(python3 scripts/build_native.py rebuilds it)",
            reason,
        )
        return None
    if str(BUILD_DIR) not in sys.path:  # mypyc's shared library is a top-level module there
        sys.path.append(str(BUILD_DIR))
    return BUILD_DIR


def native_first(path: list[str], package: str) -> list[str]:
    """A package's `__path__` with the build's directory first when the build is used."""
    build = active_build()
    if build is not None:
        directory = build.joinpath(*package.split("."))
        if directory.is_dir() and str(directory) not in path:
            path.insert(0, str(directory))
    return path


def is_compiled(module: ModuleType) -> bool:
    """Whether `module` was loaded from a C extension rather than its source."""
    filename = getattr(module, "__file__", None) or ""
    return filename.endswith(tuple(importlib.machinery.EXTENSION_SUFFIXES))
