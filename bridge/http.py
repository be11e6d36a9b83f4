"""Plain HTTP on the websocket port: a small route table the server consults per request.

rosbridge serves ``GET /version`` next to its websocket; riverbridge adds its own pages
(``/metrics``, the web dashboard) the same way. A request that asks for a websocket upgrade is
never routed here, so ``ws://host:9090/`` keeps working whatever the routes are.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.metadata import PackageNotFoundError, version

from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from schemas import codec_json

#: rosbridge protocol version this server speaks (rosbridge_suite's ``GET /version``).
PROTOCOL_VERSION = {"major": 2, "minor": 0, "patch": 0}

Handler = Callable[[ServerConnection, Request], Response]


def server_version() -> str:
    try:
        return f"riverbridge {version('riverbridge')}"
    except PackageNotFoundError:
        return "riverbridge"


def respond(
    connection: ServerConnection, status: int, body: bytes | str, content_type: str
) -> Response:
    """A response with ``body`` and the given content type (websockets defaults to text)."""
    response = connection.respond(status, "")
    response.body = body.encode("utf-8") if isinstance(body, str) else body
    del response.headers["Content-Type"]
    del response.headers["Content-Length"]
    response.headers["Content-Type"] = content_type
    response.headers["Content-Length"] = str(len(response.body))
    return response


def version_page(connection: ServerConnection, request: Request) -> Response:
    body = codec_json.dumps({"protocol": PROTOCOL_VERSION, "server": server_version()})
    return respond(connection, 200, body, "application/json")


def index_page(connection: ServerConnection, request: Request) -> Response:
    return respond(
        connection,
        200,
        "riverbridge: a rosbridge v2 server; connect with a websocket.\n",
        "text/plain; charset=utf-8",
    )


class HttpRoutes:
    """Exact paths first, then the longest matching prefix; anything else is 404."""

    def __init__(self) -> None:
        self._exact: dict[str, Handler] = {"/version": version_page, "/": index_page}
        self._prefixes: list[tuple[str, Handler]] = []

    def add(self, path: str, handler: Handler) -> None:
        self._exact[path] = handler

    def add_prefix(self, prefix: str, handler: Handler) -> None:
        self._prefixes.append((prefix, handler))
        self._prefixes.sort(key=lambda item: len(item[0]), reverse=True)

    def __call__(self, connection: ServerConnection, request: Request) -> Response | None:
        """websockets' ``process_request`` hook: ``None`` lets the websocket handshake go on."""
        if "websocket" in request.headers.get("Upgrade", "").lower():
            return None
        path = request.path.split("?", 1)[0]
        handler = self._exact.get(path)
        if handler is None:
            handler = next((h for prefix, h in self._prefixes if path.startswith(prefix)), None)
        if handler is None:
            return respond(connection, 404, "Not Found\n", "text/plain; charset=utf-8")
        return handler(connection, request)
