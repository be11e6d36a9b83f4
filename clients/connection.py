"""Opening the websocket (with retry) and translating transport errors, in one place.

Settings follow DESIGN §4 / reference/performance-measurements.md (b): permessage-deflate off
(it caps 4 MB frames at ~30 MB/s) and ``max_size`` far above one LIDAR scan (the 1 MiB default
refuses it).
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import random
import ssl
import time
import urllib.parse
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import websockets
from pydantic import BaseModel, ConfigDict, Field, SecretStr
from websockets.asyncio.client import ClientConnection
from websockets.exceptions import InvalidURI, WebSocketException

from clients.backoff import BackoffPolicy
from clients.errors import ConnectionClosed, ConnectionFailed
from schemas import rosauth

logger = logging.getLogger(__name__)

AUTH_SECRET_ENV = "RIVERBRIDGE_AUTH_SECRET_FILE"
"""Environment variable naming a rosauth secret file: every connection then authenticates
(`riverbridge up --auth-secret-file` sets it for the simulator and navigation; the bridge
reads the same variable as its default ``--auth-secret-file``)."""


TOKEN_ENV = "RIVERBRIDGE_TOKEN"
"""Environment variable holding a bridge token (`riverbridge token`): every connection then
presents it as `Authorization: Bearer` (a bridge with `--roles` gives it the token's role)."""


def token_from_env() -> SecretStr | None:
    token = os.environ.get(TOKEN_ENV, "").strip()
    return SecretStr(token) if token else None


def auth_secret_from_env() -> SecretStr | None:
    """The secret in the file ``$RIVERBRIDGE_AUTH_SECRET_FILE`` names, or None if unset."""
    path = os.environ.get(AUTH_SECRET_ENV)
    return SecretStr(rosauth.read_secret(Path(path))) if path else None


class TransportConfig(BaseModel):
    """Websocket settings of a client connection."""

    model_config = ConfigDict(frozen=True)

    max_frame_bytes: int = Field(default=256 * 1024 * 1024, gt=0)
    """Largest frame accepted: a 345,600-point XYZI cloud is 5.5 MB; 256 MiB leaves room for
    dense maps and images without letting a broken peer exhaust memory."""
    max_queued_frames: int = Field(default=64, gt=0)
    """Frames websockets buffers before pausing reads (its default 16 throttles bursts)."""
    attempt_timeout_s: float = Field(default=5.0, gt=0)
    """Opening handshake limit of one attempt; a local bridge answers in milliseconds."""
    ping_interval_s: float | None = 20.0
    """Keepalive pings detect a dead peer; websockets' default period."""
    ping_timeout_s: float | None = 20.0
    auth_secret: SecretStr | None = Field(default_factory=auth_secret_from_env)
    """rosauth secret: when set, an ``auth`` op is the first frame of every connection."""
    token: SecretStr | None = Field(default_factory=token_from_env)
    """Bridge token (``riverbridge token``): sent as ``Authorization: Bearer`` at the handshake."""
    cafile: Path | None = None
    """For ``wss://``: trust this certificate (PEM) instead of the default store (which
    ``SSL_CERT_FILE`` may also point at)."""


@contextmanager
def translate_transport_error(context: str) -> Iterator[None]:
    """Re-raise websockets / socket errors as :class:`ConnectionClosed` (the one translation)."""
    try:
        yield
    except websockets.ConnectionClosed as exc:
        raise ConnectionClosed(f"{context}: connection closed ({exc})") from exc
    except (OSError, WebSocketException) as exc:
        raise ConnectionClosed(f"{context}: {exc}") from exc


async def open_once(url: str, config: TransportConfig, timeout_s: float) -> ClientConnection:
    """One connection attempt; raises ``OSError``/``TimeoutError``/websockets errors as is.

    For ``wss://`` the server certificate is checked against the default trust store, which
    ``SSL_CERT_FILE`` may point at (``riverbridge up --certfile`` does).
    """
    options: dict[str, Any] = {}  # websockets refuses an explicit ssl=None for wss://
    if config.cafile is not None and url.startswith("wss:"):
        options["ssl"] = ssl.create_default_context(cafile=str(config.cafile))
    if config.token is not None:
        options["additional_headers"] = {
            "Authorization": f"Bearer {config.token.get_secret_value()}"
        }
    ws = await websockets.connect(
        url,
        **options,
        compression=None,
        max_size=config.max_frame_bytes,
        max_queue=config.max_queued_frames,
        open_timeout=timeout_s,
        ping_interval=config.ping_interval_s,
        ping_timeout=config.ping_timeout_s,
        proxy=None,
    )
    if config.auth_secret is not None and config.token is None:
        host = urllib.parse.urlsplit(url).hostname or ""
        op = rosauth.auth_op(config.auth_secret.get_secret_value(), time.time(), dest=host)
        await ws.send(json.dumps(op))
    return ws


async def open_with_retry(
    url: str,
    config: TransportConfig,
    backoff: BackoffPolicy,
    rng: random.Random,
    *,
    timeout_s: float | None,
) -> ClientConnection:
    """Open a websocket, retrying with backoff until it works or ``timeout_s`` elapses.

    ``timeout_s=None`` retries until cancelled (used while reconnecting). Raises
    :class:`ConnectionFailed` on timeout or for a URL that can never work.
    """
    loop = asyncio.get_running_loop()
    deadline = None if timeout_s is None else loop.time() + timeout_s
    delays = backoff.delays(rng)
    attempt = 0
    while True:
        attempt += 1
        remaining = None if deadline is None else deadline - loop.time()
        try:
            limit = (
                config.attempt_timeout_s
                if remaining is None
                else min(config.attempt_timeout_s, max(remaining, 0.01))
            )
            return await open_once(url, config, limit)
        except InvalidURI as exc:
            raise ConnectionFailed(f"{url}: invalid websocket URL ({exc})") from exc
        except (OSError, TimeoutError, WebSocketException) as exc:
            last_error = exc
        delay = next(delays)
        if deadline is not None and loop.time() + delay >= deadline:
            raise ConnectionFailed(
                f"could not connect to {url} within {timeout_s} s after {attempt} attempts: "
                f"{last_error}"
            ) from last_error
        logger.debug("connect to %s failed (%s); retrying in %.2f s", url, last_error, delay)
        await asyncio.sleep(delay)
