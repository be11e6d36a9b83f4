"""rosauth's MAC for rosbridge's `auth` op, shared by the bridge (checks) and clients (sign).

GT-RAIL/rosauth (`ros_mac_authentication`): `mac` is the hex SHA-512 of
`secret + client + dest + rand + str(t.secs) + level + str(end.secs)`; the request is good
when `|t - now| < allowed_time_delta` (5 s by default) and `end` is still in the future.
`t` and `end` travel as numbers of seconds (roslibpy, roslibjs, rosbridge 1) or as ROS time
objects (`{"secs", "nsecs"}` or `{"sec", "nanosec"}`); only the whole seconds are hashed.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import secrets
from pathlib import Path
from typing import Any

#: rosauth's default `allowed_time_delta`: a request older or newer than this is refused.
TIME_WINDOW_S = 5.0


def read_secret(path: Path) -> str:
    """The secret: the file's first line (rosauth reads one line). ValueError if empty."""
    lines = path.read_text(encoding="utf-8").splitlines()
    secret = lines[0].strip() if lines else ""
    if not secret:
        raise ValueError(f"{path}: the first line (the secret) is empty")
    return secret


def mac(
    secret: str, client: str, dest: str, rand: str, t_secs: int, level: str, end_secs: int
) -> str:
    """rosauth's MAC: hex SHA-512 of the concatenated fields."""
    text = f"{secret}{client}{dest}{rand}{t_secs}{level}{end_secs}"
    return hashlib.sha512(text.encode("utf-8")).hexdigest()


def seconds(value: Any) -> float | None:
    """A time as seconds: a number, or `{"secs"|"sec", "nsecs"|"nanosec"}`; None if neither."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, dict):
        secs = value.get("secs", value.get("sec", 0))
        nsecs = value.get("nsecs", value.get("nanosec", 0))
        if (
            isinstance(secs, int)
            and isinstance(nsecs, int)
            and not isinstance(secs, bool)
            and not isinstance(nsecs, bool)
        ):
            return secs + nsecs / 1e9
    return None


def check(
    secret: str, op: dict[str, Any], now_s: float, window_s: float = TIME_WINDOW_S
) -> str | None:
    """None if `op` (an `auth` op's fields) authenticates at `now_s`; else why not."""
    fields = [op.get(k) for k in ("mac", "client", "dest", "rand", "level")]
    strings = [f for f in fields if isinstance(f, str)]
    if len(strings) != len(fields):
        return "mac, client, dest, rand and level must be strings"
    t_s, end_s = seconds(op.get("t")), seconds(op.get("end"))
    if t_s is None or end_s is None:
        return "t and end must be times (seconds, or secs/nsecs)"
    if abs(t_s - now_s) >= window_s:
        return f"t is {t_s - now_s:+.1f} s from the bridge's clock (allowed: ±{window_s:g} s)"
    if end_s <= now_s:
        return "end is not in the future"
    given, client, dest, rand, level = strings
    expected = mac(secret, client, dest, rand, math.floor(t_s), level, math.floor(end_s))
    if not hmac.compare_digest(given.lower().encode(), expected.encode()):
        return "mac does not match"
    return None


def auth_op(
    secret: str,
    now_s: float,
    *,
    client: str = "riverbridge",
    dest: str = "bridge",
    level: str = "user",
    lifetime_s: float = 24 * 3600.0,
) -> dict[str, Any]:
    """A signed `auth` op for a client that holds the secret (t now, end `lifetime_s` on)."""
    rand = secrets.token_hex(16)
    t_secs, end_secs = math.floor(now_s), math.floor(now_s + lifetime_s)
    return {
        "op": "auth",
        "mac": mac(secret, client, dest, rand, t_secs, level, end_secs),
        "client": client,
        "dest": dest,
        "rand": rand,
        "t": t_secs,
        "level": level,
        "end": end_secs,
    }
