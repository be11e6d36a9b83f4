"""Bridge configuration: one frozen model shared by the CLI, the edge and the core.

Defaults follow the reference rosbridge server (rosbridge-protocol.md §8) except where the
design asks for more headroom: the thesis' LIDAR scan (Table 4.3, ~345,000 points at 2 Hz) is
~7.5 MB as JSON, so the inbound frame limit is raised from rosbridge's 10 MB to 64 MiB.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

MIB = 1024 * 1024
MIN_SEND_BUFFER = 64 * 1024  # below one socket buffer's worth, healthy readers would drop


class BridgeConfig(BaseModel):
    """Everything the bridge needs to start; immutable once built."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    host: str = "127.0.0.1"
    # rosbridge's default port (protocol §8); 0 picks a free port.
    port: int = Field(default=9090, ge=0, le=65535)
    # Inbound frame limit in bytes; larger frames are refused with close code 1009 (protocol
    # §1.1). 64 MiB holds a full Table 4.3 LIDAR scan in JSON (~7.5 MB) with room to spare.
    max_message_size: int = Field(default=64 * MIB, gt=0)
    # Seconds before an incomplete inbound fragment list is discarded (protocol §8).
    fragment_timeout_s: float = Field(default=600.0, gt=0)
    # Default call_service timeout in seconds (rosbridge 2.2+ default_call_service_timeout).
    call_timeout_s: float = Field(default=5.0, gt=0)
    # fnmatch patterns gating topic and service names; empty = allow all (protocol §8).
    topics_glob: tuple[str, ...] = ()
    services_glob: tuple[str, ...] = ()
    # Bytes one client may leave untaken (in its socket's buffer and its queue) before each topic
    # it subscribes to loses its oldest waiting message (docs/bridge.md, "Delivery"). 16 MiB holds
    # two JSON scans (7.4 MB each, Table 4.3) or ~100,000 small messages: only a client that
    # stops reading or falls seconds behind ever loses anything.
    send_buffer_bytes: int = Field(default=16 * MIB, ge=MIN_SEND_BUFFER)
    # Frames from this many bytes on are decoded, validated and encoded in the worker pool, off
    # the loop: a 4 MB JSON+base64 encode is ~10-30 ms (performance-measurements §2(c)), and
    # validating a 40 kB array of 400 nested messages ~6 ms on a busy core.
    offload_threshold_bytes: int = Field(default=4 * 1024, gt=0)
    # Extra folders of .msg/.srv/.action definitions registered at start-up.
    interface_dirs: tuple[Path, ...] = ()
    # ROS distribution reported by /rosapi/get_ros_version.
    distro: str = "jazzy"
    # Built web dashboard served at http://host:port/; None = $RIVERBRIDGE_WEB_ROOT or the
    # repository's web/dist (bridge.webapp.default_web_root).
    web_root: Path | None = None
