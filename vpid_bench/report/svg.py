"""An :class:`~.interactive.Figure` laid out for an inline SVG: the pixel geometry of each
series (step path, band, markers in its report style, :mod:`.styles`) and the axes' ticks;
the page templates write the elements, auto-escaped. Plain SVG, not a plotting library's
export: no script from outside (plotly's embeds megabytes per page), works from ``file://``,
tens of kilobytes for 20 optimizers."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

from .interactive import Figure
from .styles import Style, lookup

WIDTH, HEIGHT = 720, 380
LEFT, RIGHT, TOP, BOTTOM = 70, 16, 14, 46
#: The lines' width (px): the dash patterns of :mod:`.styles` are in line widths.
LINE_WIDTH = 1.6
#: Markers along a curve: one every this many pixels of x, and their radius (px).
MARK_EVERY_PX, MARK_R = 84.0, 3.6
#: A legend key: a short line with the marker in its middle, this wide and high (px).
KEY_W, KEY_H = 34, 12


def marker_path(marker: str, cx: float, cy: float, r: float = MARK_R) -> str:
    """An SVG path (filled) of one marker of :data:`.styles.MARKERS` centred at (cx, cy)."""
    if marker == "o":
        return (f"M{cx - r:.1f} {cy:.1f}a{r:.1f} {r:.1f} 0 1 0 {2 * r:.1f} 0"
                f"a{r:.1f} {r:.1f} 0 1 0 {-2 * r:.1f} 0Z")
    t = 0.36  # the half-width of a plus's or a cross's bar, in radii
    shapes = {
        "s": [(-0.85, -0.85), (0.85, -0.85), (0.85, 0.85), (-0.85, 0.85)],
        "^": [(0, -1.05), (1, 0.8), (-1, 0.8)],
        "v": [(0, 1.05), (1, -0.8), (-1, -0.8)],
        "D": [(0, -1.15), (0.85, 0), (0, 1.15), (-0.85, 0)],
        "P": [(-t, -1), (t, -1), (t, -t), (1, -t), (1, t), (t, t), (t, 1), (-t, 1), (-t, t),
              (-1, t), (-1, -t), (-t, -t)],
        "X": [(-1, -0.75), (-0.75, -1), (0, -0.25), (0.75, -1), (1, -0.75), (0.25, 0),
              (1, 0.75), (0.75, 1), (0, 0.25), (-0.75, 1), (-1, 0.75), (-0.25, 0)]}
    return "M" + "L".join(f"{cx + a * r:.1f} {cy + b * r:.1f}"
                          for a, b in shapes.get(marker, shapes["s"])) + "Z"


@dataclasses.dataclass(frozen=True)
class Tick:
    pos: float
    label: str


@dataclasses.dataclass(frozen=True)
class DrawnSeries:
    """One optimizer's curve as drawn, in its style; ``marks``: the markers along it, ``key``:
    the legend's marker (in a :data:`KEY_W` x :data:`KEY_H` box)."""

    name: str
    label: str
    colour: str
    path: str
    band: str
    dasharray: str = ""
    marker: str = ""
    marks: str = ""
    key: str = ""


@dataclasses.dataclass(frozen=True)
class Layout:
    """What the template draws: the plot area, ticks, series paths and reference lines."""

    width: int
    height: int
    left: int
    top: int
    right: int
    bottom: int
    x_ticks: tuple[Tick, ...]
    y_ticks: tuple[Tick, ...]
    series: tuple[DrawnSeries, ...]
    lines: tuple[tuple[str, float], ...]
    key_w: int = KEY_W
    key_h: int = KEY_H


class _Axis:
    """A data-to-pixel map along one axis (log or linear), over a finite range."""

    def __init__(self, lo: float, hi: float, log: bool, p0: float, p1: float) -> None:
        if log:
            lo, hi = math.log10(lo), math.log10(hi)
        if not hi > lo:
            lo, hi = lo - 0.5, hi + 0.5
        self.lo, self.hi, self.log, self.p0, self.p1 = lo, hi, log, p0, p1

    def __call__(self, v: float) -> float:
        if self.log:
            v = math.log10(v) if v > 0 else self.lo
        return self.p0 + (v - self.lo) / (self.hi - self.lo) * (self.p1 - self.p0)

    def ticks(self) -> list[Tick]:
        if self.log:
            first, last = math.ceil(self.lo - 1e-9), math.floor(self.hi + 1e-9)
            step = max(1, math.ceil((last - first + 1) / 8))
            marks = [1.0, 2.0, 5.0] if self.hi - self.lo < 2 else [1.0]  # few decades
            values = [m * 10.0 ** k for k in range(first - 1, last + 1, step) for m in marks]
            return [Tick(round(self(v), 1), _fmt(v)) for v in values
                    if self.lo - 1e-9 <= math.log10(v) <= self.hi + 1e-9]
        span = self.hi - self.lo
        raw = span / 5
        mag = 10 ** math.floor(math.log10(raw))
        step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
        k = math.ceil(self.lo / step - 1e-9)
        out = []
        while k * step <= self.hi + 1e-9 * span:
            out.append(Tick(round(self(k * step), 1), _fmt(k * step)))
            k += 1
        return out


