"""Text tables from column definitions: one :class:`Column` per column, one renderer.

A column names its title and unit, where its value comes from (an attribute path such as
``"stats.p99"``, or a function of the row) and how to format it; :func:`render_table` sizes
every column to its widest cell. The report's tables are lists of columns in
:mod:`clients.report.text`, so a new column is one entry there.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Generic, Literal, TypeVar

Row = TypeVar("Row")


def fmt_bytes(count: float | None) -> str:
    """``2.86 MB``, ``13.10 kB``, ``316 B``; ``-`` for nothing or NaN."""
    if not count or math.isnan(count):
        return "-"
    for unit, size in (("MB", 1e6), ("kB", 1e3)):
        if count >= size:
            return f"{count / size:.2f} {unit}"
    return f"{count:.0f} B"


def fmt_ms(value: float | None) -> str:
    """Milliseconds with two decimals; ``-`` for None or NaN."""
    return "-" if value is None or math.isnan(value) else f"{value:.2f}"


def fmt_ratio(value: float | None, digits: int = 2) -> str:
    """``5.56x``; ``-`` for None or NaN."""
    return "-" if value is None or math.isnan(value) else f"{value:.{digits}f}x"


def fmt_ratio3(value: float | None) -> str:
    return fmt_ratio(value, 3)


def fmt_fraction(value: float | None, digits: int = 3) -> str:
    """A precision or recall: ``0.975``; ``-`` for None or NaN."""
    return "-" if value is None or math.isnan(value) else f"{value:.{digits}f}"


def fmt_float1(value: float | None) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.1f}"


def fmt_text(value: object) -> str:
    return "" if value is None else str(value)


@dataclass(frozen=True)
class Column(Generic[Row]):
    """One column of a text table.

    title, unit : the header, ``"title unit"`` (unit may be empty).
    source : an attribute path of the row (``"summary.rate_hz"``) or a function of the row.
    fmt : the cell text of the value. align : ``">"`` numbers, ``"<"`` text.
    """

    title: str
    source: str | Callable[[Row], object]
    fmt: Callable[..., str] = fmt_text
    unit: str = ""
    align: Literal["<", ">"] = ">"

    @property
    def header(self) -> str:
        return f"{self.title} {self.unit}" if self.unit else self.title

    def cell(self, row: Row) -> str:
        get = operator.attrgetter(self.source) if isinstance(self.source, str) else self.source
        return self.fmt(get(row))


def text_column(title: str, source: str | Callable[[Row], object]) -> Column[Row]:
    """A left-aligned text column."""
    return Column(title, source, fmt_text, align="<")


def render_table(
    columns: Sequence[Column[Row]], rows: Sequence[Row], indent: str = "  "
) -> list[str]:
    """The header line and one line per row, columns two spaces apart, each as wide as its
    widest cell; trailing blanks stripped (a last text column is not padded)."""
    cells = [[column.cell(row) for column in columns] for row in rows]
    widths = [
        max([len(column.header), *(len(line[k]) for line in cells)])
        for k, column in enumerate(columns)
    ]

    def line(texts: Sequence[str]) -> str:
        parts = [
            f"{text:{column.align}{width}}"
            for text, column, width in zip(texts, columns, widths, strict=True)
        ]
        return (indent + "  ".join(parts)).rstrip()

    return [line([column.header for column in columns]), *(line(texts) for texts in cells)]
