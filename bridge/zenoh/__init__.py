"""ROS 2 over Zenoh: the bridge as an rmw_zenoh node (docs/zenoh.md).

Pure parts: `keys` (data key expressions, type hashes per distro), `attachment` (the 33-byte
attachment), `liveliness` (tokens and their QoS element), `graph` (the graph cache built from
tokens), `problems` (rate-limited lines for bad input). Zenoh's shell: `session` (configuration,
opening), `node` (identity and tokens), `topics`, `services`; `mirror.ZenohMirror` ties them to
the bridge. Only `--zenoh` imports the shell (and `eclipse-zenoh`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from bridge.host import Plugin, PluginHost


def plugin(host: PluginHost) -> Plugin:
    """The Zenoh mirror as a plug-in of `host` (`bridge.compose`); Zenoh loads only now."""
    from bridge.zenoh.mirror import ZenohMirror

    return ZenohMirror(host)
