"""How the compose engine test reports an engine that is missing or fails to start
(docker_engine.py): a missing part is a skip with its reason, an installed dockerd that does
not start is a failure carrying its log. The engine here is a stand-in executable on PATH
that behaves like a dockerd that cannot start; nothing is built."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from .docker_engine import EngineFailed, EngineUnavailable, docker_engine


def executable(folder: Path, name: str, body: str) -> None:
    path = folder / name
    path.write_text(f"#!/bin/sh\n{body}\n")
    path.chmod(0o755)


@pytest.fixture
def engine_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A PATH holding only a `docker` client whose `docker info` fails (no engine runs)."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    executable(bin_dir, "docker", "echo 'Cannot connect to the Docker daemon' >&2; exit 1")
    monkeypatch.setenv("PATH", f"{bin_dir}:/usr/bin:/bin")
    monkeypatch.setenv("RIVERBRIDGE_DOCKER_CACHE", str(tmp_path / "cache"))
    return bin_dir


@pytest.mark.skipif(os.geteuid() != 0, reason="only root may start dockerd (not root here)")
def test_a_dockerd_that_cannot_start_is_a_failure_with_its_log(engine_path: Path) -> None:
    executable(engine_path, "dockerd", "echo 'failed to start daemon: no cgroup mounts'; exit 1")
    with pytest.raises(EngineFailed, match=r"(?s)did not start.*no cgroup mounts"), docker_engine():
        pass


def test_no_dockerd_is_a_skip_that_says_so(engine_path: Path) -> None:
    if (Path("/usr/bin") / "dockerd").exists():
        pytest.skip("this machine has /usr/bin/dockerd on the PATH the test keeps")
    with pytest.raises(EngineUnavailable, match="dockerd is not installed"), docker_engine():
        pass
