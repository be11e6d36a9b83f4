"""riverbridge's rosbridge v2 websocket server (the Node.js role in the thesis' pipeline).

Entry points: `bridge.compose.run_bridge(BridgeConfig)` for programs and tests,
`python -m bridge` (`bridge.cli.main`) for people; `bridge.core.BridgeCore` is the
transport-free protocol core. See `bridge/README.md` for the module map.
"""

from schemas.runtime.native import native_first

# The compiled hot path, if built and current (schemas.runtime.native).
__path__ = native_first(__path__, __name__)
