"""Bridge configuration: `BridgeConfig`, one frozen model shared by the CLI, the edge and the
core. It lives in `schemas.bridge_config` with its command-line options, so that
``riverbridge up`` (which may not import the bridge) passes the same options through."""

from __future__ import annotations

from schemas.bridge_config import AUTH_SECRET_ENV, MIN_SEND_BUFFER, BridgeConfig
from schemas.options import MIB

__all__ = ["AUTH_SECRET_ENV", "MIB", "MIN_SEND_BUFFER", "BridgeConfig"]
