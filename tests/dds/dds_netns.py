"""Two "hosts" on one machine: network namespaces joined by a veth pair (iproute2).

Each namespace gets one end of the pair with its own address and its own loopback; nothing
is routed to the machine's real interfaces, so DDS discovery and data stay between the two.
`two_hosts()` skips the test, saying why, where namespaces cannot be made (not root, no
`ip`), and deletes the namespaces (and with them the veth pair) however the test ends.
`shape_link()` makes one end behave like a WLAN link for the benchmark: `tc netem` where the
kernel has it, else `tbf` for the rate and an iptables `statistic` rule for loss (no delay).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

SUBNET_PREFIX = "10.231.77"  # lives only inside the two namespaces


@dataclass(frozen=True)
class Host:
    """One namespace: its name, its veth end and that end's address."""

    namespace: str
    interface: str
    address: str

    def command(self, argv: Sequence[str]) -> list[str]:
        """`argv` run inside this namespace."""
        return ["ip", "netns", "exec", self.namespace, *argv]


class NamespaceError(RuntimeError):
    """An `ip` command failed; the message quotes it."""


def ip(*args: str) -> None:
    completed = subprocess.run(["ip", *args], capture_output=True, text=True, check=False)
    if completed.returncode != 0:
        raise NamespaceError(f"`ip {' '.join(args)}` failed: {completed.stderr.strip()}")


def why_not() -> str | None:
    """The reason namespaces cannot be made here, or None."""
    if shutil.which("ip") is None:
        return "iproute2's `ip` is not installed"
    if os.geteuid() != 0:
        return "creating network namespaces needs root (CAP_NET_ADMIN)"
    return None


@contextlib.contextmanager
def two_hosts(tag: str = "") -> Iterator[tuple[Host, Host]]:
    """Namespaces A and B joined by a veth pair: A is .1, B is .2 of SUBNET_PREFIX/24."""
    suffix = f"{os.getpid() % 100000}{tag}"
    a = Host(f"rbA{suffix}", f"rbva{suffix}"[:15], f"{SUBNET_PREFIX}.1")
    b = Host(f"rbB{suffix}", f"rbvb{suffix}"[:15], f"{SUBNET_PREFIX}.2")
    made: list[str] = []
    try:
        for host in (a, b):
            ip("netns", "add", host.namespace)
            made.append(host.namespace)
        ip("link", "add", a.interface, "type", "veth", "peer", "name", b.interface)
        for host in (a, b):
            ip("link", "set", host.interface, "netns", host.namespace)
            ip("-n", host.namespace, "addr", "add", f"{host.address}/24", "dev", host.interface)
            ip("-n", host.namespace, "link", "set", host.interface, "up")
            ip("-n", host.namespace, "link", "set", "lo", "up")
        yield a, b
    finally:
        for namespace in made:  # deleting a namespace deletes the veth end inside it
            with contextlib.suppress(NamespaceError):
                ip("netns", "del", namespace)


@dataclass(frozen=True)
class LinkShape:
    """WLAN-like link figures applied to each direction of the veth pair."""

    rate_mbit: float
    delay_ms: float
    jitter_ms: float
    loss_percent: float

    def describe(self) -> str:
        return (
            f"{self.rate_mbit:g} Mbit/s, {self.delay_ms:g} ms ± {self.jitter_ms:g} ms, "
            f"{self.loss_percent:g} % loss"
        )


def bridge_argv(
    host: Host | None, peer: Host | None, domain: int | None, *options: str
) -> list[str]:
    """`python -m bridge` on 127.0.0.1, port 0, with `options`: in `host`'s namespace when
    given, a participant of DDS `domain` when given, reaching `peer` over `host`'s link."""
    argv = [sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", "0", *options]
    if domain is not None:
        argv += ["--dds", "--domain", str(domain)]
    if host is not None and peer is not None:
        argv += ["--dds-interface", host.interface, "--dds-peer", peer.address]
    return host.command(argv) if host is not None else argv


def shape_link(host: Host, shape: LinkShape) -> str:
    """Shape `host`'s outgoing traffic; returns what was applied (netem, or the fallback)."""
    root_qdisc = ["tc", "qdisc", "add", "dev", host.interface, "root"]
    netem = [
        *root_qdisc,
        "netem",
        "delay",
        f"{shape.delay_ms}ms",
        f"{shape.jitter_ms}ms",
        "distribution",
        "normal",
        "loss",
        f"{shape.loss_percent}%",
        "rate",
        f"{shape.rate_mbit}mbit",
    ]
    if _run(host.command(netem)):
        return f"netem: {shape.describe()}"
    burst_bytes = max(32 * 1024, int(shape.rate_mbit * 1e6 / 8 / 100))  # ~10 ms of traffic
    tbf = [
        *root_qdisc,
        "tbf",
        "rate",
        f"{shape.rate_mbit}mbit",
        "burst",
        str(burst_bytes),
        "latency",
        "200ms",
    ]
    applied = []
    if _run(host.command(tbf)):
        applied.append(f"tbf {shape.rate_mbit:g} Mbit/s")
    loss = [
        "iptables",
        "-A",
        "OUTPUT",
        "-o",
        host.interface,
        "-m",
        "statistic",
        "--mode",
        "random",
        "--probability",
        f"{shape.loss_percent / 100}",
        "-j",
        "DROP",
    ]
    if shape.loss_percent > 0 and _run(host.command(loss)):
        applied.append(f"iptables {shape.loss_percent:g} % loss")
    missing = "no delay/jitter (this kernel has no netem)"
    return ", ".join([*applied, missing])


def _run(argv: list[str]) -> bool:
    return subprocess.run(argv, capture_output=True, check=False).returncode == 0
