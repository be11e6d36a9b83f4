"""Services between the bridge and Zenoh: queryables and queries, through the core's own call
routing (as `bridge.dds.service_mirror` does for DDS).

- A service a websocket client provides (or, as a gateway, another graph's node) is a
  queryable on its key (any type hash: a Humble or Jazzy client reaches it) with an `SS`
  token. A query becomes a `call_service` of the mirror's caller client; the provider's
  response is the reply, its attachment carrying the request's sequence number and GID.
- A service a remote node provides is advertised in the bridge by a stand-in client named
  like that node; a call becomes a query on the server's key (with its hash) with an `SC`
  token, and the reply the `service_response`. The core keeps its timeouts; when the server's
  token goes the stand-in unadvertises, which fails the calls still waiting.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zenoh

from bridge import graph_mirror
from bridge.effects import Send
from bridge.host import PluginHost
from bridge.zenoh.attachment import (
    Attachment,
    AttachmentProblem,
    decode_attachment,
    encode_attachment,
)
from bridge.zenoh.graph import RemoteZenohService
from bridge.zenoh.keys import KeyProblem, data_key, type_hash
from bridge.zenoh.liveliness import Endpoint, EntityKind
from bridge.zenoh.node import Declared, ZenohNode
from bridge.zenoh.problems import ProblemLog
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import SchemaError
from schemas.values import JsonObject, Message

logger = logging.getLogger("bridge.zenoh")

ToLoop = Callable[..., object]  # loop.call_soon_threadsafe
QUERY_TIMEOUT_S = 600.0  # the core's call timeout answers first; this only frees Zenoh's side


@dataclass
class _Server:
    name: str
    type_name: str
    queryable: zenoh.Queryable[None]
    declared: Declared


@dataclass
class _Client:
    remote: RemoteZenohService
    key: str
    declared: Declared
    sequence: itertools.count[int] = field(default_factory=lambda: itertools.count(1))


@dataclass
class _Waiting:
    """A Zenoh query waiting for a local provider's answer."""

    server: _Server
    query: zenoh.Query
    request: Attachment


