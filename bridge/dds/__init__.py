"""ROS 2 over DDS: the bridge joins a DDS domain with Eclipse Cyclone DDS (docs/ros2.md).

Pure parts: `naming` (ROS names and types on the wire), `qos` (ROS 2 profiles),
`request_header` (rmw_cyclonedds's service header), `cyclone_xml` (the domain's
configuration), `discovery` (the domain read as a ROS graph), `graph_sync` (its remote half in
the bridge's graph), `outbox` (the bounded write queue). Cyclone's shell: `participant`,
`idl_types`. The parts that carry messages: `topic_mirror`, `service_endpoints`,
`service_mirror`, `announce`; `mirror.DdsMirror` ties them to the bridge. Only `--dds` imports
the shell (Cyclone loads a C library).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from bridge.host import Plugin, PluginHost


def plugin(host: PluginHost) -> Plugin:
    """The DDS mirror as a plug-in of `host` (`bridge.compose`); Cyclone loads only now."""
    from bridge.dds.mirror import DdsMirror

    return DdsMirror(host)
