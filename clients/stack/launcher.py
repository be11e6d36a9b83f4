"""Supervise the bridge, the simulator and the navigation service as three local processes.

Design (asyncio subprocesses, one event loop, no threads of our own; one child's process in
:mod:`clients.node.child`, the shared output in :mod:`clients.node.output`):

- Each component runs as ``sys.executable -m <package> ...`` in its own process group
  (``process_group=0``), so a terminal's Ctrl-C reaches only the supervisor, which then stops
  the clients before the bridge (no reconnect noise) and signals whole groups. On Linux each
  child also gets ``PR_SET_PDEATHSIG`` = SIGTERM, so even a SIGKILLed supervisor leaves nothing
  running (the kernel signals the children when the forking thread, our event-loop thread,
  dies).
- A child's stdout and stderr are one pipe, read line by line and written with a ``[name]``
  prefix (coloured only on a TTY) and a flush per line.
- Readiness is checked, never slept on: the bridge's ``listening on ws://HOST:PORT`` line (it
  also tells the port when ``--port 0``), then ``GET /version``; the simulator and navigation
  are ready when every topic they publish has a publisher in ``/rosapi/publishers``
  (:mod:`clients.stack.healthcheck`).
- Once the stack is ready a component that dies is restarted (``restart``: on-failure by
  default, :mod:`clients.stack.restarts`) with backoff while the others keep running; the bridge
  comes back on the same port and the clients reconnect to it. Each restart is logged and
  counted on the latched ``/riverbridge/restarts`` topic (dashboard, ``GET /metrics``).
- Whatever ends the run (a signal, a child exiting with ``restart never``, a start-up
  timeout), every child gets SIGINT, then SIGTERM and SIGKILL after ``stop_timeout_s`` each.
  A child that serves must exit 0 on that SIGINT, else the shutdown is unclean (exit 1); one
  still starting (at start-up, or restarted and not yet serving again) has no handler yet and
  dies of it (by the signal, or exit 1 when it lands inside a C extension's import), which is
  the stop asked for: a user's stop during a restart exits 0.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import time
from collections.abc import Awaitable, Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, SecretStr

from clients.client import RosbridgeClient
from clients.connection import AUTH_SECRET_ENV, TransportConfig
from clients.errors import RosbridgeError
from clients.node.child import BRIDGE_URL, Child, Component, describe_exit
from clients.node.output import PrefixedOutput
from clients.stack.healthcheck import Unhealthy, fetch_version, missing_publishers
from clients.stack.restarts import RestartBackoff, RestartLedger, RestartMode, RestartPolicy
from schemas.catalogue import streams_of
from schemas.rosauth import read_secret
from schemas.runtime.process import MALLOC_ENV

log = logging.getLogger(__name__)
T = TypeVar("T")

# Ready when these have publishers: what each always streams (schemas.catalogue).
SIMULATOR_TOPICS = streams_of("simulator")
NAVIGATION_TOPICS = streams_of("navigation")
GUIDANCE_TOPICS = streams_of("guidance")

_POLL_S = 0.25  # readiness probe period: cheap (one rosapi round trip per topic)
_WILDCARD_TO_LOOPBACK = {"0.0.0.0": "127.0.0.1", "": "127.0.0.1", "::": "::1"}


class LaunchConfig(BaseModel):
    """What ``riverbridge up`` starts. Defaults: rosbridge's usual port, CBOR (DESIGN §4)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    host: str = "127.0.0.1"
    # rosbridge_server's default port; 0 lets the kernel pick a free one.
    port: int = Field(default=9090, ge=0, le=65535)
    encoding: Literal["json", "cbor"] = "cbor"  # binary frames: ~30x cheaper for a scan
    sim_config: Path | None = None
    nav_config: Path | None = None
    # `up --autopilot`: guidance and control as a fourth process (docs/guidance.md)
    autopilot: bool = False
    guidance_config: Path | None = None
    # A loaded 2-core machine needs tens of seconds to import the stack and build the
    # ~500k-triangle scene.
    startup_timeout_s: float = Field(default=120.0, gt=0)
    # Per escalation step (SIGINT, then SIGTERM, then SIGKILL); the parts stop in ~1 s.
    stop_timeout_s: float = Field(default=10.0, gt=0)
    # What happens to a component that dies once the stack runs (clients.stack.restarts).
    restart: RestartMode = "on-failure"
    # The bridge's secret and certificate (docs/bridge.md, "Security and hostile input"):
    # with them the simulator and navigation authenticate and trust it too.
    auth_secret_file: Path | None = None
    certfile: Path | None = None
    # The bridge's options as `up` passes them through (up_cli.BRIDGE_OPTIONS), these two
    # included.
    bridge_args: tuple[str, ...] = ()

    @property
    def scheme(self) -> str:
        return "wss" if self.certfile is not None else "ws"


