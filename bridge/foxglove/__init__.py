"""Foxglove's WebSocket protocol on the bridge's port, chosen by subprotocol (a plug-in).

`wire` (framing), `channels` (shared channel/service tables), `session` (the per-client
translator), `graph_view`, `playback` and `assets` are its parts; `plugin` is the shell that
meets the bridge through the `PluginHost` (`bridge.foxglove.plugin.plugin`).
"""
