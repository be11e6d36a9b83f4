"""False-alarm probabilities of the CFAR detectors and the threshold factors that meet them.

Model: square-law detected Rayleigh clutter, i.e. exponentially distributed cell power with
an unknown mean (thesis 2.5.2-2.5.3, eq. 2.5.9). Every detector compares the cell under test
with ``factor * Z``, Z its noise estimate in units of mean cell power:

* CA: Z = mean of all N reference cells; P_fa = (1 + a/N)**-N, inverted in closed form.
* SOCA / GOCA: Z = smaller / larger of the two side means of n cells each; with T = a/n on
  the side sums (Gandhi and Kassam 1988; Richards, Fundamentals of Radar Signal Processing
  §6.5.4), P_SO = 2 (2+T)**-n * sum_{k<n} C(n-1+k, k) (2+T)**-k and P_GO = 2 (1+T)**-n - P_SO.
* OS: Z = k-th smallest of N cells; P_fa = prod_{i<k} (N-i) / (N-i+a) (Rohling 1983; thesis
  eq. 2.5.11).

SOCA, GOCA and OS are solved numerically for the factor, once per configuration.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq
from scipy.special import gammaln, logsumexp


def ca_pfa(factor: float, n_cells: int) -> float:
    """P_fa of cell-averaging CFAR over ``n_cells`` reference cells."""
    return float((1.0 + factor / n_cells) ** -n_cells)


def ca_factor(pfa: float, n_cells: int) -> float:
    """Closed-form CA factor for the requested P_fa."""
    return float(n_cells * (pfa ** (-1.0 / n_cells) - 1.0))


def _log_soca_pfa(t_sum: float, n_side: int) -> float:
    """log P_SO for a factor ``t_sum`` on the side sums, summed in the log domain."""
    k = np.arange(n_side)
    log_binom = gammaln(n_side + k) - gammaln(k + 1) - gammaln(n_side)
    return float(np.log(2.0) + logsumexp(log_binom - (n_side + k) * np.log(2.0 + t_sum)))


def soca_pfa(factor: float, n_side: int) -> float:
    """P_fa of smallest-of CFAR; ``factor`` multiplies the smaller side mean."""
    return float(np.exp(_log_soca_pfa(factor / n_side, n_side)))


def goca_pfa(factor: float, n_side: int) -> float:
    """P_fa of greatest-of CFAR; ``factor`` multiplies the larger side mean."""
    t_sum = factor / n_side
    return float(2.0 * (1.0 + t_sum) ** -n_side - np.exp(_log_soca_pfa(t_sum, n_side)))


def os_pfa(factor: float, n_cells: int, rank: int) -> float:
    """P_fa of order-statistic CFAR; ``factor`` multiplies the ``rank``-th smallest cell."""
    i = np.arange(rank)
    return float(np.exp(np.sum(np.log(n_cells - i) - np.log(n_cells - i + factor))))


def solve_factor(pfa_of_factor: Callable[[float], float], pfa: float) -> float:
    """Factor a >= 0 with pfa_of_factor(a) == pfa, for a P_fa falling monotonically in a."""
    if not 0.0 < pfa < 1.0:
        raise ValueError(f"false-alarm rate must lie in (0, 1), got {pfa}")
    target = np.log(pfa)
    upper = 1.0
    while np.log(pfa_of_factor(upper)) > target:
        upper *= 2.0
        if upper > 1e12:
            raise ValueError(f"no threshold factor reaches P_fa {pfa}")
    return float(
        brentq(lambda a: np.log(pfa_of_factor(a)) - target, 0.0, upper, xtol=1e-12, rtol=1e-12)
    )


def detector_factor(kind: str, pfa: float, n_side: int, rank: int | None = None) -> float:
    """Threshold factor for a detector with ``n_side`` training cells on each side."""
    if kind == "ca":
        return ca_factor(pfa, 2 * n_side)
    if kind == "soca":
        return solve_factor(lambda a: soca_pfa(a, n_side), pfa)
    if kind == "goca":
        return solve_factor(lambda a: goca_pfa(a, n_side), pfa)
    if kind == "os":
        if rank is None:
            raise ValueError("OS-CFAR needs a rank")
        return solve_factor(lambda a: os_pfa(a, 2 * n_side, rank), pfa)
    raise ValueError(f"unknown CFAR detector {kind!r}")
