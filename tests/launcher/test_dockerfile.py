"""The Dockerfile's install step, reproduced without Docker: build the package from exactly
the files its COPY lines put in the image (minus .dockerignore), install it away from the
checkout, and run the bridge and the health check from that installation. This catches a
missing COPY, package data left out of the wheel, or a .dockerignore that drops source.
The dependencies come from this machine (``--no-deps``); the build backend comes from PyPI,
as in ``docker build``."""

from __future__ import annotations

import fnmatch
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.child_process import REPO_ROOT, Running

from .compose_support import dockerfile_copies, dockerignore_patterns

pytestmark = pytest.mark.slow


def ignored(relative: Path, patterns: list[str]) -> bool:
    """Docker's .dockerignore matching, for the pattern forms our file uses: a pattern
    matches a path from the context's root (``*`` stays within one name, a matching folder
    takes its contents along); ``**/`` in front lets it match at any depth."""
    parts = relative.parts
    for pattern in patterns:
        anywhere = pattern.startswith("**/")
        wanted = pattern.removeprefix("**/").split("/")
        starts = range(len(parts)) if anywhere else range(1)
        if any(
            len(parts) - start >= len(wanted)
            and all(
                fnmatch.fnmatch(part, want)
                for part, want in zip(parts[start : start + len(wanted)], wanted, strict=True)
            )
            for start in starts
        ):
            return True
    return False


def build_context(target: Path) -> None:
    """Copy what the Dockerfile's COPY lines would see into ``target``."""
    patterns = dockerignore_patterns()
    for source in dockerfile_copies():
        origin = REPO_ROOT / source
        files = [origin] if origin.is_file() else sorted(origin.rglob("*"))
        files = [path for path in files if path.is_file()]
        for path in files:
            relative = path.relative_to(REPO_ROOT)
            if not ignored(relative, patterns):
                (target / relative).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(path, target / relative)


def source_packages() -> list[str]:
    """Dotted names of the checkout's packages and subpackages (folders with __init__.py)."""
    tops = ("bridge", "clients", "navigation", "schemas", "simulator")
    return sorted(
        ".".join(init.parent.relative_to(REPO_ROOT).parts)
        for top in tops
        for init in (REPO_ROOT / top).rglob("__init__.py")
    )


def run(*argv: str, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, f"{' '.join(argv)}:\n{result.stdout}\n{result.stderr}"
    return result


def test_dockerignore_keeps_sources_and_drops_caches() -> None:
    patterns = dockerignore_patterns()
    assert ignored(Path("bridge/__pycache__/core.cpython-311.pyc"), patterns)
    assert ignored(Path("tests/launcher/test_compose.py"), patterns)
    assert not ignored(Path("schemas/interfaces/riverbridge_msgs/msg/RadarImage.msg"), patterns)
    assert not ignored(Path("bridge/core.py"), patterns)
    # `report*` is the report's output at the top, not the report's package
    assert ignored(Path("report/bytes.png"), patterns)
    assert not ignored(Path("clients/report/cli.py"), patterns)


def test_the_image_install_step_yields_a_working_package(tmp_path: Path) -> None:
    context, wheels, site, elsewhere = (
        tmp_path / name for name in ("context", "wheels", "site", "elsewhere")
    )
    for folder in (context, elsewhere):
        folder.mkdir()
    build_context(context)
    env = {
        "PATH": "/usr/bin:/bin",
        "PYTHONPATH": str(site),
        "PYTHONNOUSERSITE": "1",
        "PYTHONUNBUFFERED": "1",
    }
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    # With build isolation, as `pip install .` in the image: pip fetches the build backend
    # pyproject.toml asks for (setuptools>=68, wheel) from PyPI.
    run(
        *pip,
        "wheel",
        "--no-deps",
        "--wheel-dir",
        str(wheels),
        str(context),
        cwd=elsewhere,
        env={**env, "PYTHONPATH": ""},
    )
    run(
        *pip,
        "install",
        "--no-deps",
        "--target",
        str(site),
        *map(str, wheels.glob("*.whl")),
        cwd=elsewhere,
        env=env,
    )
    # Every package and subpackage of the checkout must come from the installation: the
    # shared editable install would otherwise supply a subpackage the wheel left out.
    packages = ["riverbridge", *source_packages()]
    probe = (
        "import importlib, sys\n"
        "from schemas.registry import TypeRegistry\n"
        "for name in sys.argv[1:]:\n"
        "    print(importlib.import_module(name).__file__)\n"
        "TypeRegistry.with_defaults().message('riverbridge_msgs/msg/RadarImage')\n"
    )
    located = run(sys.executable, "-c", probe, *packages, cwd=elsewhere, env=env).stdout.split()
    outside = [
        (name, path)
        for name, path in zip(packages, located, strict=True)
        if not path.startswith(str(site))
    ]
    assert len(located) == len(packages) and not outside, outside
    bridge = Running(
        [sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", "0"],
        env=env,
        cwd=elsewhere,
    )
    try:
        port = bridge.wait_for_line(r"listening on ws://127\.0\.0\.1:(?P<port>\d+)")["port"]
        run(
            sys.executable,
            "-m",
            "clients.stack.healthcheck",
            "--bridge",
            f"ws://127.0.0.1:{port}",
            "--topic",
            "/rosout",
            cwd=elsewhere,
            env=env,
        )
        assert bridge.stop() == 0, bridge.text()
    finally:
        bridge.kill_session()
