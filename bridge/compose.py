"""The composition: the one place that builds a bridge and its plug-ins from the configuration.

`compose` makes the sans-I/O core, the asyncio edge around it (`BridgeServer`), the
`PluginHost` plug-ins meet them through, and the plug-ins the configuration asks for;
`run_bridge` starts them for the duration of an `async with` block. Adding a graph transport
(a Zenoh mirror, say) is a package exposing `plugin(host)` and one line in `plugin_table`.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import bridge.dds
import bridge.foxglove.plugin
import bridge.zenoh
from bridge.access import scheme
from bridge.audit import AuditTrail
from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.host import Plugin, PluginHost
from bridge.server import BridgeServer
from bridge.stats import BridgeTelemetry
from bridge.webapp import Dashboard
from schemas.registry import TypeRegistry

PluginFactory = Callable[[PluginHost], Plugin]


def plugin_table(config: BridgeConfig) -> list[tuple[str, bool, PluginFactory]]:
    """(name, wanted, factory) of every plug-in, in start order (stopped in reverse)."""
    return [
        ("dashboard", True, Dashboard),
        ("telemetry", True, BridgeTelemetry),
        ("dds", config.dds, bridge.dds.plugin),
        ("audit", config.audit_log is not None, AuditTrail),
        ("zenoh", config.zenoh, bridge.zenoh.plugin),
        ("foxglove", True, bridge.foxglove.plugin.plugin),
    ]


@dataclass(frozen=True)
class ComposedBridge:
    """A bridge built but not started: its edge, the host and the wanted plug-ins by name."""

    server: BridgeServer
    plugin_host: PluginHost
    plugins: Mapping[str, Plugin]


def compose(
    config: BridgeConfig,
    registry: TypeRegistry | None = None,
    more: Sequence[tuple[str, PluginFactory]] = (),
) -> ComposedBridge:
    """Core, edge, host and plug-ins for `config` (then those of `more`: a tool's own, a
    test's); `registry` defaults to the standard types plus `config.interface_dirs`."""
    if registry is None:
        registry = TypeRegistry.with_defaults(config.interface_dirs)
    server = BridgeServer(config, BridgeCore(config, registry))
    host = PluginHost(server.core, server)
    wanted = [(name, build) for name, on, build in plugin_table(config) if on] + list(more)
    return ComposedBridge(server, host, {name: build(host) for name, build in wanted})


@dataclass(frozen=True)
class RunningBridge:
    """A started bridge: where it listens, and its parts for tests and tools."""

    host: str
    port: int
    server: BridgeServer
    plugins: Mapping[str, Plugin]

    @property
    def url(self) -> str:
        return f"{scheme(self.server.config)}://{self.host}:{self.port}"

    @property
    def core(self) -> BridgeCore:
        return self.server.core

    @property
    def dds(self) -> Any:
        """The DDS mirror (bridge.dds.mirror.DdsMirror) when `config.dds`, else None."""
        return self.plugins.get("dds")


@contextlib.asynccontextmanager
async def run_bridge(
    config: BridgeConfig,
    registry: TypeRegistry | None = None,
    more: Sequence[tuple[str, PluginFactory]] = (),
) -> AsyncIterator[RunningBridge]:
    """Start a bridge and its plug-ins (`compose`) for the duration of the `async with`."""
    bridge = compose(config, registry, more)
    await bridge.server.start()
    started: list[Plugin] = []
    try:
        for plugin in bridge.plugins.values():
            await plugin.start()
            started.append(plugin)
        yield RunningBridge(config.host, bridge.server.port, bridge.server, bridge.plugins)
    finally:
        for plugin in reversed(started):
            await plugin.stop()
        await bridge.plugin_host.close()
        await bridge.server.stop()


__all__ = ["ComposedBridge", "RunningBridge", "compose", "plugin_table", "run_bridge"]