def _fmt(v: float) -> str:
    if v == 0:
        return "0"
    if abs(v) >= 1e5 or abs(v) < 1e-3:
        return f"{v:.0e}".replace("e+0", "e").replace("e-0", "e-").replace("e+", "e")
    return f"{v:g}"


def _finite(values: Sequence[float], log: bool) -> list[float]:
    return [v for v in values if math.isfinite(v) and (v > 0 or not log)]


def _step_path(xs: Sequence[float], ys: Sequence[float], fx: _Axis, fy: _Axis,
               x_end: float | None = None) -> str:
    """An SVG path of a step curve (each y holds until the next x; NaN: a gap)."""
    parts: list[str] = []
    pen = False
    for i, (x, y) in enumerate(zip(xs, ys, strict=True)):
        if not (math.isfinite(x) and math.isfinite(y)) or (fy.log and y <= 0):
            pen = False
            continue
        px, py = fx(x), fy(y)
        nxt = xs[i + 1] if i + 1 < len(xs) else x_end
        parts.append(f"V{py:.1f}" if pen else f"M{px:.1f} {py:.1f}")
        pen = True
        if nxt is not None and math.isfinite(nxt):
            parts.append(f"H{fx(nxt):.1f}")
    return "".join(parts)


def _band_path(xs: Sequence[float], lo: Sequence[float], hi: Sequence[float], fx: _Axis,
               fy: _Axis) -> str:
    """A closed SVG path between two step curves (the interquartile band)."""
    pts = [(x, a, b) for x, a, b in zip(xs, lo, hi, strict=True)
           if math.isfinite(a) and math.isfinite(b) and (not fy.log or (a > 0 and b > 0))]
    if len(pts) < 2:
        return ""
    upper, lower = [], []
    for i, (x, a, b) in enumerate(pts):
        x2 = pts[i + 1][0] if i + 1 < len(pts) else x
        upper += [(fx(x), fy(b)), (fx(x2), fy(b))]
        lower += [(fx(x), fy(a)), (fx(x2), fy(a))]
    ring = upper + lower[::-1]
    return "M" + "L".join(f"{x:.1f} {y:.1f}" for x, y in ring) + "Z"


def _marks(xs: Sequence[float], ys: Sequence[float], fx: _Axis, fy: _Axis,
           st: Style, x_end: float) -> str:
    """The markers along a step curve, one every :data:`MARK_EVERY_PX` of x, the first
    shifted by the style's offset (equal curves keep them apart)."""
    pts = [(fx(x), fy(y)) for x, y in zip(xs, ys, strict=True)
           if math.isfinite(x) and math.isfinite(y) and not (fy.log and y <= 0)]
    if not pts:
        return ""
    end = fx(x_end) if math.isfinite(x_end) else pts[-1][0]
    out, k = [], 0
    px = pts[0][0] + MARK_EVERY_PX * (0.15 + 0.7 * st.offset)
    while px <= end:
        while k + 1 < len(pts) and pts[k + 1][0] <= px:
            k += 1
        out.append(marker_path(st.marker, px, pts[k][1]))
        px += MARK_EVERY_PX
    return "".join(out)


def dasharray(st: Style) -> str:
    """The style's dash pattern as SVG's ``stroke-dasharray`` (px; ``""``: solid)."""
    return " ".join(f"{v * LINE_WIDTH:.1f}" for v in st.pattern)


def layout(fig: Figure, style_of: Mapping[str, Style] | None = None) -> Layout:
    """Pixel geometry of ``fig``, each optimizer in its ``style_of`` (default: by name)."""
    xs = [v for s in fig.series for v in s.x]
    ys = [v for s in fig.series for v in (*s.y, *s.lo, *s.hi)] + [v for _, v in fig.lines]
    fxv, fyv = _finite(xs, fig.x_log), _finite(ys, fig.y_log)
    x0, x1 = (min(fxv), max(fxv)) if fxv else (1.0, 10.0)
    if fig.y_range is not None:
        y0, y1 = fig.y_range
    else:
        y0, y1 = (min(fyv), max(fyv)) if fyv else (1.0, 10.0)
        if fig.y_log:
            y0, y1 = y0 / 1.2, y1 * 1.2
        else:
            pad = 0.04 * (y1 - y0 or 1.0)
            y0, y1 = y0 - pad, y1 + pad
    fx = _Axis(x0, x1, fig.x_log, LEFT, WIDTH - RIGHT)
    fy = _Axis(y0, y1, fig.y_log, HEIGHT - BOTTOM, TOP)
    look = lookup(style_of, [s.name for s in fig.series])
    drawn = tuple(DrawnSeries(s.name, s.label or s.name, look[s.name].colour,
                              _step_path(s.x, s.y, fx, fy, x1),
                              _band_path(s.x, s.lo, s.hi, fx, fy) if s.lo else "",
                              dasharray(look[s.name]), look[s.name].marker,
                              _marks(s.x, s.y, fx, fy, look[s.name], x1),
                              marker_path(look[s.name].marker, KEY_W / 2, KEY_H / 2))
                  for s in fig.series)
    lines = tuple((label, round(fy(v), 1)) for label, v in fig.lines
                  if math.isfinite(v) and (v > 0 or not fig.y_log))
    return Layout(WIDTH, HEIGHT, LEFT, TOP, WIDTH - RIGHT, HEIGHT - BOTTOM,
                  tuple(fx.ticks()), tuple(fy.ticks()), drawn, lines)
