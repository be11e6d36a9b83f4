"""The web dashboard's static files, served by the bridge on its own port (``http://HOST:PORT/``).

The front end lives in ``web/`` and is built with npm into ``web/dist/`` (``index.html`` plus
content-hashed files under ``assets/``); this module only serves that folder: the right content
types, long caching for hashed assets and none for ``index.html`` (so a rebuild shows at once),
and nothing outside the folder. Without a build, ``/`` answers with a page giving the build
command, and the bridge says the same in its log at start-up.
"""

from __future__ import annotations

import html
import logging
import os
from pathlib import Path
from urllib.parse import unquote

from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from bridge.host import PluginHost
from bridge.http import HttpRoutes, respond

logger = logging.getLogger("bridge.webapp")

BUILD_COMMAND = "npm ci --prefix web && npm run build --prefix web"
WEB_ROOT_ENV = "RIVERBRIDGE_WEB_ROOT"
INDEX = "index.html"
# Vite names everything under assets/ by content hash: a changed file gets a new name, so a
# browser may keep these for a year without asking again.
HASHED_PREFIX = "assets/"
CACHE_HASHED = "public, max-age=31536000, immutable"
CACHE_REVALIDATE = "no-cache"

CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".map": "application/json",
    ".svg": "image/svg+xml",
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".ico": "image/x-icon",
    ".wasm": "application/wasm",
    ".woff2": "font/woff2",
    ".txt": "text/plain; charset=utf-8",
}


def default_web_root() -> Path:
    """``$RIVERBRIDGE_WEB_ROOT`` if set, else ``web/dist`` next to the installed package."""
    configured = os.environ.get(WEB_ROOT_ENV)
    if configured:
        return Path(configured)
    return Path(__file__).resolve().parent.parent / "web" / "dist"


class StaticSite:
    """A request handler for the files under `root` (a built ``web/dist``)."""

    def __init__(self, root: Path) -> None:
        self.root = root.resolve()

    @property
    def built(self) -> bool:
        return (self.root / INDEX).is_file()

    def resolve(self, url_path: str) -> Path | None:
        """The file a URL path names, or ``None`` if it is missing or lies outside the root."""
        relative = unquote(url_path.split("?", 1)[0]).lstrip("/") or INDEX
        if "\x00" in relative or "\\" in relative:
            return None
        candidate = (self.root / relative).resolve()
        if not candidate.is_relative_to(self.root) or not candidate.is_file():
            return None
        return candidate

    def __call__(self, connection: ServerConnection, request: Request) -> Response:
        target = self.resolve(request.path)
        if not self.built and request.path.split("?", 1)[0] in ("/", f"/{INDEX}"):
            return build_instructions(connection, self.root)
        if target is None:
            return respond(connection, 404, "Not Found\n", "text/plain; charset=utf-8")
        response = respond(connection, 200, target.read_bytes(), content_type_of(target))
        hashed = target.relative_to(self.root).as_posix().startswith(HASHED_PREFIX)
        response.headers["Cache-Control"] = CACHE_HASHED if hashed else CACHE_REVALIDATE
        response.headers["X-Content-Type-Options"] = "nosniff"
        return response


def content_type_of(path: Path) -> str:
    return CONTENT_TYPES.get(path.suffix.lower(), "application/octet-stream")


def build_instructions(connection: ServerConnection, root: Path) -> Response:
    """The page at ``/`` while no dashboard build exists: what to run, and where it looked."""
    body = (
        "<!doctype html><meta charset='utf-8'><title>riverbridge: dashboard not built</title>"
        "<body style='font-family:system-ui;max-width:44em;margin:3em auto'>"
        "<h1>riverbridge</h1><p>This bridge serves rosbridge v2 on this port (connect a "
        "websocket). Its web dashboard has not been built: run, in the repository,</p>"
        f"<pre>{html.escape(BUILD_COMMAND)}</pre>"
        f"<p>The bridge looked for <code>{html.escape(str(root / INDEX))}</code> "
        f"(set <code>--web-root DIR</code> or <code>{WEB_ROOT_ENV}</code>).</p>"
    )
    response = respond(connection, 200, body, "text/html; charset=utf-8")
    response.headers["Cache-Control"] = CACHE_REVALIDATE
    return response


def mount_webapp(routes: HttpRoutes, root: Path) -> StaticSite:
    """Serve `root` at ``/`` (exact routes such as ``/version`` still win) and log its state."""
    site = StaticSite(root)
    routes.add("/", site)
    routes.add_prefix("/", site)
    if site.built:
        logger.info("web dashboard from %s", site.root)
    else:
        logger.warning("no web dashboard build in %s; build it with: %s", site.root, BUILD_COMMAND)
    return site


class Dashboard:
    """The plug-in: serves `config.web_root` (else `default_web_root()`) on the bridge's port."""

    def __init__(self, host: PluginHost) -> None:
        self._host = host
        self.site: StaticSite | None = None

    async def start(self) -> None:
        root = self._host.config.web_root or default_web_root()
        self.site = mount_webapp(self._host.http, root)

    async def stop(self) -> None:
        """Nothing to undo: the routes end with the server."""


__all__ = ["BUILD_COMMAND", "Dashboard", "StaticSite", "default_web_root", "mount_webapp"]
