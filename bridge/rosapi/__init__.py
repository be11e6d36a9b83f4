"""rosapi services answered by the bridge itself: the bridge is the ROS graph (protocol §9).

`ROSAPI_SERVICES` maps each service name to its `rosapi_msgs/srv/*` type and a handler
`(ctx, request) -> response values`; a handler raises `RosapiError` to fail the call with
`result: false` and the error text.
"""

from __future__ import annotations

from bridge.errors import RosapiError
from bridge.rosapi.common import RosapiService
from bridge.rosapi.graph_services import SERVICES as GRAPH_SERVICES
from bridge.rosapi.param_services import SERVICES as PARAM_SERVICES
from bridge.rosapi.type_services import SERVICES as TYPE_SERVICES

ROSAPI_SERVICES: dict[str, RosapiService] = {**GRAPH_SERVICES, **TYPE_SERVICES, **PARAM_SERVICES}

__all__ = ["ROSAPI_SERVICES", "RosapiError", "RosapiService"]
