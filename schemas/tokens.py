"""Bridge access tokens: HS256 JSON Web Tokens (PyJWT) signed with the bridge's secret.

`riverbridge token` issues them; the bridge checks them (`verify`) wherever a client presents
one: the rosauth `auth` op's `mac`, `Authorization: Bearer`, or `?token=`. A token carries the
role (`role`), the principal (`sub`), when it was issued (`iat`) and when it ends (`exp`).
The time is passed in (`now_s`), never read here, so the check is the same in the sans-I/O
core and in tests with a fake clock. PyJWT (which loads `cryptography`) is imported with the
first token: ~8 MiB of resident memory that a bridge nobody presents a token to never carries.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

ALGORITHM = "HS256"
# Clocks of the issuing host and the bridge may differ a little.
LEEWAY_S = 5.0
MAX_TOKEN_CHARS = 4096  # far above a real token (~200 characters); refuse larger at once
# RFC 7518 §3.2: an HS256 key should have at least 256 bits. rosauth's secrets are 16
# characters; `riverbridge token` says so once (`short_secret`) instead of PyJWT warning at
# every check.
MIN_SECRET_BYTES = 32


def short_secret(secret: str) -> bool:
    return len(secret.encode("utf-8")) < MIN_SECRET_BYTES


class TokenError(ValueError):
    """A token that does not grant anything: forged, expired, malformed; says which."""


@dataclass(frozen=True)
class Claims:
    """What a valid token grants."""

    subject: str
    role: str
    expires_s: float | None


def looks_like_token(text: str) -> bool:
    """A JWT's shape (three dot-separated parts), as opposed to rosauth's hex MAC."""
    return text.count(".") == 2


def issue(secret: str, role: str, subject: str, now_s: float, ttl_s: float | None) -> str:
    """A signed token for `role` as `subject`, valid for `ttl_s` seconds (None: no end)."""
    claims: dict[str, object] = {"sub": subject, "role": role, "iat": int(now_s)}
    if ttl_s is not None:
        claims["exp"] = int(now_s + ttl_s)
    import jwt
    from jwt.warnings import InsecureKeyLengthWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InsecureKeyLengthWarning)
        return jwt.encode(claims, secret, algorithm=ALGORITHM)


def verify(secret: str, token: str, now_s: float) -> Claims:
    """The claims of a token signed with `secret` and valid at `now_s` (else TokenError)."""
    if len(token) > MAX_TOKEN_CHARS:
        raise TokenError("token too long")
    import jwt
    from jwt.warnings import InsecureKeyLengthWarning

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InsecureKeyLengthWarning)
            claims = jwt.decode(
                token,
                secret,
                algorithms=[ALGORITHM],
                options={"verify_exp": False, "verify_iat": False, "verify_nbf": False},
            )
    except jwt.InvalidSignatureError:
        raise TokenError("token signature does not match (forged, or another secret)") from None
    except jwt.InvalidTokenError as exc:
        raise TokenError(f"malformed token: {exc}") from None
    role, subject, expires = claims.get("role"), claims.get("sub"), claims.get("exp")
    if not isinstance(role, str) or not isinstance(subject, str) or not subject:
        raise TokenError("token lacks a role or a subject")
    if expires is not None:
        if not isinstance(expires, int | float):
            raise TokenError("token's exp is not a number")
        if now_s > expires + LEEWAY_S:
            raise TokenError(f"token expired {now_s - expires:.0f} s ago")
    return Claims(subject, role, float(expires) if expires is not None else None)


__all__ = [
    "ALGORITHM",
    "Claims",
    "TokenError",
    "issue",
    "looks_like_token",
    "short_secret",
    "verify",
]
