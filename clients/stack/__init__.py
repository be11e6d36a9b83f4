"""Running riverbridge's processes: ``riverbridge up``'s supervisor and what every node shares.

``riverbridge up`` (:mod:`clients.stack.up_cli`) starts the bridge, the simulator and the
navigation service as local processes (:mod:`clients.stack.launcher`), restarts a component
that dies (:mod:`clients.stack.restarts`) and decides readiness through the bridge
(:mod:`clients.stack.healthcheck`, also docker compose's health check). The simulator's and
navigation's command lines and connections are :mod:`clients.stack.node_cli` and
:mod:`clients.stack.node_links`. clients/README.md is the map.
"""