def stack_components(config: LaunchConfig) -> tuple[Component, ...]:
    """The bridge, the simulator and the navigation service (and with ``autopilot``,
    guidance) for ``config``, in start order."""
    sim_args = ["--bridge", BRIDGE_URL, "--encoding", config.encoding]
    nav_args, guide_args = list(sim_args), list(sim_args)
    if config.sim_config is not None:
        sim_args += ["--config", str(config.sim_config)]
    if config.nav_config is not None:
        nav_args += ["--config", str(config.nav_config)]
    if config.guidance_config is not None:
        guide_args += ["--config", str(config.guidance_config)]
    guidance = (
        (Component("guide", "guidance", "guidance", tuple(guide_args), GUIDANCE_TOPICS),)
        if config.autopilot
        else ()
    )
    return (
        Component(
            "bridge",
            "bridge",
            "bridge",
            (
                "--host",
                config.host,
                "--port",
                str(config.port),
                *config.bridge_args,
            ),
        ),
        Component("sim", "simulator", "simulator", tuple(sim_args), SIMULATOR_TOPICS),
        Component("nav", "navigation", "navigation", tuple(nav_args), NAVIGATION_TOPICS),
        *guidance,
    )


def child_environment(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default ``os.environ``) plus unbuffered output and the malloc tuning."""
    env = dict(os.environ if base is None else base)
    env.update(MALLOC_ENV)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def access_environment(config: LaunchConfig) -> dict[str, str]:
    """What the simulator and navigation need to use a secured bridge: the rosauth secret
    file (clients.connection) and the bridge's certificate as their trust store."""
    env = {}
    if config.auth_secret_file is not None:
        env[AUTH_SECRET_ENV] = str(config.auth_secret_file)
    if config.certfile is not None:
        env["SSL_CERT_FILE"] = str(config.certfile)
    return env


def client_transport(config: LaunchConfig) -> TransportConfig:
    """The supervisor's own connections (readiness probe, restart counts) to the bridge."""
    secret = (
        None if config.auth_secret_file is None else SecretStr(read_secret(config.auth_secret_file))
    )
    return TransportConfig(auth_secret=secret, cafile=config.certfile)


def connect_host(host: str) -> str:
    """Where a local client connects to reach a server bound to ``host``."""
    return _WILDCARD_TO_LOOPBACK.get(host, host)


def ws_url(host: str, port: int, scheme: str = "ws") -> str:
    return f"{scheme}://[{host}]:{port}" if ":" in host else f"{scheme}://{host}:{port}"


def with_port(component: Component, port: int) -> Component:
    """``component`` with the value after ``--port`` replaced by ``port``."""
    args = list(component.args)
    args[args.index("--port") + 1] = str(port)
    return replace(component, args=tuple(args))


class ComponentDied(RuntimeError):
    """A component exited while the stack was starting or running."""

    def __init__(self, title: str, code: int, child: Child | None = None) -> None:
        super().__init__(describe_exit(title, code))
        self.title, self.code, self.child = title, code, child


class StartupTimeout(RuntimeError):
    """A component did not become ready in time; the message says what was missing."""


class StopRequested(Exception):
    """The supervisor was asked to stop (signal) before the stack was ready."""


# --------------------------------------------------------------------------- the stack


