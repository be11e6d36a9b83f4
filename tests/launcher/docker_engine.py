"""A Docker engine, base images and a build context for running docker-compose.yml for real.

No image registry is reachable here, so the Dockerfile's two bases are built locally:
``riverbridge-base:local`` is Debian (the release and mirror apt uses on this machine) with
python3 and its venv module, made by ``debootstrap --variant=minbase`` and ``docker import``;
``riverbridge-node:local`` adds this machine's Node.js (Debian bookworm's Node.js 18 is too old
for Vite 7). The debootstrap tarball is cached (``$RIVERBRIDGE_DOCKER_CACHE``, default
``~/.cache/riverbridge/docker``) and images stay in the engine, so a second run builds nothing.
The engine is started (``dockerd --bridge=none``: no container network, host networking only)
when none runs and this process is root.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
import ssl
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from tests.child_process import REPO_ROOT

BASE_IMAGE = "riverbridge-base:local"
NODE_IMAGE = "riverbridge-node:local"
BASE_PACKAGES = ("python3", "python3-venv", "ca-certificates")
NODE_MIN_VERSION = (20, 19)  # web/package.json engines, Vite 7
ENGINE_START_S = 60.0
CONTEXT_EXCLUDED = ("tests/", "benchmarks/")


class EngineUnavailable(Exception):
    """Why no Docker engine can run here: a part is not installed or not allowed (the test is
    skipped with this text, which pytest's summary shows)."""


class EngineFailed(Exception):
    """The engine is installed and could have run but did not start: a failure, with its log
    (never a skip: a skip is green)."""


def cache_dir() -> Path:
    configured = os.environ.get("RIVERBRIDGE_DOCKER_CACHE")
    folder = Path(configured) if configured else Path.home() / ".cache/riverbridge/docker"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def run(
    *argv: str, timeout_s: float = 600.0, check: bool = True, **kwargs: object
) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(argv, capture_output=True, text=True, timeout=timeout_s, **kwargs)  # type: ignore[call-overload]
    if check and result.returncode != 0:
        raise RuntimeError(
            f"{' '.join(argv)} exited {result.returncode}:\n{result.stdout}\n{result.stderr}"
        )
    return result


def engine_answers() -> bool:
    docker = shutil.which("docker")
    return docker is not None and run(docker, "info", timeout_s=30, check=False).returncode == 0


@contextlib.contextmanager
def docker_engine() -> Iterator[None]:
    """A running engine for the block: the one already running, or one started here (and
    stopped after). Raises :class:`EngineUnavailable` with the reason when a part is missing
    or not allowed, :class:`EngineFailed` with dockerd's log when it could start and did not.

    Test sessions on one machine take turns (a lock file): a session that started dockerd
    stops it at the end, which must not pull the engine from under another session's build.
    """
    with open(cache_dir() / "engine.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        with _engine():
            yield


@contextlib.contextmanager
def _engine() -> Iterator[None]:
    if shutil.which("docker") is None:
        raise EngineUnavailable("no docker client (scripts/setup.sh installs docker.io)")
    if engine_answers():
        yield
        return
    dockerd = shutil.which("dockerd")
    if dockerd is None:
        raise EngineUnavailable("no Docker engine runs and dockerd is not installed")
    if os.geteuid() != 0:
        raise EngineUnavailable("no Docker engine runs and only root can start dockerd")
    log_path = cache_dir() / "dockerd.log"
    with open(log_path, "wb") as log:
        daemon = subprocess.Popen(
            [dockerd, "--bridge=none", "--iptables=false", "--ip6tables=false"],
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
    try:
        deadline = time.monotonic() + ENGINE_START_S
        while not engine_answers():
            if daemon.poll() is not None or time.monotonic() > deadline:
                tail = log_path.read_text(errors="replace")[-2000:]
                raise EngineFailed(
                    f"dockerd is installed but did not start within {ENGINE_START_S:g} s "
                    f"(exit {daemon.poll()}); the end of {log_path}:\n{tail}"
                )
            time.sleep(0.5)
        yield
    finally:
        daemon.terminate()
        try:
            daemon.wait(timeout=30)
        except subprocess.TimeoutExpired:
            daemon.kill()
            daemon.wait()


def compose_command() -> list[str]:
    """``docker compose`` (v2 plugin) where it works, else Debian's ``docker-compose``."""
    docker = shutil.which("docker")
    if docker and run(docker, "compose", "version", check=False, timeout_s=60).returncode == 0:
        return [docker, "compose"]
    legacy = shutil.which("docker-compose")
    if legacy is None:
        raise EngineUnavailable("neither `docker compose` nor docker-compose is installed")
    return [legacy]


def image_exists(name: str) -> bool:
    return run("docker", "image", "inspect", name, check=False, timeout_s=60).returncode == 0


# --------------------------------------------------------------------------- base images


def apt_source() -> tuple[str, str]:
    """(suite, mirror URI) of the Debian release this machine's apt uses."""
    release = Path("/etc/os-release").read_text()
    suite = re.search(r"^VERSION_CODENAME=(\w+)", release, re.M)
    if suite is None:
        raise EngineUnavailable("not a Debian release (no VERSION_CODENAME in /etc/os-release)")
    sources = "\n".join(
        path.read_text()
        for path in [
            *Path("/etc/apt").glob("sources.list"),
            *Path("/etc/apt/sources.list.d").glob("*"),
        ]
        if path.is_file()
    )
    # deb822 stanzas (URIs: before Suites:, no blank line between) or one-line entries
    for pattern in (
        r"^URIs:\s*(\S+)[^\n]*\n(?:[^\n]+\n)*?"
        r"Suites:(?:[ \t]+\S+)*?[ \t]+%s[ \t]*(?:\s|$)",
        r"^deb\s+(?:\[[^\]]*\]\s+)?(\S+)\s+%s\s",
    ):
        match = re.search(pattern % suite[1], sources, re.M)
        if match:
            return suite[1], match[1]
    raise EngineUnavailable(f"no apt source for {suite[1]} in /etc/apt")


def base_tarball() -> Path:
    """The debootstrapped root file system as a tarball, made once and cached."""
    suite, mirror = apt_source()
    tarball = cache_dir() / f"debian-{suite}-minbase-{'-'.join(BASE_PACKAGES)}.tar"
    if tarball.is_file():
        return tarball
    debootstrap = shutil.which("debootstrap")
    if debootstrap is None:
        raise EngineUnavailable("debootstrap is not installed (scripts/setup.sh installs it)")
    with tempfile.TemporaryDirectory(dir=cache_dir()) as scratch:
        root = Path(scratch) / "root"
        run(
            debootstrap,
            "--variant=minbase",
            f"--include={','.join(BASE_PACKAGES)}",
            suite,
            str(root),
            mirror,
            timeout_s=1200,
        )
        for leftovers in ("var/cache/apt/archives", "var/lib/apt/lists"):
            for item in (root / leftovers).glob("*"):
                if item.is_file():
                    item.unlink()
        partial = tarball.with_suffix(".partial")
        run("tar", "-C", str(root), "-cf", str(partial), ".", timeout_s=600)
        partial.rename(tarball)
    return tarball


def node_version() -> tuple[int, int] | None:
    node = shutil.which("node")
    if node is None:
        return None
    match = re.match(r"v(\d+)\.(\d+)", run(node, "--version", check=False).stdout)
    return (int(match[1]), int(match[2])) if match else None


def build_bases() -> tuple[str, str]:
    """The Python and Node.js base image names, built when missing."""
    if not image_exists(BASE_IMAGE):
        run("sh", "-c", f"docker import - {BASE_IMAGE} < '{base_tarball()}'", timeout_s=600)
    if not image_exists(NODE_IMAGE):
        version = node_version()
        if version is None or version < NODE_MIN_VERSION:
            raise EngineUnavailable(
                f"the dashboard build needs Node.js >= "
                f"{'.'.join(map(str, NODE_MIN_VERSION))}, found {version}"
            )
        node = Path(shutil.which("node") or "").resolve()
        npm_root = Path(run("npm", "root", "-g").stdout.strip())
        with tempfile.TemporaryDirectory() as context:
            run(
                "tar",
                "-C",
                "/",
                "-cf",
                f"{context}/node.tar",
                str(node)[1:],
                str(npm_root / "npm")[1:],
            )
            Path(context, "Dockerfile").write_text(
                f"FROM {BASE_IMAGE}\nADD node.tar /\nENV PATH={node.parent}:$PATH\n"
                f"RUN ln -sf {npm_root}/npm/bin/npm-cli.js /usr/local/bin/npm\n"
            )
            run(
                "docker",
                "build",
                "--network",
                "host",
                "-t",
                NODE_IMAGE,
                context,
                env={**os.environ, "DOCKER_BUILDKIT": "0"},
            )
    return BASE_IMAGE, NODE_IMAGE


# --------------------------------------------------------------------------- build context


def context_files() -> list[str]:
    """The checkout's files (tracked or new, not git-ignored) a compose build could read."""
    listed = run(
        "git", "ls-files", "--cached", "--others", "--exclude-standard", "-z", cwd=REPO_ROOT
    ).stdout.split("\0")
    return [
        name
        for name in listed
        if name and not name.startswith(CONTEXT_EXCLUDED) and (REPO_ROOT / name).is_file()
    ]


def pip_settings() -> dict[str, str]:
    """This machine's pip index settings that a container can use (http/https only)."""
    listed = run("python3", "-m", "pip", "config", "list", check=False).stdout
    settings: dict[str, str] = {}
    for line in listed.splitlines():
        key, _, value = line.partition("=")
        name = key.rsplit(".", 1)[-1]
        if name in ("index-url", "extra-index-url", "trusted-host", "timeout", "default-timeout"):
            urls = [
                v
                for v in value.strip("'\"").split()
                if "://" not in v or v.startswith(("http://", "https://"))
            ]
            if urls:
                settings[name] = " ".join(urls)
    for variable, name in (
        ("PIP_INDEX_URL", "index-url"),
        ("PIP_EXTRA_INDEX_URL", "extra-index-url"),
    ):
        if os.environ.get(variable, "").startswith(("http://", "https://")):
            settings[name] = os.environ[variable]
    return settings


def ca_bundle() -> Path | None:
    for candidate in (
        os.environ.get("PIP_CERT"),
        os.environ.get("SSL_CERT_FILE"),
        ssl.get_default_verify_paths().cafile,
        "/etc/ssl/certs/ca-certificates.crt",
    ):
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    return None


def write_build_config(folder: Path) -> None:
    """This machine's package-index settings and CA bundle as docker/build-config/ files."""
    folder.mkdir(parents=True, exist_ok=True)
    bundle = ca_bundle()
    pip_lines = ["[global]", *(f"{k} = {v}" for k, v in pip_settings().items())]
    registry = run("npm", "config", "get", "registry", check=False).stdout.strip()
    npm_lines = [f"registry={registry}"] if registry.startswith("http") else []
    if bundle is not None:
        shutil.copyfile(bundle, folder / "ca-certificates.crt")
        pip_lines.append("cert = /build-config/ca-certificates.crt")
        npm_lines.append("cafile=/build-config/ca-certificates.crt")
    (folder / "pip.conf").write_text("\n".join(pip_lines) + "\n")
    (folder / "npmrc").write_text("\n".join(npm_lines) + "\n")


def make_context(target: Path) -> Path:
    """A copy of the checkout as a compose project folder, with this machine's build
    settings in docker/build-config/ (the checkout itself is left alone)."""
    for name in context_files():
        destination = target / name
        destination.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO_ROOT / name, destination)
    write_build_config(target / "docker" / "build-config")
    return target
