"""The compiled hot path (`schemas.runtime.native`): used when current, the same program as the
sources, and never used when it does not match them."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from schemas.runtime import native

ROOT = Path(__file__).resolve().parent.parent


def probe(**env: str) -> list[str]:
    """The output of `tests/native_probe.py` in a fresh interpreter."""
    run_env = {k: v for k, v in os.environ.items() if k != native.PURE_ENV} | env
    done = subprocess.run(
        [sys.executable, "-m", "tests.native_probe"],
        cwd=ROOT,
        env=run_env,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    return done.stdout.splitlines()


def test_setup_built_the_hot_path_and_the_bridge_runs_it() -> None:
    """scripts/setup.sh builds it (`scripts/build_native.py`): every listed module then loads
    from build/native, in a new process as in the bridge's."""
    assert native.stale_reason() is None, native.stale_reason()
    compiled = probe()[0].removeprefix("compiled: ").split(",")
    assert compiled == list(native.MODULES)


def test_compiled_and_pure_modules_answer_every_frame_alike() -> None:
    """Good and bad JSON and CBOR ops through the core: the same frames, byte for byte."""
    compiled, pure = probe(), probe(**{native.PURE_ENV: "1"})
    assert compiled[0] != "compiled: " and pure[0] == "compiled: "
    assert len(compiled) > 10  # publishes in three encodings, answers, refusals
    assert compiled[1:] == pure[1:]


def test_a_build_that_does_not_match_the_sources_is_not_used(tmp_path: Path) -> None:
    """An edited module, another interpreter or a damaged manifest: the sources run."""
    root, build = tmp_path / "src", tmp_path / "build"
    for module in native.MODULES:
        target = native.source_path(module, root)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(native.source_path(module), target)
    build.mkdir()
    assert native.stale_reason(build, root) == "not built"
    manifest = {"interpreter": native.interpreter_tag(), "sources": native.source_hashes(root)}
    (build / native.MANIFEST).write_text(json.dumps(manifest))
    assert native.stale_reason(build, root) is None

    edited = native.source_path("bridge.link", root)
    edited.write_text(edited.read_text() + "\n# edited\n")
    assert native.stale_reason(build, root) == "sources changed since the build: bridge.link"
    manifest["sources"] = native.source_hashes(root)
    (build / native.MANIFEST).write_text(json.dumps(manifest | {"interpreter": "cpython-27"}))
    assert "another interpreter" in (native.stale_reason(build, root) or "")
    (build / native.MANIFEST).write_text("{")
    assert "unreadable manifest" in (native.stale_reason(build, root) or "")
