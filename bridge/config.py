"""Bridge configuration: one frozen model shared by the CLI, the edge and the core.

Defaults follow the reference rosbridge server (rosbridge-protocol.md §8) except where the
design asks for more headroom: the thesis' LIDAR scan (Table 4.3, ~345,000 points at 2 Hz) is
~7.5 MB as JSON, so the inbound frame limit is raised from rosbridge's 10 MB to 64 MiB.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, SecretStr, model_validator

MIB = 1024 * 1024
MIN_SEND_BUFFER = 64 * 1024  # below one socket buffer's worth, healthy readers would drop
#: Environment variable naming a rosauth secret file: the bridge's default --auth-secret-file,
#: and what riverbridge's clients authenticate with (clients.connection).
AUTH_SECRET_ENV = "RIVERBRIDGE_AUTH_SECRET_FILE"


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
    # fnmatch patterns gating action names (advertise_action, send_action_goal); empty = the
    # services' patterns, since ROS 2 actions are services underneath (rosbridge gates none).
    actions_glob: tuple[str, ...] = ()
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
    # ROS 2 over DDS (docs/ros2.md): with `dds` the bridge joins DDS domain `dds_domain` with
    # Cyclone DDS and mirrors topics and services the way ROS 2 puts them on the wire. DDS
    # traffic stays on `dds_interface` (the loopback unless told otherwise), discovery goes to
    # the listed unicast `dds_peers` (127.0.0.1 on `lo`), multicast is off unless asked for.
    dds: bool = False
    # 0..232: Cyclone's default port mapping (7400 + 250 * domain) ends at domain 232.
    dds_domain: int = Field(default=0, ge=0, le=232)
    dds_interface: str = Field(default="lo", pattern=r"^[A-Za-z0-9._@-]+$")
    dds_peers: tuple[Annotated[str, Field(pattern=r"^[A-Za-z0-9._:\[\]-]+$")], ...] = ()
    dds_multicast: Literal["false", "spdp", "true"] = "false"
    # The bridge's ROS 2 node on the domain; "" = /riverbridge_<8 hex digits of its GUID>.
    dds_node: str = Field(default="", pattern=r"^(/?[A-Za-z_][A-Za-z0-9_]*)*$")
    # Large-sample tuning of Cyclone (socket buffers, writer history cache; bridge.dds
    # .cyclone_xml); off only to measure what it buys (benchmarks/dds.py).
    dds_tuned: bool = True
    # Access control (bridge.access, docs/bridge.md "Security and hostile input").
    # rosauth secret (first line of --auth-secret-file); None = no authentication, as ROS 2
    # rosbridge. With it, every op before a valid `auth` op is refused (protocol §1.5).
    auth_secret: SecretStr | None = None
    # Seconds an `auth` op's `t` may differ from the bridge's clock (rosauth's default).
    auth_window_s: float = Field(default=5.0, gt=0)
    # TLS: serve wss:// (and the HTTP pages over https://) with this chain and key.
    certfile: Path | None = None
    keyfile: Path | None = None
    # fnmatch globs of browser Origins allowed to open a websocket; empty = any. Handshakes
    # without an Origin (not a browser) and from the bridge's own pages are always allowed.
    allowed_origins: tuple[str, ...] = ()
    # Most clients connected at once; None = no limit. More handshakes get HTTP 503.
    max_clients: int | None = Field(default=None, gt=0)
    # Bytes of answers (never dropped) a client may leave unread before it is closed with
    # 1008 (bridge.reply_budget). Half the inbound frame limit: ~300 full rosapi definition
    # lists, and one larger request to a provider still passes on its own.
    reply_budget_bytes: int = Field(default=32 * MIB, gt=0)

    @model_validator(mode="after")
    def _tls_pair(self) -> BridgeConfig:
        if (self.certfile is None) != (self.keyfile is None):
            raise ValueError("certfile and keyfile must be given together")
        return self

    def action_patterns(self) -> tuple[str, ...]:
        """The globs actions must match: `actions_glob`, else `services_glob`."""
        return self.actions_glob or self.services_glob
