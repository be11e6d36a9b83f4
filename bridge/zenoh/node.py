"""The bridge as one rmw_zenoh node: its identity and the liveliness tokens it declares.

The node `/riverbridge_<8 hex digits of the session id>` (or `--dds-node`'s name) is node 0 of
the session; each publisher, subscription, service and client it opens gets the next entity
id and a token (`bridge.zenoh.liveliness`), withdrawn when it closes. An entity's GID (the
attachment's source GID) derives from its token's key.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import zenoh

from bridge.dds.naming import node_name
from bridge.zenoh.attachment import entity_gid
from bridge.zenoh.keys import Distro
from bridge.zenoh.liveliness import Endpoint, Entity, EntityKind, token_key


@dataclass
class Declared:
    """A declared entity: what it announces, its GID, its live token."""

    entity: Entity
    gid: bytes
    token: zenoh.LivelinessToken

    def close(self) -> None:
        self.token.undeclare()


class ZenohNode:
    """The session as an rmw_zenoh node of `domain`."""

    def __init__(self, session: zenoh.Session, domain: int, distro: Distro, name: str) -> None:
        self.session = session
        self.domain = domain
        self.distro = distro
        self.zid = str(session.zid())
        full = name or f"riverbridge_{self.zid[:8]}"
        full = full if full.startswith("/") else "/" + full
        namespace, _, short = full.rpartition("/")
        self.namespace = namespace or "/"
        self.name = short
        self.fqn = node_name(self.namespace, short)
        self._ids = itertools.count(1)
        self.node = self._declare(Entity(domain, self.zid, 0, 0, EntityKind.NODE, *self._ns()))

    def _ns(self) -> tuple[str, str]:
        return self.namespace, self.name

    def declare(self, kind: EntityKind, endpoint: Endpoint) -> Declared:
        """A token for a new endpoint of the node."""
        entity = Entity(
            self.domain, self.zid, 0, next(self._ids), kind, *self._ns(), endpoint=endpoint
        )
        return self._declare(entity)

    def _declare(self, entity: Entity) -> Declared:
        key = token_key(entity)
        return Declared(entity, entity_gid(key), self.session.liveliness().declare_token(key))

    def close(self) -> None:
        self.node.close()
