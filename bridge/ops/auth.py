"""Authentication: rosauth's `auth` op (protocol §1.5) and bridge tokens.

With `--auth-secret-file`, a client must authenticate before anything else, within
`--auth-grace` seconds, else it is closed (1008, policy violation); a failed attempt closes it
too. It authenticates with:

- a token (`schemas.tokens`, a JWT signed with the secret, from `riverbridge token`) in the
  `auth` op's `mac` field (roslibpy's and roslibjs's `authenticate()` send it unchanged), or
  at the handshake as `Authorization: Bearer` or `?token=` (the edge hands it to
  `BridgeCore.admit`). The token names the client's principal and role.
- rosauth's MAC (`schemas.rosauth`): over the secret and the op's fields, `t` within
  `auth_window_s` of the bridge's clock (`ctx.now_ns`) and `end` still ahead; it grants the
  roles file's `rosauth_role`.

Without a secret the op is accepted and ignored (ROS 2 rosbridge has no authentication).
"""

from __future__ import annotations

from bridge.context import Context
from bridge.ops import route
from bridge.session import ClientSession, StatusLevel
from schemas import rosauth, tokens
from schemas.ops import Auth
from schemas.values import OpId

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
    if session.principal:  # authenticated already (an anonymous client may still upgrade)
        return
    if tokens.looks_like_token(op.mac):
        authenticate_token(ctx, session, op.mac, op.id)
        return
    problem = rosauth.check(
        secret.get_secret_value(),
        op.model_dump(),
        ctx.now_ns / NS_PER_S,
        ctx.state.config.auth_window_s,
    )
    roles = ctx.state.config.roles
    if problem is None and roles is not None and roles.rosauth_role is None:
        problem = "the roles file grants no role to a rosauth MAC (no rosauth_role): use a token"
    if problem is not None:
        refuse(ctx, session, op.id, f"authentication failed: {problem}", "authentication failed")
        return
    principal = f"rosauth:{op.client}"
    if admit(ctx, session, roles.rosauth_role if roles else None, principal, op.id):
        ctx.problem(
            session,
            "auth",
            op.id,
            f"authenticated (client {op.client!r}, level {op.level!r}) with rosauth's MAC",
            StatusLevel.INFO,
        )


def authenticate_token(ctx: Context, session: ClientSession, token: str, op_id: OpId) -> bool:
    """Check a presented token; a bad one closes the connection with the reason."""
    secret = ctx.state.config.auth_secret
    if secret is None:
        refuse(ctx, session, op_id, "a token was presented but this bridge has no secret")
        return False
    try:
        claims = tokens.verify(secret.get_secret_value(), token, ctx.now_ns / NS_PER_S)
    except tokens.TokenError as exc:
        refuse(ctx, session, op_id, f"authentication failed: {exc}")
        return False
    if not admit(ctx, session, claims.role, claims.subject, op_id):
        return False
    ctx.problem(
        session,
        "auth",
        op_id,
        f"authenticated {claims.subject!r} with role {claims.role!r} (token)",
        StatusLevel.INFO,
    )
    return True


def admit(
    ctx: Context, session: ClientSession, role: str | None, principal: str, op_id: OpId
) -> bool:
    """Give the client its role (`bridge.roles`); refused (unknown role, too many
    connections of the principal) closes it."""
    policy = ctx.state.policy
    problem = policy.grant(session, role, principal, ctx.state.sessions.values(), ctx.now_ns)
    if problem is not None:
        refuse(ctx, session, op_id, f"authentication refused: {problem}")
        return False
    session.authenticated = True
    policy.record(session, "auth", principal, ctx.now_ns, "allowed")
    return True


def refuse(
    ctx: Context, session: ClientSession, op_id: OpId, problem: str, reason: str | None = None
) -> None:
    """Log, audit and close (1008) with `reason` (default: the problem, cut to fit a close
    frame's 123 bytes)."""
    ctx.problem(session, "auth", op_id, f"{problem}; closing")
    ctx.state.policy.record(session, "auth", session.principal, ctx.now_ns, "refused", problem)
    shown = (reason or problem).encode("utf-8")[:120].decode("utf-8", "ignore")
    ctx.close(session.client_id, POLICY_VIOLATION, shown)
    session.closing = True


def on_grace_deadline(ctx: Context, client_id: int) -> None:
    """`--auth-grace` passed: a client that has not authenticated is closed."""
    session = ctx.state.sessions.get(client_id)
    if session is None or session.authenticated or session.closing:
        return
    grace_s = ctx.state.config.auth_grace_s
    refuse(ctx, session, None, f"not authenticated within {grace_s:g} s")


ROUTES = (route(Auth, handle_auth),)
