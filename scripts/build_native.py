"""Compile the relay's hot path (`schemas.runtime.native.MODULES`) with mypyc into build/native/.

Usage: python3 scripts/build_native.py [--force] [--check]

Does nothing when the build already matches the sources and this interpreter. Otherwise mypyc
type-checks and compiles the modules in a scratch directory (about two minutes on two cores)
and the result replaces build/native/ whole, with a manifest of the source hashes it was
made from; the packages pick it up on their next import (`schemas.runtime.native`). On any
failure the old build is removed, so the Python sources run, and the exit status is 1.
`--check` only says whether the build is current (exit 0) or not (exit 1, with the reason).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ["RIVERBRIDGE_PURE"] = "1"  # (this process must not load the build it replaces)

from schemas.runtime import native

# Run in a child: setuptools' setup() exits the process on errors.
_SETUP = """
import sys
from mypyc.build import mypycify
from setuptools import setup

paths, c_dir, lib_dir, temp_dir = sys.argv[1].split(","), sys.argv[2], sys.argv[3], sys.argv[4]
setup(
    name="riverbridge-native",
    ext_modules=mypycify(paths, opt_level="3", target_dir=c_dir, group_name="riverbridge_native"),
    script_args=["build_ext", "--build-lib", lib_dir, "--build-temp", temp_dir],
)
"""


def build(force: bool) -> int:
    reason = native.stale_reason()
    if reason is None and not force:
        print(f"build_native: {native.BUILD_DIR} is current")
        return 0
    print(f"build_native: compiling {len(native.MODULES)} modules with mypyc ({reason})")
    started = time.monotonic()
    hashes = native.source_hashes()
    shutil.rmtree(native.BUILD_DIR, ignore_errors=True)
    with tempfile.TemporaryDirectory(prefix="riverbridge-native-") as scratch:
        lib_dir = Path(scratch, "lib")
        paths = [str(native.source_path(m).relative_to(native.ROOT)) for m in native.MODULES]
        done = subprocess.run(
            [
                sys.executable,
                "-c",
                _SETUP,
                ",".join(paths),
                str(Path(scratch, "c")),
                str(lib_dir),
                str(Path(scratch, "temp")),
            ],
            cwd=native.ROOT,  # mypy reads pyproject.toml's settings from here
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            print(done.stdout[-4000:], done.stderr[-4000:], sep="\n", file=sys.stderr)
            print("build_native: mypyc failed; the Python sources run instead", file=sys.stderr)
            return 1
        manifest = {"interpreter": native.interpreter_tag(), "sources": hashes}
        (lib_dir / native.MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
        native.BUILD_DIR.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(lib_dir), native.BUILD_DIR)
    if native.source_hashes() != hashes:  # edited while compiling: this build is already stale
        print("build_native: sources changed during the build; run it again", file=sys.stderr)
        return 1
    print(f"build_native: built {native.BUILD_DIR} in {time.monotonic() - started:.0f} s")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--force", action="store_true", help="rebuild even if current")
    parser.add_argument("--check", action="store_true", help="only say whether it is current")
    args = parser.parse_args(argv)
    if args.check:
        reason = native.stale_reason()
        print(f"build_native: {'current' if reason is None else reason}")
        return 0 if reason is None else 1
    return build(args.force)


if __name__ == "__main__":
    sys.exit(main())
