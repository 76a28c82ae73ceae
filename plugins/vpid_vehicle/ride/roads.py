"""Road profiles h(x) (m) over distance x (m): :func:`bump` (the paper's, 0.04 m x 0.10 m),
:func:`step` (the University of Michigan quarter bus's 0.10 m, its edge rounded over a tyre's
0.15 m contact: a sharp step would make the wheel's acceleration a Dirac pulse), :func:`hump`
(one raised-cosine period, UK TRL geometry: 3.7 m, 0.10 m), :func:`iso8608`.

ISO 8608 at the class geometric means (a public generator uses the upper limits, and one is
off by 1600x): ``Gd(n) = Gd(n0) (n / n0)^-2``, ``n0 = 0.1`` cycles/m, ``Gd(n0)`` of A..H =
16 x 4^i x 1e-6 m^3, over 0.011..2.83 cycles/m; ``h(x) = sum_i sqrt(2 Gd(n_i) dn) cos(2 pi
n_i x + phi_i)``, ``phi_i ~ U(0, 2 pi)``: one-sided PSD ``Gd(n)`` on the band (tested).
"""

from __future__ import annotations

import numpy as np

#: ISO 8608 class -> Gd(n0) at the class geometric mean (m^3), n0 = 0.1 cycles/m.
ISO8608_GD0 = {c: 16e-6 * 4.0**i for i, c in enumerate("ABCDEFGH")}
ISO8608_N0 = 0.1  # cycles/m
ISO8608_W = 2.0
ISO8608_BAND = (0.011, 2.83)  # cycles/m


def bump(x: np.ndarray, start: float, height: float = 0.04, length: float = 0.10) -> np.ndarray:
    """Rectangular bump from ``start`` to ``start + length`` m."""
    x = np.asarray(x, dtype=float)
    return np.where((x >= start) & (x < start + length), height, 0.0)


def step(x: np.ndarray, start: float, height: float = 0.10, edge: float = 0.15) -> np.ndarray:
    """A step of ``height`` m rising over ``edge`` m as half a raised cosine (see the module)."""
    s = np.clip((np.asarray(x, dtype=float) - start) / edge, 0.0, 1.0)
    return 0.5 * height * (1.0 - np.cos(np.pi * s))


def hump(x: np.ndarray, start: float, height: float = 0.10, length: float = 3.7) -> np.ndarray:
    """One raised-cosine hump of ``height`` m and ``length`` m from ``start`` m."""
    s = np.asarray(x, dtype=float) - start
    inside = (s >= 0) & (s <= length)
    return np.where(inside, 0.5 * height * (1.0 - np.cos(2.0 * np.pi * s / length)), 0.0)


def iso8608_psd(n: np.ndarray, road_class: str) -> np.ndarray:
    """ISO 8608's fitted displacement PSD ``Gd(n)`` (m^3) of a class at ``n`` cycles/m."""
    return ISO8608_GD0[road_class] * (np.asarray(n, dtype=float) / ISO8608_N0) ** -ISO8608_W


#: Spacing (m) of the grid an ISO road is computed on; between its points the road is
#: linear (the shortest wavelength of the band, 0.35 m, spans 35 points).
ISO8608_DX = 0.01


def iso8608(x: np.ndarray, road_class: str, rng: np.random.Generator,
            waves: int = 2000, taper_m: float = 5.0) -> np.ndarray:
    """A random ISO 8608 road of ``road_class`` at ``x`` (m): ``waves`` sinusoids every
    ``ISO8608_DX`` m, linear between (a fine record and a coarse fit see one road), faded in
    over ``taper_m`` (the car starts at rest on a level road)."""
    lo, hi = ISO8608_BAND
    dn = (hi - lo) / waves
    n = lo + dn * (np.arange(waves) + 0.5)
    amp = np.sqrt(2.0 * iso8608_psd(n, road_class) * dn)
    phase = rng.uniform(0.0, 2.0 * np.pi, waves)
    x = np.asarray(x, dtype=float)
    grid = np.arange(0.0, max(float(np.max(x, initial=0.0)), 0.0) + 2 * ISO8608_DX, ISO8608_DX)
    h = np.zeros_like(grid)
    for chunk in range(0, waves, 200):  # bounded memory: (len(grid), 200) at a time
        sl = slice(chunk, chunk + 200)
        h += np.cos(2.0 * np.pi * np.outer(grid, n[sl]) + phase[sl]) @ amp[sl]
    if taper_m > 0:
        fade = np.clip(grid / taper_m, 0.0, 1.0)
        h *= 0.5 * (1.0 - np.cos(np.pi * fade))
    return np.interp(x, grid, h)
