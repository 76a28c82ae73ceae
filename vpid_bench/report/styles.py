"""One style per optimizer for every figure of the report: a colour, a dash pattern and a
marker shape, so that a figure of up to 20 optimizers (and more) keeps every line apart.

A qualitative palette alone fails past ten lines: evenly spaced hues for 19 optimizers give
five or six greens no one tells apart. So the i-th optimizer (the report's optimizers sorted
by name) gets

* the colour ``PALETTE[i % 10]`` (matplotlib's and seaborn's qualitative ``tab10``),
* the dash pattern ``DASHES[(i // 10) % 4]`` (solid for the first ten, then dashed, dotted,
  dash-dot): (colour, dash) differs for every pair of the first 40 optimizers,
* the marker ``MARKERS[i % 7]`` (seven shapes: seven and ten share no factor, so two
  optimizers of one colour never share a shape below 70), a few per line.

:func:`assign` is the ONE mapping: the PNG figures (:mod:`.anytime`, :mod:`.figures`,
:mod:`.suite_scores`) and the HTML's SVG figures (:mod:`.svg`) all look their optimizers up
in the mapping of the whole report (:func:`of_report`), so an optimizer has the same style in
every figure of a report, whichever subset of optimizers a figure shows.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

#: ``tab10``, the qualitative palette of matplotlib's default cycle and of seaborn's
#: ``deep``/``tab10`` family: ten colours that stay apart for colour-normal readers.
PALETTE: tuple[str, ...] = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                            "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")
#: Dash patterns, in line widths: (name, on-off sequence; empty: solid).
DASHES: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("solid", ()), ("dashed", (6.0, 3.0)), ("dotted", (1.2, 2.4)),
    ("dash-dot", (6.0, 2.5, 1.2, 2.5)))
#: Marker shapes, by their matplotlib names (:mod:`.svg` draws the same shapes).
MARKERS: tuple[str, ...] = ("o", "s", "^", "D", "v", "P", "X")
#: Markers along a line: one every this fraction of the axes' diagonal (matplotlib's
#: ``markevery``), each optimizer's first one shifted so that markers of equal curves do
#: not sit on one another.
MARK_SPACING = 0.18


@dataclasses.dataclass(frozen=True)
class Style:
    """How one optimizer is drawn: ``colour`` (hex), ``dash`` (a name of :data:`DASHES`),
    ``marker`` (a name of :data:`MARKERS`); ``index`` is its place in the report's sorted
    optimizers (it shifts the markers along the line)."""

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

    def key(self) -> tuple[str, str, str]:
        """What tells it apart from another style: (colour, dash, marker)."""
        return self.colour, self.dash, self.marker

    def mpl(self, markers: bool = True) -> dict[str, Any]:
        """Keyword arguments of matplotlib's ``plot``/``step`` for this style."""
        kw: dict[str, Any] = {"color": self.colour,
                              "linestyle": (0, self.pattern) if self.pattern else "-"}
        if markers:
            kw.update(marker=self.marker, markersize=4.5, markevery=(
                MARK_SPACING * (0.1 + 0.8 * self.offset), MARK_SPACING))
        return kw


def style(index: int) -> Style:
    """The style of the ``index``-th optimizer (see the module)."""
    return Style(PALETTE[index % len(PALETTE)],
                 DASHES[(index // len(PALETTE)) % len(DASHES)][0],
                 MARKERS[index % len(MARKERS)], index)


def assign(names: Iterable[str]) -> dict[str, Style]:
    """The style of each optimizer of ``names`` (sorted, duplicates once): the one mapping
    every figure of a report uses."""
    return {name: style(i) for i, name in enumerate(sorted(set(names)))}


def of_report(data: Any) -> dict[str, Style]:
    """The mapping of a report (a :class:`~.compute.ReportData`): every optimizer of its
    runs."""
    return assign(r["algorithm"] for r in data.rows)


def lookup(style_of: Mapping[str, Style] | None, names: Iterable[str]) -> dict[str, Style]:
    """``style_of`` where it names every one of ``names``, else :func:`assign` of ``names``
    (a figure drawn on its own, outside a report)."""
    names = list(names)
    if style_of is not None and all(n in style_of for n in names):
        return dict(style_of)
    return assign(names)


def legend(ax: Any, n: int, **kw: Any) -> Any:
    """A legend of ``n`` optimizers' lines, each entry long enough to show its dashes and
    marker: inside the axes (where it hides least) for up to six, beside them (right) for
    more, where it hides no curve."""
    where: dict[str, Any] = ({"loc": "best"} if n <= 6 else
                             {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0),
                              "borderaxespad": 0.0})
    return ax.legend(fontsize=8, handlelength=3.4, **where, **kw)
