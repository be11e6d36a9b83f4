"""The bridge's configuration: one frozen model shared by its CLI, edge and core, and by
``riverbridge up``, which passes bridge options through (it may not import `bridge`).

Each field with a command-line option carries it (`schemas.options.Option`): the option is
written once, here; `python -m bridge` and `up` derive their arguments from it.

Defaults follow the reference rosbridge server (rosbridge-protocol.md §8) except where the
design asks for more headroom: the thesis' LIDAR scan (Table 4.3, ~345,000 points at 2 Hz) is
~7.5 MB as JSON, so the inbound frame limit is raised from rosbridge's 10 MB to 64 MiB.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, SecretStr, model_validator

from schemas.options import MIB, Option
from schemas.roles_config import RolesConfig, load_roles
from schemas.rosauth import read_secret

MIN_SEND_BUFFER = 64 * 1024  # below one socket buffer's worth, healthy readers would drop
#: Environment variable naming a rosauth secret file: the bridge's default --auth-secret-file,
#: and what riverbridge's clients authenticate with (clients.connection).
AUTH_SECRET_ENV = "RIVERBRIDGE_AUTH_SECRET_FILE"

# The option groups of `--help`, in order.
NETWORK = "network"
LIMITS = "limits (per client unless said)"
SECURITY = 'access control (docs/bridge.md, "Security and hostile input")'
TYPES = "message types"
DASHBOARD = "web dashboard"
DDS = "ROS 2 over DDS (docs/ros2.md)"
ZENOH = "ROS 2 over Zenoh, rmw_zenoh's wire format (docs/zenoh.md)"
GROUPS = (NETWORK, LIMITS, SECURITY, TYPES, DASHBOARD, DDS, ZENOH)
# A Zenoh endpoint: <protocol>/<address>[#<metadata>] (tcp/127.0.0.1:7447, udp/[::1]:0).
ZENOH_ENDPOINT = r"^[a-z0-9]+/[A-Za-z0-9._:\[\]%-]+(#[A-Za-z0-9=;._-]*)?$"


def secret_of(path: Path) -> SecretStr:
    """`--auth-secret-file`: the secret on the file's first line."""
    return SecretStr(read_secret(path))


