"""CFAR detection, all cells of a polar radar image at once (thesis 2.5.2-2.5.4, table 4.2).

The image is power : (beams, cells) float, one row per azimuth beam, one column per range
cell. For each cell under test (CUT) the reference cells are ``n`` training cells on each
side beyond ``g`` guard cells, along one axis of the image (``CfarConfig.axis``):

* ``"azimuth"`` (default): the neighbours at the same range in the beams on either side. The
  beams close a ring, so every cell has both sides complete (the window wraps around) and the
  reference cells share the CUT's range, where the ray-cast water returns are the same in
  every beam; along range they come in rings (docs/quality.md).
* ``"range"``: the neighbours along the beam. Near the ends of a row only one side is
  complete: those cells use that side alone, with the factor solved for ``n`` cells, so the
  false-alarm rate holds there too.

A window longer than its axis is an error naming the field, never silently shrunk. Side sums
come from one cumulative sum per image; OS-CFAR partitions a strided window view.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from navigation.cfar_pfa import ca_factor, detector_factor, os_pfa, solve_factor
from navigation.config import CfarConfig


class CfarWindowError(ValueError):
    """The configured window does not fit the image along its axis."""


@dataclass(frozen=True)
class CfarDetector:
    """A configured detector with its threshold factors solved once.

    factor : multiplies the noise estimate where both sides are complete.
    edge_factor : multiplies the one-sided estimate near the row ends (range axis only).
    """

    kind: str
    axis: str
    n_side: int
    n_guard: int
    false_alarm_rate: float
    rank: int
    edge_rank: int
    factor: float
    edge_factor: float

    @classmethod
    def from_config(cls, config: CfarConfig) -> CfarDetector:
        """Solve the factors for ``config`` (its window as configured: see ``check_fits``)."""
        n = config.training_cells_per_side
        rank = config.os_rank if config.os_rank is not None else max(1, (3 * 2 * n) // 4)
        edge_rank = max(1, min(n, round(rank / 2)))
        pfa = config.false_alarm_rate
        factor = detector_factor(config.detector, pfa, n, rank)
        if config.detector == "os":
            edge_factor = solve_factor(lambda a: os_pfa(a, n, edge_rank), pfa)
        else:
            edge_factor = ca_factor(pfa, n)  # one side alone is a CA over n cells
        return cls(
            config.detector,
            config.axis,
            n,
            config.guard_cells_per_side,
            pfa,
            rank,
            edge_rank,
            factor,
            edge_factor,
        )

    @property
    def span(self) -> int:
        """Cells of one full window: both training sides, both guard sides and the CUT."""
        return 2 * (self.n_side + self.n_guard) + 1

    def check_fits(self, beams: int, cells: int) -> None:
        """Raise CfarWindowError, naming the fields, unless one full window fits the axis:
        ``span`` distinct beams of the ring (azimuth) or cells of a row (range)."""
        length, what = (beams, "beams") if self.axis == "azimuth" else (cells, "range cells")
        if self.span > length:
            raise CfarWindowError(
                f"cfar.training_cells_per_side = {self.n_side} and cfar.guard_cells_per_side = "
                f"{self.n_guard} need {self.span} {what} along cfar.axis = '{self.axis}', the "
                f"radar image has {length}: lower them (at most "
                f"{max(0, (length - 1) // 2 - self.n_guard)} training cells per side)"
            )

    def threshold(self, power: np.ndarray) -> np.ndarray:
        """Detection threshold per cell: (beams, cells) -> (beams, cells) float32, +inf where
        no reference side is complete. Raises CfarWindowError if the window does not fit."""
        power = np.asarray(power, dtype=np.float32)
        self.check_fits(*power.shape)
        if self.axis == "range":
            return self._row_threshold(power)
        if self.kind != "os":
            lead, lag = ring_side_sums(power, self.n_side, self.n_guard)
            noise = _COMBINE_SIDES[self.kind](lead / self.n_side, lag / self.n_side)
            return (self.factor * noise).astype(np.float32)
        pad = self.n_side + self.n_guard  # OS: wrap the beams, rank, cut the pad off
        rows = np.pad(power.T, ((0, 0), (pad, pad)), mode="wrap")
        noise, _, _ = self._os_estimates(rows, edges=False)
        return np.ascontiguousarray((self.factor * noise[:, pad:-pad]).T, dtype=np.float32)

    def detect(self, power: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cells whose power exceeds the threshold: mask (beams, cells) bool, threshold."""
        threshold = self.threshold(power)
        return np.asarray(power) > threshold, threshold

    def _row_threshold(self, rows: np.ndarray) -> np.ndarray:
        """Thresholds along the last axis of rows : (r, c) float32 -> (r, c) float32."""
        lead, lag = side_sums(rows, self.n_side, self.n_guard)
        if self.kind == "os":
            noise_both, noise_lead, noise_lag = self._os_estimates(rows)
        else:
            noise_lead = lead / self.n_side
            noise_lag = lag / self.n_side
            noise_both = _COMBINE_SIDES[self.kind](noise_lead, noise_lag)
        out = np.where(np.isnan(lead), noise_lag, noise_lead) * self.edge_factor
        both = ~(np.isnan(lead) | np.isnan(lag))
        out[both] = self.factor * noise_both[both]
        out[np.isnan(out)] = np.inf
        return out.astype(np.float32)

    def _os_estimates(
        self, rows: np.ndarray, edges: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Order statistics: rank-th of both sides, edge_rank-th of each side alone (unless
        ``edges`` is False: wrapped rows have no ends)."""
        n, g = self.n_side, self.n_guard
        count, cells = rows.shape
        both = np.full((count, cells), np.nan)
        lead = np.full((count, cells), np.nan)
        lag = np.full((count, cells), np.nan)
        span = self.span
        if cells >= span:
            windows = sliding_window_view(rows, span, axis=1)
            training = np.concatenate([windows[..., :n], windows[..., n + 2 * g + 1 :]], axis=-1)
            both[:, n + g : cells - n - g] = _kth_smallest(training, self.rank)
        if edges and cells >= n + g + 1:
            # Only cells missing the other side need a one-sided estimate.
            sides = sliding_window_view(rows, n, axis=1)  # sides[:, s] covers s .. s+n-1
            lag_cells = np.arange(min(n + g, cells - n - g))  # no complete lead side
            lead_cells = np.arange(max(cells - n - g, n + g), cells)  # no complete lag side
            lag[:, lag_cells] = _kth_smallest(sides[:, lag_cells + g + 1], self.edge_rank)
            lead[:, lead_cells] = _kth_smallest(sides[:, lead_cells - g - n], self.edge_rank)
        return both, lead, lag


def _mean(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    return 0.5 * (a + b)


# How CA, SOCA and GOCA turn the two side means into one noise estimate (thesis eq. 2.5.12).
_COMBINE_SIDES: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "ca": _mean,
    "soca": np.fmin,
    "goca": np.fmax,
}


def _kth_smallest(windows: np.ndarray, rank: int) -> np.ndarray:
    """rank-th smallest (1-based) along the last axis: (..., w) -> (...)."""
    return np.partition(windows, rank - 1, axis=-1)[..., rank - 1]


def ring_side_sums(power: np.ndarray, n_side: int, n_guard: int) -> tuple[np.ndarray, np.ndarray]:
    """Sums of the training windows of every cell along the ring of beams (axis 0, wrapping).

    power : (beams, cells) -> lead, lag : (beams, cells) float64. Lead covers beams
    i-g-n .. i-g-1, lag i+g+1 .. i+g+n, both modulo the beam count; one cumulative sum over
    the beams, and a window that runs past the last beam adds the part from beam 0 on.
    """
    beams = power.shape[0]
    csum = np.zeros((beams + 1, power.shape[1]), dtype=np.float64)
    np.cumsum(power, axis=0, out=csum[1:])
    index = np.arange(beams)

    def window(first: np.ndarray) -> np.ndarray:
        start = first % beams
        stop = start + n_side
        sums: npt.NDArray[np.float64] = csum[np.minimum(stop, beams)] - csum[start]
        wraps = stop > beams
        sums[wraps] += csum[stop[wraps] - beams]
        return sums

    return window(index - n_guard - n_side), window(index + n_guard + 1)


def side_sums(power: np.ndarray, n_side: int, n_guard: int) -> tuple[np.ndarray, np.ndarray]:
    """Sums of the leading and lagging training windows of every cell along the last axis.

    power : (rows, cells) -> lead, lag : (rows, cells) float64, NaN where the window
    leaves the row. Lead covers cells i-g-n .. i-g-1, lag covers i+g+1 .. i+g+n.
    """
    rows, cells = power.shape
    n, g = n_side, n_guard
    csum = np.zeros((rows, cells + 1), dtype=np.float64)
    np.cumsum(power, axis=1, out=csum[:, 1:])
    lead = np.full((rows, cells), np.nan)
    lag = np.full((rows, cells), np.nan)
    if cells > n + g:
        lead[:, n + g :] = csum[:, n : cells - g] - csum[:, : cells - g - n]
        lag[:, : cells - n - g] = csum[:, g + n + 1 :] - csum[:, g + 1 : cells - n + 1]
    return lead, lag
