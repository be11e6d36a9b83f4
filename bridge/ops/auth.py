"""rosauth's `auth` op (protocol §1.5): with `--auth-secret-file`, a client must send a valid
`auth` before anything else; a failed `auth` closes its connection (1008, policy violation).

The check is GT-RAIL/rosauth's (`schemas.rosauth`): the MAC over the secret and the op's
fields, `t` within `auth_window_s` of the bridge's clock (`ctx.now_ns`) and `end` still ahead.
Without a secret the op is accepted and ignored (ROS 2 rosbridge has no authentication).
"""

from __future__ import annotations

from bridge.context import Context
from bridge.ops import route
from bridge.session import ClientSession, StatusLevel
from schemas import rosauth
from schemas.ops import Auth

NS_PER_S = 1_000_000_000
POLICY_VIOLATION = 1008  # RFC 6455 close code


def handle_auth(ctx: Context, session: ClientSession, op: Auth) -> None:
    secret = ctx.state.config.auth_secret
    if secret is None:
        ctx.problem(
            session,
            "auth",
            op.id,
            "authentication is not enabled on this bridge; auth ignored",
            StatusLevel.INFO,
        )
        return
    if session.authenticated:
        return
    problem = rosauth.check(
        secret.get_secret_value(),
        op.model_dump(),
        ctx.now_ns / NS_PER_S,
        ctx.state.config.auth_window_s,
    )
    if problem is not None:
        ctx.problem(session, "auth", op.id, f"authentication failed: {problem}; closing")
        ctx.close(session.client_id, POLICY_VIOLATION, "authentication failed")
        session.closing = True
        return
    session.authenticated = True
    ctx.problem(
        session,
        "auth",
        op.id,
        f"authenticated (client {op.client!r}, level {op.level!r})",
        StatusLevel.INFO,
    )


ROUTES = (route(Auth, handle_auth),)
