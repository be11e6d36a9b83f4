"""docker-compose.yml and the Dockerfile, checked without a Docker engine.

(a) the compose file validates with docker compose's own validator (`docker compose config`
or Debian's `docker-compose` 1.29, which checks the compose-spec JSON schema); (b) every
service's command line, environment and health check run as local processes and make a
working pipeline; (c) the services run exactly `riverbridge up`'s command lines.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Literal

import pytest

from clients.stack.launcher import (
    GUIDANCE_TOPICS,
    MALLOC_ENV,
    NAVIGATION_TOPICS,
    SIMULATOR_TOPICS,
    LaunchConfig,
    stack_components,
)
from tests.child_process import Running, free_port

from .compose_support import (
    COMPOSE_FILE,
    HOST_COMPOSE_FILE,
    REPO_ROOT,
    dockerfile_env,
    dockerfile_stages,
    healthcheck_command,
    load_compose,
    localize,
    service_env,
)
from .sensor_data import map_marking_a_water_obstacle

DEFAULTS = load_compose()
SERVICES = DEFAULTS["services"]
HEALTHY_TIMEOUT_S = 180.0


def compose_validator() -> list[str] | None:
    """`docker compose` (v2 plugin) if it works here, else `docker-compose`, else None."""
    docker = shutil.which("docker")
    if (
        docker
        and subprocess.run(
            [docker, "compose", "version"], capture_output=True, timeout=60
        ).returncode
        == 0
    ):
        return [docker, "compose"]
    legacy = shutil.which("docker-compose")
    return [legacy] if legacy else None


VALIDATOR = compose_validator()


def validate(path: Path) -> subprocess.CompletedProcess[str]:
    assert VALIDATOR is not None, "no compose validator: run scripts/setup.sh (docker-compose)"
    return subprocess.run(
        [*VALIDATOR, "-f", str(path), "config", "-q"],
        cwd=path.parent,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize("path", [COMPOSE_FILE, HOST_COMPOSE_FILE], ids=lambda p: p.name)
def test_compose_file_validates(path: Path) -> None:
    result = validate(path)
    assert result.returncode == 0, result.stderr


def test_the_validator_rejects_a_broken_copy(tmp_path: Path) -> None:
    """Proves the validation above is a real check: one wrong condition fails it."""
    broken = tmp_path / "docker-compose.yml"
    broken.write_text(COMPOSE_FILE.read_text().replace("service_healthy", "service_happy", 1))
    result = validate(broken)
    assert result.returncode != 0
    assert "service_happy" in result.stderr


def expected_commands(encoding: Literal["json", "cbor"]) -> dict[str, list[str]]:
    """What `riverbridge up` would run with the compose settings, with `python` as argv[0]."""
    config = LaunchConfig(
        host="0.0.0.0",
        port=9090,
        encoding=encoding,
        sim_config=Path("/config/sim.toml"),
        nav_config=Path("/config/nav.toml"),
        autopilot=True,  # the compose profile "autopilot"
        guidance_config=Path("/config/guidance.toml"),
    )
    bridge, sim, nav, guide = stack_components(config)
    commands = {"bridge": bridge, "simulator": sim, "navigation": nav, "guidance": guide}
    return {name: ["python", *c.argv("ws://bridge:9090")[1:]] for name, c in commands.items()}


@pytest.mark.parametrize("encoding", ["cbor", "json"])
def test_services_run_the_same_command_lines_as_up(encoding: Literal["json", "cbor"]) -> None:
    services = load_compose({"RIVERBRIDGE_ENCODING": encoding})["services"]
    assert {name: services[name]["command"] for name in services} == expected_commands(encoding)


def test_services_restart_wait_for_a_healthy_bridge_and_read_mounted_config() -> None:
    assert set(SERVICES) == {"bridge", "simulator", "navigation", "guidance"}
    for name, service in SERVICES.items():
        assert service["restart"] == "unless-stopped", name
        assert "./config:/config:ro" in service["volumes"], name
        assert service["healthcheck"]["test"][0] == "CMD", name
    assert SERVICES["guidance"]["profiles"] == ["autopilot"]  # only when asked for
    for name in ("simulator", "navigation", "guidance"):
        assert SERVICES[name]["depends_on"] == {"bridge": {"condition": "service_healthy"}}
    assert SERVICES["bridge"]["ports"] == ["9090:9090"]


def test_health_checks_require_every_published_topic() -> None:
    for name, topics in (
        ("simulator", SIMULATOR_TOPICS),
        ("navigation", NAVIGATION_TOPICS),
        ("guidance", GUIDANCE_TOPICS),
    ):
        words = healthcheck_command(SERVICES[name])
        required = {words[i + 1] for i, word in enumerate(words) if word == "--topic"}
        assert required == set(topics), name
    assert "/version" in " ".join(healthcheck_command(SERVICES["bridge"]))


def test_image_environment_is_the_launchers() -> None:
    env = dockerfile_env()
    assert {key: env[key] for key in MALLOC_ENV} == dict(MALLOC_ENV)
    assert env["PYTHONUNBUFFERED"] == "1"
    assert "ARG BASE_IMAGE=python:3.11-slim" in dockerfile_stages()["global"]


def test_image_serves_the_dashboard_as_a_user_without_the_build_settings() -> None:
    """The final stage takes the venv and web/dist from the build stages, never the build
    configuration (pip.conf, npmrc, CA bundle), and drops root."""
    image = dockerfile_stages()[""]
    copies = [line for line in image if line.startswith("COPY ")]
    assert copies == [
        "COPY --from=install /opt/riverbridge /opt/riverbridge",
        "COPY --from=dashboard /web/dist /opt/riverbridge/web",
        "COPY config /config",
    ]
    assert dockerfile_env()["RIVERBRIDGE_WEB_ROOT"] == "/opt/riverbridge/web"
    assert any(line.startswith("USER ") and line.split()[1] != "root" for line in image)
    assert image[-1].startswith("CMD ")
    for stage in ("dashboard", "install-bridge"):
        assert "COPY docker/build-config/ /build-config/" in dockerfile_stages()[stage]


def test_build_args_name_the_bases_with_the_dockerfile_defaults() -> None:
    args = SERVICES["bridge"]["build"]["args"]
    globals_ = dockerfile_stages()["global"]
    for name, value in args.items():
        assert f"ARG {name}={value}" in globals_, name


def test_host_network_file_is_the_compose_file_on_loopback() -> None:
    """docker-compose.host.yml differs from docker-compose.yml only in networking: host
    network, no published ports, and `bridge:9090` read as 127.0.0.1:$RIVERBRIDGE_PORT."""
    port = 9191
    env = {"RIVERBRIDGE_PORT": str(port)}
    main, host = load_compose(env)["services"], load_compose(env, HOST_COMPOSE_FILE)["services"]
    assert set(host) == set(main)
    for name, service in main.items():
        moved = dict(host[name])
        assert moved.pop("network_mode") == "host", name
        build = dict(moved.pop("build"))
        assert build.pop("network") == "host", name
        assert build == service["build"], name
        expected = {key: value for key, value in service.items() if key not in ("ports", "build")}
        as_local = {
            "command": localize(service["command"], port, Path("/config"), python="python"),
            "healthcheck": {
                **service["healthcheck"],
                "test": [
                    "CMD",
                    *localize(healthcheck_command(service), port, Path("/config"), python="python"),
                ],
            },
        }
        assert moved == {**expected, **as_local}, name


def test_shipped_example_configs_load_as_the_defaults() -> None:
    from navigation.config import NavigationConfig
    from navigation.config import load_config as load_nav
    from simulator.config import SimConfig
    from simulator.config import load_config as load_sim

    assert load_sim(REPO_ROOT / "config" / "sim.toml") == SimConfig()
    assert load_nav(REPO_ROOT / "config" / "nav.toml") == NavigationConfig()
    from guidance.config import GuidanceConfig
    from guidance.config import load_config as load_guidance

    assert load_guidance(REPO_ROOT / "config" / "guidance.toml") == GuidanceConfig()


def wait_healthy(
    name: str, command: list[str], env: dict[str, str], watched: list[Running]
) -> None:
    """Run ``command`` (a service's health check) until it exits 0, like docker does."""
    deadline = time.monotonic() + HEALTHY_TIMEOUT_S
    while True:
        result = subprocess.run(
            command, cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=120
        )
        if result.returncode == 0:
            return
        for process in watched:
            assert process.process.poll() is None, f"{process.argv} died:\n{process.text()}"
        assert time.monotonic() < deadline, (
            f"{name} not healthy after {HEALTHY_TIMEOUT_S} s: {result.stderr}\n"
            + "\n".join(process.text() for process in watched)
        )
        time.sleep(1.0)


@pytest.mark.slow
async def test_compose_services_as_local_processes_make_a_working_pipeline() -> None:
    port = free_port()
    config_dir = REPO_ROOT / "config"
    started: list[Running] = []
    try:
        for name in ("bridge", "simulator", "navigation"):  # depends_on order
            service = SERVICES[name]
            env = service_env(service)
            started.append(Running(localize(service["command"], port, config_dir), env))
            wait_healthy(
                name, localize(healthcheck_command(service), port, config_dir), env, started
            )
        # sensor data end to end: the map marks an obstacle the simulator's truth names
        await map_marking_a_water_obstacle(f"ws://127.0.0.1:{port}")
    finally:
        codes = {process.argv[2]: process.stop() for process in reversed(started)}
    assert codes == {"bridge": 0, "simulator": 0, "navigation": 0}, "\n".join(
        process.text() for process in started
    )


def test_localize_swaps_service_names_ports_and_config(tmp_path: Path) -> None:
    words = [
        "python",
        "-m",
        "simulator",
        "--bridge",
        "ws://bridge:9090",
        "--config",
        "/config/sim.toml",
    ]
    assert localize(words, 4242, tmp_path) == [
        sys.executable,
        "-m",
        "simulator",
        "--bridge",
        "ws://127.0.0.1:4242",
        "--config",
        str(tmp_path / "sim.toml"),
    ]
    bridge = ["python", "-m", "bridge", "--host", "0.0.0.0", "--port", "9090"]
    assert localize(bridge, 4242, tmp_path)[3:] == ["--host", "127.0.0.1", "--port", "4242"]


def test_the_bridge_target_is_the_light_install_with_the_dashboard() -> None:
    """`docker build --target bridge`: the venv of the stage that installs only the base
    dependencies and schemas, bridge and clients, the dashboard, a non-root user."""
    stages = dockerfile_stages()
    install = stages["install-bridge"]
    assert "python3 requirements.py > requirements.txt" in " ".join(install)
    copied = {line.split()[1] for line in install if line.startswith("COPY ")}
    assert not copied & {"simulator", "navigation"}, copied
    bridge = stages["bridge"]
    assert bridge[0] == "FROM runtime AS bridge"
    assert [line for line in bridge if line.startswith("COPY ")] == [
        "COPY --from=install-bridge /opt/riverbridge /opt/riverbridge",
        "COPY --from=dashboard /web/dist /opt/riverbridge/web",
    ]
    assert any(line.startswith("USER ") and line.split()[1] != "root" for line in bridge)
    assert bridge[-1] == stages[""][-1], "both images start the bridge the same way"
