"""Bridge tokens (schemas.tokens): HS256 only, signature, expiry, claims; time passed in."""

from __future__ import annotations

import base64
import json

import jwt
import pytest

from schemas import tokens

SECRET = "a-secret-of-at-least-thirty-two-bytes!"
NOW_S = 1_800_000_000.0


def test_a_token_round_trips_its_claims():
    token = tokens.issue(SECRET, "observer", "dashboard", NOW_S, 60)
    assert tokens.looks_like_token(token)
    claims = tokens.verify(SECRET, token, NOW_S + 59)
    assert claims == tokens.Claims("dashboard", "observer", NOW_S + 60)
    forever = tokens.verify(SECRET, tokens.issue(SECRET, "r", "s", NOW_S, None), NOW_S + 1e9)
    assert forever.expires_s is None


def test_expiry_has_a_small_leeway_for_clock_skew():
    token = tokens.issue(SECRET, "observer", "dashboard", NOW_S, 60)
    tokens.verify(SECRET, token, NOW_S + 60 + tokens.LEEWAY_S)
    with pytest.raises(tokens.TokenError, match="token expired 6 s ago"):
        tokens.verify(SECRET, token, NOW_S + 66)


def unsigned(claims: dict) -> str:
    """A token with `alg: none`: the classic forgery a JWT library must refuse."""

    def part(value: dict) -> str:
        return base64.urlsafe_b64encode(json.dumps(value).encode()).rstrip(b"=").decode()

    return f"{part({'alg': 'none', 'typ': 'JWT'})}.{part(claims)}."


@pytest.mark.parametrize(
    ("token", "why"),
    [
        (tokens.issue("another-secret-of-32-bytes-or-more", "r", "s", NOW_S, 60), "signature"),
        (unsigned({"sub": "mallory", "role": "operator"}), "malformed token"),
        (jwt.encode({"sub": "s", "role": "r"}, SECRET * 2, algorithm="HS512"), "malformed token"),
        (jwt.encode({"role": "operator"}, SECRET, algorithm="HS256"), "lacks a role"),
        (jwt.encode({"sub": "s", "role": 7}, SECRET, algorithm="HS256"), "lacks a role"),
        (jwt.encode({"sub": "s", "role": "r", "exp": "soon"}, SECRET), "exp is not a number"),
        ("x" * 5000, "too long"),
        ("not.a.token", "malformed token"),
    ],
    ids=[
        "forged",
        "alg-none",
        "other-alg",
        "no-subject",
        "role-not-text",
        "bad-exp",
        "huge",
        "junk",
    ],
)
def test_tokens_that_grant_nothing(token, why):
    with pytest.raises(tokens.TokenError, match=why):
        tokens.verify(SECRET, token, NOW_S)


def test_a_changed_claim_breaks_the_signature():
    header, _, signature = tokens.issue(SECRET, "observer", "s", NOW_S, 60).split(".")
    raised = (
        base64.urlsafe_b64encode(
            json.dumps({"sub": "s", "role": "operator", "iat": int(NOW_S)}).encode()
        )
        .rstrip(b"=")
        .decode()
    )
    with pytest.raises(tokens.TokenError, match="signature"):
        tokens.verify(SECRET, f"{header}.{raised}.{signature}", NOW_S)
