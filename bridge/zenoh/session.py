"""The bridge's Zenoh session: its configuration and its opening (the only Zenoh I/O setup).

rmw_zenoh's defaults, kept on this host: peer mode, multicast scouting off, connect to the
router on `tcp/127.0.0.1:7447` (rmw_zenohd's) and listen on the loopback at a free port.
Given `--zenoh-listen` but no `--zenoh-connect`, it seeks no router: peers connect to it.
`--zenoh-config FILE` starts from the user's json5 configuration instead; `--zenoh-listen`
and `--zenoh-connect` replace its endpoints. Multicast scouting stays off unless that file
turns it on.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import zenoh

DEFAULT_CONNECT = ("tcp/127.0.0.1:7447",)  # rmw_zenohd's router on this host
DEFAULT_LISTEN = ("tcp/127.0.0.1:0",)


@dataclass(frozen=True)
class ZenohSettings:
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    config_file: Path | None = None


def session_config(settings: ZenohSettings) -> zenoh.Config:
    """The session's configuration (ValueError naming the problem if Zenoh refuses it)."""
    try:
        if settings.config_file is not None:
            config = zenoh.Config.from_file(str(settings.config_file))
        else:
            config = zenoh.Config()
            config.insert_json5("mode", '"peer"')
            config.insert_json5("scouting/multicast/enabled", "false")
        # Publication caches (transient local) order samples by timestamp, as rmw_zenoh's do.
        config.insert_json5("timestamping/enabled", "true")
        listen = settings.listen or (() if settings.config_file else DEFAULT_LISTEN)
        # Told where to listen, the bridge is the meeting point: it seeks no router then.
        connect = settings.connect or (
            () if settings.config_file or settings.listen else DEFAULT_CONNECT
        )
        if listen:
            config.insert_json5("listen/endpoints", json.dumps(list(listen)))
        if connect:
            config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    except zenoh.ZError as exc:
        raise ValueError(f"Zenoh configuration refused: {exc}") from exc
    return config


def open_session(settings: ZenohSettings) -> zenoh.Session:
    """Open the session (ValueError if the configuration is bad or an endpoint cannot be
    bound)."""
    config = session_config(settings)
    try:
        return zenoh.open(config)
    except zenoh.ZError as exc:
        raise ValueError(f"cannot open the Zenoh session: {exc}") from exc
