"""Running riverbridge's processes: ``riverbridge up``'s supervisor.

``riverbridge up`` (:mod:`clients.stack.up_cli`) starts the bridge, the simulator and the
navigation service as local processes (:mod:`clients.stack.launcher`, each a
:mod:`clients.node.child`), restarts a component that dies (:mod:`clients.stack.restarts`)
and decides readiness through the bridge (:mod:`clients.stack.healthcheck`, also docker
compose's health check). clients/README.md is the map.
"""
