"""Who may open a connection: TLS, browser Origins and a client limit, decided at handshake.

rosauth's `auth` op (who may *use* a connection) lives in `bridge.ops.auth`; this module holds
what the edge decides before a websocket exists:

- `tls_context`: `--certfile/--keyfile` serve `wss://` and the HTTP pages over `https://`.
- `handshake_token`: a bridge token presented at the handshake, as `Authorization: Bearer` or
  `?token=` (browsers cannot set headers); the core checks it (`BridgeCore.admit`).
- `HandshakePolicy.refusal`: a browser handshake whose `Origin` matches none of
  `--allowed-origins` gets HTTP 403 (a client that sends no Origin, i.e. not a browser, and
  the bridge's own dashboard, same origin, are not affected); past `--max-clients` HTTP 503.
"""

from __future__ import annotations

import ssl
import urllib.parse
from fnmatch import fnmatchcase

from websockets.http11 import Request

from bridge.config import BridgeConfig
from bridge.roles import bearer_token


def tls_context(config: BridgeConfig) -> ssl.SSLContext | None:
    """A server TLS context for the configured certificate, or None for plain ws://."""
    if config.certfile is None or config.keyfile is None:
        return None
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(config.certfile, config.keyfile)
    return context


def scheme(config: BridgeConfig) -> str:
    """`wss` with TLS, else `ws`."""
    return "wss" if config.certfile is not None else "ws"


def same_origin(origin: str, host_header: str | None) -> bool:
    """True when the page that opens the websocket was served by this bridge (host:port)."""
    if not host_header:
        return False
    return urllib.parse.urlsplit(origin).netloc.lower() == host_header.lower()


def handshake_token(request: Request) -> str | None:
    """The token of `Authorization: Bearer <token>`, else of the URL's `?token=`, else None."""
    token = bearer_token(request.headers.get("Authorization"))
    if token is not None:
        return token
    query = urllib.parse.parse_qs(urllib.parse.urlsplit(request.path).query)
    found = query.get("token")
    return found[0] if found else None


class HandshakePolicy:
    """The handshake checks of one bridge; `refusal` is called for every upgrade request."""

    def __init__(self, config: BridgeConfig) -> None:
        self.allowed_origins = config.allowed_origins
        self.max_clients = config.max_clients

    def origin_allowed(self, origin: str | None, host_header: str | None) -> bool:
        if origin is None or not self.allowed_origins:
            return True
        return same_origin(origin, host_header) or any(
            fnmatchcase(origin, pattern) for pattern in self.allowed_origins
        )

    def refusal(self, request: Request, clients: int) -> tuple[int, str] | None:
        """(HTTP status, body) refusing a websocket handshake, or None to let it proceed."""
        origins, hosts = request.headers.get_all("Origin"), request.headers.get_all("Host")
        if len(origins) > 1 or len(hosts) > 1:
            return 400, "several Origin or Host headers\n"
        origin = origins[0] if origins else None
        if not self.origin_allowed(origin, hosts[0] if hosts else None):
            return 403, f"Origin {origin} is not allowed (--allowed-origins)\n"
        if self.max_clients is not None and clients >= self.max_clients:
            return 503, f"the bridge serves at most {self.max_clients} clients (--max-clients)\n"
        return None
