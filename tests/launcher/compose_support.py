"""Read docker-compose.yml and the Dockerfile the way docker would, and turn a service into a
local process: its command line, environment and health check, with the service's DNS name
and ports swapped for loopback and a free port."""

from __future__ import annotations

import os
import re
import shlex
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from tests.child_process import REPO_ROOT

COMPOSE_FILE = REPO_ROOT / "docker-compose.yml"
HOST_COMPOSE_FILE = REPO_ROOT / "docker-compose.host.yml"
DOCKERFILE = REPO_ROOT / "Dockerfile"
BRIDGE_PORT = 9090  # the port inside the compose network
CONTAINER_CONFIG_DIR = "/config"

_VARIABLE = re.compile(r"\$\{(?P<name>\w+)(?::-(?P<default>[^}]*))?\}")


def interpolate(value: Any, env: Mapping[str, str]) -> Any:
    """Compose's ``${VAR}`` / ``${VAR:-default}`` substitution, applied to every string."""
    if isinstance(value, str):
        return _VARIABLE.sub(lambda m: env.get(m["name"]) or (m["default"] or ""), value)
    if isinstance(value, list):
        return [interpolate(item, env) for item in value]
    if isinstance(value, dict):
        return {key: interpolate(item, env) for key, item in value.items()}
    return value


def load_compose(env: Mapping[str, str] | None = None, path: Path = COMPOSE_FILE) -> dict[str, Any]:
    """docker-compose.yml (or ``path``) with YAML merge keys resolved and variables from
    ``env``."""
    return interpolate(yaml.safe_load(path.read_text()), env or {})


def dockerfile_env() -> dict[str, str]:
    """The ``ENV key=value ...`` settings of the Dockerfile (continuation lines joined)."""
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    env: dict[str, str] = {}
    for line in text.splitlines():
        if line.startswith("ENV "):
            for pair in shlex.split(line[4:]):
                key, _, value = pair.partition("=")
                env[key] = value
    return env


def dockerfile_stages() -> dict[str, list[str]]:
    """The Dockerfile's instructions (continuation lines joined) per stage; stages are named by
    ``AS name``, the last one (the image) is ``""``; ``ARG``s before the first ``FROM`` are
    stage ``"global"``."""
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    stages: dict[str, list[str]] = {"global": []}
    current = "global"
    for line in text.splitlines():
        if line.startswith("FROM "):
            words = line.split()
            current = words[3] if len(words) >= 4 and words[2].upper() == "AS" else ""
            stages[current] = []
        if line and not line.startswith("#"):
            stages[current].append(line)
    return stages


def dockerfile_copies() -> list[str]:
    """Sources of the ``COPY`` lines of the ``install`` stage and the ``install-bridge`` stage
    it builds on, which feed ``pip install .`` (not the build configuration, which goes to an
    absolute path)."""
    sources: list[str] = []
    stages = dockerfile_stages()
    for line in [*stages["install-bridge"], *stages["install"]]:
        if line.startswith("COPY ") and "--from=" not in line:
            *parts, destination = shlex.split(line[5:])
            if not destination.startswith("/"):
                sources.extend(parts)
    return sources


def dockerignore_patterns() -> list[str]:
    lines = (REPO_ROOT / ".dockerignore").read_text().splitlines()
    return [line.strip() for line in lines if line.strip() and not line.startswith("#")]


def localize(
    words: list[str], port: int, config_dir: Path, python: str = sys.executable
) -> list[str]:
    """A container command line as a local one: ``python`` is this interpreter (or
    ``python``), the ``bridge`` host and port 9090 are loopback and ``port``, ``/config`` is
    ``config_dir``."""
    address = f"127.0.0.1:{port}"
    local = []
    for word in words:
        word = word.replace(f"bridge:{BRIDGE_PORT}", address)
        word = word.replace(f"127.0.0.1:{BRIDGE_PORT}", address)
        word = word.replace("0.0.0.0", "127.0.0.1")
        if word.startswith(CONTAINER_CONFIG_DIR + "/"):
            word = str(config_dir / word.removeprefix(CONTAINER_CONFIG_DIR + "/"))
        local.append(word)
    if local[:1] == ["python"]:
        local[0] = python
    if "--port" in local and local[local.index("--port") + 1] == str(BRIDGE_PORT):
        local[local.index("--port") + 1] = str(port)
    return local


def service_env(service: Mapping[str, Any]) -> dict[str, str]:
    """The process environment a container of ``service`` gets: image ENV, then the
    service's ``environment``, on top of this machine's (for PATH and the checkout)."""
    env = dict(os.environ)
    env.update(dockerfile_env())
    extra = service.get("environment") or {}
    if isinstance(extra, list):
        extra = dict(item.split("=", 1) for item in extra)
    env.update({key: str(value) for key, value in extra.items()})
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT), env.get("PYTHONPATH")]))
    return env


def healthcheck_command(service: Mapping[str, Any]) -> list[str]:
    test = service["healthcheck"]["test"]
    assert test[0] == "CMD", f"healthcheck must be exec form, got {test!r}"
    return list(test[1:])