class Supervisor:
    """Starts ``components`` (the first is the bridge), watches them, stops them all.

    on_ready : called once with the bridge URL when every component is ready.
    """

    def __init__(
        self,
        components: Sequence[Component],
        config: LaunchConfig,
        output: PrefixedOutput,
        env: Mapping[str, str] | None = None,
        on_ready: Callable[[str], None] | None = None,
    ) -> None:
        self._bridge, *self._clients = components
        self._config = config
        self._output = output
        self._env = {**child_environment(env), **access_environment(config)}
        self._on_ready = on_ready
        self.children: list[Child] = []
        self.url = ""
        self._missing: dict[str, tuple[str, ...]] = {}
        self._policy = RestartPolicy(config.restart)
        self._backoffs: dict[str, RestartBackoff] = {}
        self.ledger = RestartLedger()
        self._restarting: set[asyncio.Task[None]] = set()
        self._changed = asyncio.Event()  # a restarted child joined `children`
        self._bridge_port = 0

    async def run(self, stop: asyncio.Event) -> int:
        """Run until ``stop`` is set (0), or a component dies that the restart policy does
        not restart, or one fails to start (1)."""
        status = 1
        try:
            await self._start(stop)
            if self._on_ready is not None:
                self._on_ready(self.url)
            await self._supervise(stop)
            status = 0
        except StopRequested:
            status = 0
        except (ComponentDied, StartupTimeout) as exc:
            log.error("%s; stopping the others", exc)
        except RosbridgeError as exc:  # the readiness probe lost the bridge
            log.error("cannot check readiness through %s: %s", self.url, exc)
        finally:
            for task in self._restarting:
                task.cancel()
            await asyncio.gather(*self._restarting, return_exceptions=True)
            await self.ledger.close()
            codes = await self._stop_all()
        unclean = {title: code for title, code in codes.items() if code != 0}
        if status == 0 and unclean:
            log.error(
                "unclean shutdown: %s", ", ".join(describe_exit(t, c) for t, c in unclean.items())
            )
            status = 1
        return status

    async def _start(self, stop: asyncio.Event) -> None:
        deadline = asyncio.get_running_loop().time() + self._config.startup_timeout_s
        bridge = await self._spawn(self._bridge)
        port = await self._guard(
            asyncio.shield(bridge.port), stop, deadline, waiting_for=self._bridge.title
        )
        self._bridge_port = port
        self.url = ws_url(connect_host(self._config.host), port, self._config.scheme)
        await self._guard(self._probe_version(), stop, deadline, waiting_for=self._bridge.title)
        bridge.ready = True
        log.info("%s ready at %s", self._bridge.title, self.url)
        for component in self._clients:
            await self._spawn(component)
        await self._guard(
            self._probe_clients(self._clients),
            stop,
            deadline,
            waiting_for=", ".join(c.title for c in self._clients),
        )
        for child in self.children:
            child.ready = True

    async def _spawn(self, component: Component) -> Child:
        child = await Child.start(component, self.url, self._env, self._output)
        self.children.append(child)
        self.ledger.started(component.title, child.pid)
        return child

    # -- supervision once running ----------------------------------------------------------

    async def _supervise(self, stop: asyncio.Event) -> None:
        """Until ``stop``: restart components that die (per the policy); raise ComponentDied
        for one that is not restarted."""
        self._restarting.add(asyncio.create_task(self._attach_ledger(), name="up restarts"))
        while True:
            self._changed.clear()
            try:
                await self._guard(self._changed.wait(), stop, timeout_s=None)
            except ComponentDied as died:
                if died.child is None or not self._policy.restarts(died.code):
                    raise
                self._schedule_restart(died.child, died.code)

    async def _attach_ledger(self) -> None:
        try:
            await self.ledger.attach(self.url, client_transport(self._config))
        except RosbridgeError as exc:
            log.warning("cannot publish restart counts through %s: %s", self.url, exc)

    def _schedule_restart(self, child: Child, code: int) -> None:
        title = child.component.title
        self.children.remove(child)
        count = self.ledger.died(title, describe_exit(title, code).removeprefix(title + " "))
        backoff = self._backoffs.setdefault(title, RestartBackoff())
        delay_s = backoff.next_delay(time.monotonic() - child.started_s)
        log.warning(
            "%s; restarting it in %g s (restart %d)", describe_exit(title, code), delay_s, count
        )
        task = asyncio.create_task(self._restart(child.component, delay_s), name=f"restart {title}")
        self._restarting.add(task)
        task.add_done_callback(self._restarting.discard)

    async def _restart(self, component: Component, delay_s: float) -> None:
        await asyncio.sleep(delay_s)
        if component.name == self._bridge.name:  # same port: the clients reconnect to it
            component = with_port(component, self._bridge_port)
        child = await self._spawn(component)
        self._changed.set()
        await self.ledger.publish()
        await self._settle(child)

    async def _settle(self, child: Child) -> None:
        """Mark a restarted `child` ready once it serves again (or give up if it exits)."""
        if child.component.name == self._bridge.name:
            probe = asyncio.ensure_future(self._probe_version())
        else:
            probe = asyncio.ensure_future(self._probe_until_served(child.component))
        exited = asyncio.ensure_future(child.wait())
        try:
            await asyncio.wait({probe, exited}, return_when=asyncio.FIRST_COMPLETED)
            child.ready = probe.done() and not probe.cancelled() and probe.exception() is None
        finally:
            for task in (probe, exited):
                task.cancel()
            await asyncio.gather(probe, exited, return_exceptions=True)

    async def _probe_until_served(self, component: Component) -> None:
        """`_probe_clients` for one component, retried while the bridge is away."""
        while True:
            with contextlib.suppress(RosbridgeError):
                await self._probe_clients((component,))
                return
            await asyncio.sleep(_POLL_S)

    async def _probe_version(self) -> None:
        while True:
            with contextlib.suppress(Unhealthy):
                await asyncio.to_thread(fetch_version, self.url, 5.0, self._config.certfile)
                return
            await asyncio.sleep(_POLL_S)

    async def _probe_clients(self, components: Sequence[Component]) -> None:
        """Poll ``/rosapi/publishers`` until every topic of `components` has a publisher."""
        pending = {c.title: c.topics for c in components}
        self._missing = dict(pending)
        async with RosbridgeClient(
            self.url,
            encoding="json",
            name="up-probe",
            reconnect=False,
            transport=client_transport(self._config),
        ) as probe:
            while pending:
                for title, topics in list(pending.items()):
                    with contextlib.suppress(RosbridgeError, TimeoutError):
                        self._missing[title] = tuple(await missing_publishers(probe, topics))
                        if not self._missing[title]:
                            log.info("%s ready: publishing %s", title, ", ".join(topics))
                            del pending[title]
                if pending:
                    await asyncio.sleep(_POLL_S)

    async def _guard(
        self,
        work: Awaitable[T],
        stop: asyncio.Event,
        deadline: float | None = None,
        *,
        timeout_s: float | None = None,
        waiting_for: str = "",
    ) -> T:
        """Await ``work`` unless a child exits (ComponentDied), ``stop`` is set
        (StopRequested) or ``deadline`` passes (StartupTimeout) first."""
        loop = asyncio.get_running_loop()
        if deadline is not None:
            timeout_s = max(0.0, deadline - loop.time())
        task = asyncio.ensure_future(work)
        stopping = asyncio.ensure_future(stop.wait())
        exits = {asyncio.ensure_future(child.wait()): child for child in self.children}
        try:
            done, _ = await asyncio.wait(
                {task, stopping, *exits}, timeout=timeout_s, return_when=asyncio.FIRST_COMPLETED
            )
            for exited, child in exits.items():
                if exited in done:
                    raise ComponentDied(child.component.title, exited.result(), child)
            if task in done:
                return task.result()
            if stopping in done:
                raise StopRequested
            raise StartupTimeout(self._timeout_message(waiting_for))
        finally:
            for pending in (task, stopping, *exits):
                pending.cancel()
            await asyncio.gather(task, stopping, *exits, return_exceptions=True)

    def _timeout_message(self, waiting_for: str) -> str:
        details = "; ".join(
            f"{title} has no publisher on {', '.join(topics)}"
            for title, topics in self._missing.items()
            if topics
        )
        return f"{waiting_for} not ready within {self._config.startup_timeout_s:.0f} s" + (
            f" ({details})" if details else ""
        )

    async def _stop_all(self) -> dict[str, int]:
        """Stop the clients (together), then the bridge; exit code by component title."""
        timeout_s = self._config.stop_timeout_s
        clients = [child for child in self.children if child.component.name != self._bridge.name]
        bridge = [child for child in self.children if child.component.name == self._bridge.name]
        codes: dict[str, int] = {}
        for group in (clients, bridge):
            starting = {id(c) for c in group if not c.ready and c.process.returncode is None}
            results = await asyncio.gather(*(child.stop(timeout_s) for child in group))
            for child, code in zip(group, results, strict=True):
                title = child.component.title
                if id(child) in starting and code != 0:
                    # Stopped before it handled signals (still importing, just restarted): it
                    # ended on our request, which is what a user's stop asks for. SIGINT in the
                    # middle of a C extension's import (numpy's) surfaces as an ImportError and
                    # exit 1 rather than a death by the signal, so any exit counts here.
                    how = signal.Signals(-code).name if code < 0 else f"exit code {code}"
                    log.info("%s stopped while starting (%s)", title, how)
                    code = 0
                else:
                    log.info("%s", describe_exit(title, code))
                codes[title] = code
        return codes
