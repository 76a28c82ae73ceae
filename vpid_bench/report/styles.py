"""One style per optimizer for every figure of the report (PNG and SVG alike), so that 20
optimizers and more keep every line apart (evenly spaced hues alone give five greens): the
i-th optimizer by name gets the colour ``PALETTE[i % 10]``, the dashes ``DASHES[(i // 10) %
4]`` ((colour, dash) differs for the first 40) and the marker ``MARKERS[i % 7]`` (two of one
colour share no shape below 70). :func:`assign` is the ONE mapping; every figure looks its
optimizers up in the whole report's (:func:`of_report`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

#: ``tab10``, matplotlib's default qualitative palette.
PALETTE: tuple[str, ...] = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                            "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")
#: Dash patterns, in line widths: (name, on-off sequence; empty: solid).
DASHES: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("solid", ()), ("dashed", (6.0, 3.0)), ("dotted", (1.2, 2.4)),
    ("dash-dot", (6.0, 2.5, 1.2, 2.5)))
#: Marker shapes, by their matplotlib names (:mod:`.svg` draws the same shapes).
MARKERS: tuple[str, ...] = ("o", "s", "^", "D", "v", "P", "X")
#: Markers along a line: one every this fraction of the axes' diagonal (``markevery``), each
#: optimizer's first shifted so that equal curves keep them apart.
MARK_SPACING = 0.18


@dataclasses.dataclass(frozen=True)
class Style:
    """How one optimizer is drawn; ``index`` (its place in the report) shifts its markers."""

    colour: str
    dash: str
    marker: str
    index: int = 0

    @property
    def pattern(self) -> tuple[float, ...]:
        """The dash pattern's on-off lengths in line widths (empty: solid)."""
        return dict(DASHES)[self.dash]

    @property
    def offset(self) -> float:
        """Where along the line (fraction of :data:`MARK_SPACING`) its first marker sits."""
        return (self.index * 0.37) % 1.0

    def mpl(self) -> dict[str, Any]:
        """Keyword arguments of matplotlib's ``plot``/``step`` for this style."""
        return {"color": self.colour, "linestyle": (0, self.pattern) if self.pattern else "-",
                "marker": self.marker, "markersize": 4.5,
                "markevery": (MARK_SPACING * (0.1 + 0.8 * self.offset), MARK_SPACING)}


def style(index: int) -> Style:
    """The style of the ``index``-th optimizer (see the module)."""
    return Style(PALETTE[index % len(PALETTE)],
                 DASHES[(index // len(PALETTE)) % len(DASHES)][0],
                 MARKERS[index % len(MARKERS)], index)


def assign(names: Iterable[str]) -> dict[str, Style]:
    """The style of each optimizer of ``names`` (sorted, duplicates once)."""
    return {name: style(i) for i, name in enumerate(sorted(set(names)))}


def of_report(data: Any) -> dict[str, Style]:
    """The mapping of a report: every optimizer of its runs."""
    return assign(r["algorithm"] for r in data.rows)


def lookup(style_of: Mapping[str, Style] | None, names: Iterable[str]) -> dict[str, Style]:
    """``style_of`` where it names all ``names``, else :func:`assign` of ``names``."""
    names = list(names)
    if style_of is not None and all(n in style_of for n in names):
        return dict(style_of)
    return assign(names)


def legend(ax: Any, n: int, **kw: Any) -> Any:
    """A legend of ``n`` lines showing dashes and markers: inside the axes up to six, or beside."""
    where: dict[str, Any] = ({"loc": "best"} if n <= 6 else
                             {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0),
                              "borderaxespad": 0.0})
    return ax.legend(fontsize=8, handlelength=3.4, **where, **kw)
