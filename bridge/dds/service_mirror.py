"""Services across the bridge and the DDS domain, through the core's own call routing.

Both directions reuse what the core already does for websocket clients, with in-process
clients that the mirror drives (`BridgeCore.connect(node=...)`; the server hands their sends
to the mirror instead of a socket):

- A service a websocket client provides is offered on DDS (`ServiceServer`). A DDS request
  becomes a `call_service` from the mirror's caller client (the bridge's DDS node); the
  provider's `service_response` comes back to it and goes out as the DDS reply.
- A service a remote node provides is advertised in the bridge by a stand-in client named
  like that node (`/add_two_ints_server`). The core forwards local calls to the stand-in as
  `call_service`; the mirror sends them as DDS requests and answers with the reply's values.
  The core keeps its timeouts; when the remote server goes away the stand-in unadvertises,
  which fails the calls still waiting.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TypeVar

from bridge import graph_mirror
from bridge.dds.discovery import RemoteService
from bridge.dds.participant import DdsPlumbing
from bridge.dds.request_header import RequestId
from bridge.dds.service_endpoints import Received, ServiceClient, ServiceServer
from bridge.effects import Send
from bridge.host import PluginHost
from schemas.errors import SchemaError
from schemas.values import JsonObject, Message

logger = logging.getLogger("bridge.dds")

ToLoop = Callable[..., object]  # loop.call_soon_threadsafe
EndpointT = TypeVar("EndpointT", ServiceServer, ServiceClient)


class ServiceMirror:
    """Keeps DDS service endpoints and stand-in clients in step with both graphs."""

    def __init__(
        self,
        host: PluginHost,
        dds: DdsPlumbing,
        node: str,
        to_loop: ToLoop,
    ) -> None:
        self._host = host
        self._dds, self._to_loop = dds, to_loop
        self.caller = graph_mirror.Caller(host, node, "dds", self._answered)
        self.client_ids = {self.caller.client_id}
        self.servers: dict[str, ServiceServer] = {}
        self.clients: dict[str, ServiceClient] = {}
        self.stand_ins = graph_mirror.StandIns(
            host, self._stand_in_receives, "dds", self.client_ids
        )
        self._remote: dict[str, RemoteService] = {}
        # (service, sequence) -> the call waiting for the server's reply
        self._to_dds: dict[tuple[str, int], graph_mirror.WaitingCall] = {}
        self._refused: set[str] = set()

    # -- keeping in step ---------------------------------------------------------------------

    def sync(self, local: dict[str, str], remote: dict[str, RemoteService]) -> bool:
        """`local`: services websocket clients provide (name -> type); `remote`: servers on
        the domain. Returns True if DDS endpoints were created or deleted."""
        changed = False
        for name in [n for n, s in self.servers.items() if local.get(n) != s.type_name]:
            self.servers.pop(name).close()
            changed = True
        for name, type_name in local.items():
            if name not in self.servers:
                server = self._open(ServiceServer, name, type_name, self._on_request)
                if server is not None:
                    self.servers[name] = server
                    changed = True
        wanted = {n: s for n, s in remote.items() if n not in local}
        for name in [n for n, s in self._remote.items() if wanted.get(n) != s]:
            changed |= self._withdraw(name)
        for name, service in wanted.items():
            if name not in self._remote:
                changed |= self._adopt(service)
        return changed

    def _open(
        self,
        kind: type[EndpointT],
        name: str,
        type_name: str,
        received: Received,
        request_header: bool = True,
    ) -> EndpointT | None:
        try:
            return kind(
                self._dds,
                name,
                type_name,
                lambda *args: self._to_loop(received, *args),
                request_header,
            )
        except (SchemaError, ValueError) as exc:  # an unknown type, a Cyclone refusal
            if name not in self._refused:
                self._refused.add(name)
                logger.warning("DDS: service %s (%s) is not mirrored: %s", name, type_name, exc)
            return None

    def _adopt(self, service: RemoteService) -> bool:
        """Advertise a remote server's service through a stand-in named like its node."""
        if self.stand_ins.node_is_a_client(service.node):
            return False
        client = self._open(
            ServiceClient, service.name, service.type_name, self._on_reply, service.request_header
        )
        if client is None:
            return False
        self.clients[service.name] = client
        self._remote[service.name] = service
        self.stand_ins.advertise(service.node, service.name, service.type_name)
        return True

    def _withdraw(self, name: str) -> bool:
        service = self._remote.pop(name)
        client = self.clients.pop(name, None)
        if client is not None:
            client.close()
        for key in [k for k in self._to_dds if k[0] == name]:  # unadvertising fails them
            del self._to_dds[key]
        still_serves = any(s.node == service.node for s in self._remote.values())
        withdrawn = self.stand_ins.unadvertise(service.node, name, still_serves)
        return withdrawn or client is not None

    def guids(self) -> tuple[list[bytes], list[bytes]]:
        """(reader GUIDs, writer GUIDs) of every service endpoint."""
        pairs = [e.guids() for e in [*self.servers.values(), *self.clients.values()]]
        return [r for r, _ in pairs], [w for _, w in pairs]

    def close(self) -> None:
        self.sync({}, {})
        self.caller.close()

    # -- DDS clients calling local providers ------------------------------------------------

    def _on_request(self, service: str, request: RequestId, msg: Message) -> None:
        server = self.servers.get(service)
        if server is None:
            return
        self.caller.call(service, msg, (server, request))

    def _answered(self, waiting: tuple[ServiceServer, RequestId], payload: JsonObject) -> None:
        """The local provider's `service_response` to a DDS request: the DDS reply."""
        server, request = waiting
        if payload.get("result") is True and isinstance(payload.get("values"), dict):
            server.send(request, payload["values"])
        else:  # ROS 2 services have no error reply: the DDS client waits or times out
            logger.warning(
                "DDS: call to %s from DDS failed, no reply sent: %s",
                server.service,
                payload.get("values"),
            )

    # -- local callers using remote servers -------------------------------------------------

    def _stand_in_receives(self, send: Send) -> None:
        payload = graph_mirror.control_payload(send)
        client = graph_mirror.called_endpoint(self.clients, payload)
        if client is None:
            return
        request = client.request(payload.get("args") or {})
        self._to_dds[(client.service, request.sequence)] = graph_mirror.waiting_call(send, payload)

    def _on_reply(self, service: str, request: RequestId, msg: Message) -> None:
        waiting = self._to_dds.pop((service, request.sequence), None)
        if waiting is not None:
            self.stand_ins.answer(waiting, msg, ok=True)
