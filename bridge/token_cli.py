"""`riverbridge token`: print a bridge token (an HS256 JWT, `schemas.tokens`) for a role.

    riverbridge token --role observer --secret-file SECRET [--ttl SECONDS] [--subject NAME]

The bridge started with `--auth-secret-file SECRET --roles FILE` accepts it in the `auth`
op's `mac`, as `Authorization: Bearer`, or as `?token=`; the subject is the principal its
limits, metrics and audit entries are counted under.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from schemas import tokens
from schemas.roles_config import load_roles
from schemas.rosauth import read_secret


def positive_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverbridge token", description="Print a signed bridge token for a role."
    )
    parser.add_argument("--role", required=True, help="the role the token grants")
    parser.add_argument(
        "--secret-file",
        required=True,
        type=Path,
        metavar="FILE",
        help="the bridge's --auth-secret-file (the secret on its first line)",
    )
    parser.add_argument(
        "--ttl",
        type=positive_seconds,
        metavar="SECONDS",
        help="seconds until the token expires (default: it never does)",
    )
    parser.add_argument(
        "--subject", metavar="NAME", help="the principal the token names (default: the role)"
    )
    parser.add_argument(
        "--roles",
        type=Path,
        metavar="FILE",
        help="refuse a role this roles file does not name (a typo would be refused later)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        secret = read_secret(args.secret_file)
    except (OSError, ValueError) as exc:
        parser.error(f"argument --secret-file: {exc}")
    if args.roles is not None:
        try:
            known = load_roles(args.roles).roles
        except ValueError as exc:
            parser.error(f"argument --roles: {exc}")
        if args.role not in known:
            parser.error(f"argument --role: {args.role!r} is not a role of {args.roles}")
    if tokens.short_secret(secret):
        print(
            f"riverbridge token: warning: the secret is shorter than {tokens.MIN_SECRET_BYTES} "
            "bytes; HS256 wants at least 32 (e.g. `openssl rand -hex 32 > FILE`)",
            file=sys.stderr,
        )
    subject = args.subject or args.role
    print(tokens.issue(secret, args.role, subject, time.time(), args.ttl))
    return 0


if __name__ == "__main__":
    sys.exit(main())