class ZenohServices:
    """Keeps queryables, clients and stand-ins in step with both graphs."""

    def __init__(
        self, host: PluginHost, node: ZenohNode, to_loop: ToLoop, problems: ProblemLog
    ) -> None:
        self._host, self._node, self._to_loop, self._problems = host, node, to_loop, problems
        self.caller = graph_mirror.Caller(host, node.fqn, "zenoh", self._answered)
        self.client_ids = {self.caller.client_id}
        self.servers: dict[str, _Server] = {}
        self.clients: dict[str, _Client] = {}
        self.stand_ins = graph_mirror.StandIns(
            host, self._stand_in_receives, "zenoh", self.client_ids
        )
        # (service, sequence) -> the call waiting for the server's reply
        self._to_zenoh: dict[tuple[str, int], graph_mirror.WaitingCall] = {}

    # -- keeping in step ---------------------------------------------------------------------

    def sync(self, local: dict[str, str], remote: dict[str, RemoteZenohService]) -> None:
        """`local`: services to offer on Zenoh (name -> type); `remote`: Zenoh's servers."""
        for name in [n for n, s in self.servers.items() if local.get(n) != s.type_name]:
            server = self.servers.pop(name)
            server.declared.close()
            server.queryable.undeclare()
        for name, type_name in local.items():
            if name not in self.servers:
                self._offer(name, type_name)
        wanted = {n: s for n, s in remote.items() if n not in local}
        for name in [n for n, c in self.clients.items() if wanted.get(n) != c.remote]:
            self._withdraw(name)
        for name, service in wanted.items():
            if name not in self.clients:
                self._adopt(service)

    def _offer(self, name: str, type_name: str) -> None:
        hash_ = type_hash(self._host.registry, type_name, self._node.distro)
        try:
            key = data_key(self._node.domain, name, type_name, hash_)
        except (KeyProblem, ValueError) as exc:
            self._problems.dropped(name, "service not offered", str(exc))
            return
        listen = key.rsplit("/", 1)[0] + "/*"
        try:
            queryable = self._node.session.declare_queryable(
                listen,
                lambda query: self._take_query(name, type_name, query),
                complete=True,
                allowed_origin=zenoh.Locality.REMOTE,
            )
        except zenoh.ZError as exc:
            self._problems.dropped(name, "service not offered", str(exc))
            return
        declared = self._node.declare(EntityKind.SERVICE, Endpoint(name, type_name, hash_))
        self.servers[name] = _Server(name, type_name, queryable, declared)

    def _adopt(self, service: RemoteZenohService) -> None:
        """Advertise a remote server's service through a stand-in named like its node."""
        if self.stand_ins.node_is_a_client(service.node):
            return
        try:
            key = data_key(self._node.domain, service.name, service.type_name, service.type_hash)
        except (KeyProblem, ValueError) as exc:
            self._problems.dropped(service.name, "remote service not adopted", str(exc))
            return
        endpoint = Endpoint(service.name, service.type_name, service.type_hash)
        self.clients[service.name] = _Client(
            service, key, self._node.declare(EntityKind.CLIENT, endpoint)
        )
        self.stand_ins.advertise(service.node, service.name, service.type_name)

    def _withdraw(self, name: str) -> None:
        client = self.clients.pop(name)
        client.declared.close()
        for key in [k for k in self._to_zenoh if k[0] == name]:  # unadvertising fails them
            del self._to_zenoh[key]
        node = client.remote.node
        still_serves = any(c.remote.node == node for c in self.clients.values())
        self.stand_ins.unadvertise(node, name, still_serves)

    def close(self) -> None:
        self.sync({}, {})
        for waiting in self.caller.waiting.values():
            waiting.query.drop()
        self.caller.close()

    # -- Zenoh clients calling local providers -----------------------------------------------

    def _take_query(self, name: str, type_name: str, query: zenoh.Query) -> None:
        """Check and decode a request (on Zenoh's thread); hand it to the loop or drop it."""
        try:
            attachment = query.attachment
            request = decode_attachment(None if attachment is None else attachment.to_bytes())
            payload = query.payload
            msg = from_cdr(
                self._host.registry,
                f"{type_name}_Request",
                b"" if payload is None else payload.to_bytes(),
            )
        except AttachmentProblem as exc:
            self._problems.dropped(name, "request with a bad attachment", str(exc))
            query.drop()
            return
        except Exception as exc:  # rosbags raises whatever its reader meets
            self._problems.dropped(name, "undecodable request", repr(exc))
            query.drop()
            return
        self._to_loop(self._on_request, name, query, request, msg)

    def _on_request(self, name: str, query: zenoh.Query, request: Attachment, msg: Any) -> None:
        server = self.servers.get(name)
        if server is None:
            query.drop()
            return
        self.caller.call(name, msg, _Waiting(server, query, request))

    def _answered(self, waiting: _Waiting, payload: JsonObject) -> None:
        """The local provider's `service_response` to a Zenoh query: the reply."""
        values = payload.get("values")
        try:
            if payload.get("result") is not True or not isinstance(values, dict):
                raise SchemaError(f"the provider failed: {values}")
            cdr = to_cdr(self._host.registry, f"{waiting.server.type_name}_Response", values)
        except SchemaError as exc:
            logger.warning("Zenoh: call to %s from Zenoh failed: %s", waiting.server.name, exc)
            waiting.query.reply_err(str(exc).encode())
            waiting.query.drop()
            return
        reply = Attachment(
            waiting.request.sequence_number, self._host.now_ns(), waiting.request.source_gid
        )
        query = waiting.query
        query.reply(query.key_expr, cdr, attachment=encode_attachment(reply))
        query.drop()

    # -- local callers using remote servers --------------------------------------------------

    def _stand_in_receives(self, send: Send) -> None:
        payload = graph_mirror.control_payload(send)
        client = graph_mirror.called_endpoint(self.clients, payload)
        if client is None:
            return
        waiting = graph_mirror.waiting_call(send, payload)
        args = payload.get("args")
        try:
            cdr = to_cdr(
                self._host.registry,
                f"{client.remote.type_name}_Request",
                args if isinstance(args, dict) else {},
            )
        except SchemaError as exc:
            self.stand_ins.answer(waiting, f"request does not encode: {exc}", ok=False)
            return
        sequence = next(client.sequence)
        self._to_zenoh[(client.remote.name, sequence)] = waiting
        attachment = Attachment(sequence, self._host.now_ns(), client.declared.gid)
        self._node.session.get(
            client.key,
            lambda reply: self._take_reply(client.remote, sequence, reply),
            payload=cdr,
            attachment=encode_attachment(attachment),
            target=zenoh.QueryTarget.ALL_COMPLETE,
            timeout=QUERY_TIMEOUT_S,
        )

    def _take_reply(self, remote: RemoteZenohService, sequence: int, reply: zenoh.Reply) -> None:
        """Decode a reply (on Zenoh's thread) and answer the waiting caller on the loop."""
        sample = reply.ok
        if sample is None:
            error = reply.err
            text = error.payload.to_string() if error is not None else "no reply"
            self._to_loop(self._on_reply, remote.name, sequence, f"the server failed: {text}")
            return
        try:
            msg = from_cdr(
                self._host.registry, f"{remote.type_name}_Response", sample.payload.to_bytes()
            )
        except Exception as exc:  # rosbags raises whatever its reader meets
            self._problems.dropped(remote.name, "undecodable reply", repr(exc))
            return
        self._to_loop(self._on_reply, remote.name, sequence, msg)

    def _on_reply(self, name: str, sequence: int, result: Message | str) -> None:
        waiting = self._to_zenoh.pop((name, sequence), None)
        if waiting is not None:
            self.stand_ins.answer(waiting, result, ok=not isinstance(result, str))