class BridgeConfig(BaseModel):
    """Everything the bridge needs to start; immutable once built."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    host: Annotated[str, Option("--host", NETWORK, "address to listen on")] = "127.0.0.1"
    # rosbridge's default port (protocol §8); 0 picks a free port.
    port: Annotated[
        int, Option("--port", NETWORK, "TCP port; 0 picks a free one", metavar="PORT")
    ] = Field(default=9090, ge=0, le=65535)
    # Inbound frame limit in bytes; larger frames are refused with close code 1009 (protocol
    # §1.1). 64 MiB holds a full Table 4.3 LIDAR scan in JSON (~7.5 MB) with room to spare.
    max_message_size: Annotated[
        int,
        Option(
            "--max-message-size",
            LIMITS,
            "inbound frame limit in bytes; larger frames close with 1009",
            metavar="BYTES",
        ),
    ] = Field(default=64 * MIB, gt=0)
    # Seconds before an incomplete inbound fragment list is discarded (protocol §8).
    fragment_timeout_s: Annotated[
        float,
        Option("--fragment-timeout", LIMITS, "seconds to wait for missing fragments", "S"),
    ] = Field(default=600.0, gt=0)
    # Default call_service timeout in seconds (rosbridge 2.2+ default_call_service_timeout).
    call_timeout_s: Annotated[
        float, Option("--call-timeout", LIMITS, "default call_service timeout in seconds", "S")
    ] = Field(default=5.0, gt=0)
    # fnmatch patterns gating topic and service names; empty = allow all (protocol §8).
    topics_glob: Annotated[
        tuple[str, ...],
        Option(
            "--topics-glob",
            SECURITY,
            "allow only topics matching this fnmatch pattern (repeatable)",
            "PATTERN",
            many="append",
        ),
    ] = ()
    services_glob: Annotated[
        tuple[str, ...],
        Option(
            "--services-glob",
            SECURITY,
            "allow only services matching this fnmatch pattern (repeatable)",
            "PATTERN",
            many="append",
        ),
    ] = ()
    # fnmatch patterns gating action names (advertise_action, send_action_goal); empty = the
    # services' patterns, since ROS 2 actions are services underneath (rosbridge gates none).
    actions_glob: Annotated[
        tuple[str, ...],
        Option(
            "--actions-glob",
            SECURITY,
            "allow only actions matching this fnmatch pattern (repeatable; default: the "
            "--services-glob patterns)",
            "PATTERN",
            many="append",
        ),
    ] = ()
    # Bytes one client may leave untaken (in its socket's buffer and its queue) before each topic
    # it subscribes to loses its oldest waiting message (docs/bridge.md, "Delivery"). 16 MiB holds
    # two JSON scans (7.4 MB each, Table 4.3) or ~100,000 small messages: only a client that
    # stops reading or falls seconds behind ever loses anything.
    send_buffer_bytes: Annotated[
        int,
        Option(
            "--send-buffer",
            LIMITS,
            "bytes a client may leave untaken before each of its topics loses its oldest "
            "waiting message",
            "BYTES",
        ),
    ] = Field(default=16 * MIB, ge=MIN_SEND_BUFFER)
    # Frames from this many bytes on are decoded, validated and encoded in the worker pool, off
    # the loop: a 4 MB JSON+base64 encode is ~10-30 ms (performance-measurements §2(c)), and
    # validating a 40 kB array of 400 nested messages ~6 ms on a busy core.
    offload_threshold_bytes: Annotated[
        int,
        Option(
            "--offload-threshold",
            LIMITS,
            "payloads at least this large are decoded and encoded in a worker thread, off "
            "the event loop",
            "BYTES",
        ),
    ] = Field(default=4 * 1024, gt=0)
    # Extra folders of .msg/.srv/.action definitions registered at start-up.
    interface_dirs: Annotated[
        tuple[Path, ...],
        Option(
            "--interfaces",
            TYPES,
            "extra folder of <pkg>/{msg,srv,action}/ definitions (repeatable)",
            "DIR",
            many="append",
            exists="dir",
        ),
    ] = ()
    # Foxglove clients' fetchAsset: files under these folders only (bridge/foxglove/assets.py).
    asset_dirs: Annotated[
        tuple[Path, ...],
        Option(
            "--asset-dir",
            NETWORK,
            "serve this folder's meshes to Foxglove clients as package://<name>/... (repeatable)",
            "DIR",
            many="append",
            exists="dir",
        ),
    ] = ()
    # ROS 2 distribution the bridge acts as: reported by /rosapi/get_ros_version, and on DDS
    # the layout of ros_discovery_info (Humble's 24-byte GIDs, 16 since Jazzy) and whether
    # endpoints carry a type hash (not in Humble); docs/ros2.md.
    distro: Annotated[
        Literal["humble", "jazzy", "kilted"],
        Option("--ros-distro", DDS, "the ROS 2 distribution to act as: humble, jazzy or kilted"),
    ] = "jazzy"
    # Built web dashboard served at http://host:port/; None = $RIVERBRIDGE_WEB_ROOT or the
    # repository's web/dist (bridge.webapp.default_web_root).
    web_root: Annotated[
        Path | None,
        Option(
            "--web-root",
            DASHBOARD,
            "built web dashboard to serve at http://HOST:PORT/ (default: "
            "$RIVERBRIDGE_WEB_ROOT, else the repository's web/dist)",
            "DIR",
        ),
    ] = None
    # ROS 2 over DDS (docs/ros2.md): with `dds` the bridge joins DDS domain `dds_domain` with
    # Cyclone DDS and mirrors topics and services the way ROS 2 puts them on the wire. DDS
    # traffic stays on `dds_interface` (the loopback unless told otherwise), discovery goes to
    # the listed unicast `dds_peers` (127.0.0.1 on `lo`), multicast is off unless asked for.
    # Defaults come from where ROS 2 or a container puts them: `ROS_DOMAIN_ID`, and
    # `RIVERBRIDGE_DDS*` for docker compose; options win over variables.
    dds: Annotated[
        bool,
        Option(
            "--dds",
            DDS,
            "join a ROS 2 DDS domain with Cyclone DDS and mirror topics and services both ways",
            env="RIVERBRIDGE_DDS",
        ),
    ] = False
    # 0..232: Cyclone's default port mapping (7400 + 250 * domain) ends at domain 232.
    dds_domain: Annotated[
        int, Option("--domain", DDS, "DDS domain id", "N", env="ROS_DOMAIN_ID")
    ] = Field(default=0, ge=0, le=232)
    dds_interface: Annotated[
        str,
        Option(
            "--dds-interface",
            DDS,
            "the only network interface DDS may use",
            "NAME",
            env="RIVERBRIDGE_DDS_INTERFACE",
        ),
    ] = Field(default="lo", pattern=r"^[A-Za-z0-9._@-]+$")
    dds_peers: Annotated[
        tuple[Annotated[str, Field(pattern=r"^[A-Za-z0-9._:\[\]-]+$")], ...],
        Option(
            "--dds-peer",
            DDS,
            "unicast discovery peer, repeatable or comma-separated; none: 127.0.0.1 on lo",
            "ADDR",
            env="RIVERBRIDGE_DDS_PEERS",
            many="append",
            split=",",
        ),
    ] = ()
    # The bridge's own parameters as a ROS 2 node's services (`ros2 param` on the bridge), as
    # a ROS 2 node has them; --no-dds-parameters leaves out their five services.
    dds_parameters: Annotated[
        bool,
        Option(
            "--dds-parameters",
            DDS,
            "serve the bridge's own parameters as its DDS node's parameter services (on unless "
            "--no-dds-parameters)",
            env="RIVERBRIDGE_DDS_PARAMETERS",
            paired=True,
        ),
    ] = True
    dds_multicast: Annotated[
        Literal["false", "spdp", "true"],
        Option(
            "--dds-multicast",
            DDS,
            "multicast on that interface: false, spdp (discovery only) or true",
        ),
    ] = "false"
    # The bridge's ROS 2 node on the domain; "" = /riverbridge_<8 hex digits of its GUID>.
    dds_node: Annotated[
        str,
        Option(
            "--dds-node",
            DDS,
            "the bridge's ROS 2 node name on the domain (default /riverbridge_<id>)",
            "NAME",
        ),
    ] = Field(default="", pattern=r"^(/?[A-Za-z_][A-Za-z0-9_]*)*$")
    # Large-sample tuning of Cyclone (socket buffers, writer history cache; bridge.dds
    # .cyclone_xml); off only to measure what it buys (benchmarks/dds.py).
    dds_tuned: Annotated[
        bool,
        Option(
            "--dds-untuned",
            DDS,
            "Cyclone's own socket buffers and writer cache limits instead of the bridge's "
            "large-sample settings (to measure them)",
            negate=True,
        ),
    ] = True
    # ROS 2 over Zenoh (docs/zenoh.md): with `zenoh` the bridge opens a Zenoh session (peer
    # mode, multicast scouting off) in ROS domain `dds_domain` (`--domain`) and behaves on the
    # wire like an rmw_zenoh node of `zenoh_distro`. It connects to `zenoh_connect` (rmw_zenoh's
    # router on this host unless told) and listens on `zenoh_listen` (the loopback unless told).
    zenoh: Annotated[
        bool,
        Option(
            "--zenoh",
            ZENOH,
            "join ROS 2's Zenoh graph as an rmw_zenoh node and mirror topics and services both "
            "ways (with --dds too: a DDS <-> Zenoh gateway)",
            env="RIVERBRIDGE_ZENOH",
        ),
    ] = False
    zenoh_listen: Annotated[
        tuple[Annotated[str, Field(pattern=ZENOH_ENDPOINT)], ...],
        Option(
            "--zenoh-listen",
            ZENOH,
            "Zenoh endpoint to listen on, repeatable or comma-separated (default tcp/127.0.0.1:0)",
            "ENDPOINT",
            env="RIVERBRIDGE_ZENOH_LISTEN",
            many="append",
            split=",",
        ),
    ] = ()
    zenoh_connect: Annotated[
        tuple[Annotated[str, Field(pattern=ZENOH_ENDPOINT)], ...],
        Option(
            "--zenoh-connect",
            ZENOH,
            "Zenoh router or peer to connect to, repeatable or comma-separated (default "
            "tcp/127.0.0.1:7447, rmw_zenohd's, unless --zenoh-listen is given)",
            "ENDPOINT",
            env="RIVERBRIDGE_ZENOH_CONNECT",
            many="append",
            split=",",
        ),
    ] = ()
    # A Zenoh configuration file (json5) the session starts from; the options above win.
    zenoh_config: Annotated[
        Path | None,
        Option(
            "--zenoh-config",
            ZENOH,
            "Zenoh session configuration file (json5) to start from; --zenoh-listen and "
            "--zenoh-connect override its endpoints",
            "FILE",
            env="RIVERBRIDGE_ZENOH_CONFIG",
            exists="file",
        ),
    ] = None
    # Jazzy and later put the RIHS01 type hash in keys and tokens, Humble TypeHashNotSupported.
    # None = the distribution the bridge acts as (`--ros-distro`), so one flag pins both graphs.
    zenoh_distro: Annotated[
        Literal["humble", "jazzy", "kilted", "rolling"] | None,
        Option(
            "--zenoh-distro",
            ZENOH,
            "the ROS 2 distribution whose rmw_zenoh keys to use (default: --ros-distro's)",
        ),
    ] = None
    # Access control (bridge.access, docs/bridge.md "Security and hostile input").
    # rosauth secret (first line of --auth-secret-file); None = no authentication, as ROS 2
    # rosbridge. With it, every op before a valid `auth` op is refused (protocol §1.5).
    auth_secret: Annotated[
        SecretStr | None,
        Option(
            "--auth-secret-file",
            SECURITY,
            "require rosauth's auth op, checked against the secret on the file's first line, "
            "before any other op",
            "FILE",
            env=AUTH_SECRET_ENV,
            exists="file",
            read=secret_of,
        ),
    ] = None
    # Seconds an `auth` op's `t` may differ from the bridge's clock (rosauth's default).
    auth_window_s: float = Field(default=5.0, gt=0)
    # TLS: serve wss:// (and the HTTP pages over https://) with this chain and key.
    certfile: Annotated[
        Path | None,
        Option(
            "--certfile",
            SECURITY,
            "TLS certificate chain (PEM): serve wss:// and https://",
            "FILE",
            exists="file",
        ),
    ] = None
    keyfile: Annotated[
        Path | None,
        Option("--keyfile", SECURITY, "TLS private key (PEM) of --certfile", "FILE", exists="file"),
    ] = None
    # fnmatch globs of browser Origins allowed to open a websocket; empty = any. Handshakes
    # without an Origin (not a browser) and from the bridge's own pages are always allowed.
    allowed_origins: Annotated[
        tuple[str, ...],
        Option(
            "--allowed-origins",
            SECURITY,
            "browser Origins allowed to open a websocket (fnmatch, e.g. "
            "'https://*.example.org'); others get 403; clients without Origin are not affected",
            "GLOB",
            many="extend",
        ),
    ] = ()
    # Most clients connected at once; None = no limit. More handshakes get HTTP 503.
    max_clients: Annotated[
        int | None,
        Option(
            "--max-clients", LIMITS, "refuse handshakes (503) while N clients are connected", "N"
        ),
    ] = Field(default=None, gt=0)
    # Bytes of answers (never dropped) a client may leave unread before it is closed with
    # 1008 (bridge.reply_budget). Half the inbound frame limit: ~300 full rosapi definition
    # lists, and one larger request to a provider still passes on its own.
    reply_budget_bytes: Annotated[
        int,
        Option(
            "--reply-budget",
            LIMITS,
            "unread answers (never dropped) a client may leave before it is closed with 1008",
            "BYTES",
        ),
    ] = Field(default=32 * MIB, gt=0)

    # Roles, tokens and audit (bridge.roles, docs/bridge.md "Roles and tokens"): who may
    # do what, read from a TOML file (schemas.roles_config); None = everyone may do everything.
    roles: Annotated[
        RolesConfig | None,
        Option(
            "--roles",
            SECURITY,
            "roles file (TOML): what each role may subscribe, publish, call, advertise, and its "
            "quotas; clients get a role from their token (config/roles.example.toml)",
            "FILE",
            exists="file",
            read=load_roles,
        ),
    ] = None
    # Seconds a client of a bridge that needs authentication may stay without authenticating.
    auth_grace_s: Annotated[
        float,
        Option(
            "--auth-grace",
            SECURITY,
            "seconds a client may stay connected without authenticating (with --auth-secret-file)",
            "S",
        ),
    ] = Field(default=5.0, gt=0)
    # JSON lines: audited publishes, calls, goals, parameter changes, refusals; rotated by size.
    audit_log: Annotated[
        Path | None,
        Option(
            "--audit-log",
            SECURITY,
            "append an audit trail (JSON lines, rotated by size) of calls, goals, parameter "
            "changes, publishes on audited topics and refusals to this file",
            "FILE",
        ),
    ] = None

    @model_validator(mode="after")
    def _tls_pair(self) -> BridgeConfig:
        if (self.certfile is None) != (self.keyfile is None):
            raise ValueError("certfile and keyfile (--certfile, --keyfile) go together")
        return self

    @model_validator(mode="after")
    def _roles_reachable(self) -> BridgeConfig:
        roles = self.roles
        if roles is not None and self.auth_secret is None and roles.unauthenticated_role is None:
            raise ValueError(
                "roles (--roles) without --auth-secret-file: nobody could authenticate; "
                "give a secret, or name an unauthenticated_role in the roles file"
            )
        return self

    def needs_auth(self) -> bool:
        """Whether a websocket client must authenticate before anything else."""
        unauthenticated = self.roles.unauthenticated_role if self.roles is not None else None
        return self.auth_secret is not None and unauthenticated is None

    def zenoh_keys_distro(self) -> Literal["humble", "jazzy", "kilted", "rolling"]:
        """Whose rmw_zenoh keys the Zenoh graph uses: `--zenoh-distro`, else `--ros-distro`."""
        return self.zenoh_distro or self.distro

    def action_patterns(self) -> tuple[str, ...]:
        """The globs actions must match: `actions_glob`, else `services_glob`."""
        return self.actions_glob or self.services_glob


__all__ = ["AUTH_SECRET_ENV", "GROUPS", "MIB", "MIN_SEND_BUFFER", "BridgeConfig"]
