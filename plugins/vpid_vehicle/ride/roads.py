"""Road profiles h(x) (m) over distance x (m), and their time histories at a speed.

* :func:`bump`: a rectangular bump (the paper's: 0.04 m high, 0.10 m long);
* :func:`step`: a step up (the University of Michigan quarter-bus case: 0.10 m), its edge
  rounded over a tyre's contact length (0.15 m, a half raised cosine): a tyre envelops a sharp
  edge, and with tyre damping a sharp step would make the wheel's acceleration a Dirac pulse
  that no sampled record (nor a model fitted at ``dt``) can hold;
* :func:`hump`: a speed hump, one raised-cosine period (UK TRL geometry: 3.7 m long, 0.10 m
  high): ``h = H/2 (1 - cos(2 pi s / L))`` for ``0 <= s <= L``;
* :func:`iso8608`: a random road of an ISO 8608 class, a sum of sinusoids with random phases.

ISO 8608 values used here (a public generator uses the class *upper* limits instead, and one
is off by 1600x: these are the class geometric means). Displacement PSD
``Gd(n) = Gd(n0) (n / n0)^-w`` with ``n0 = 0.1`` cycles/m, ``w = 2``, ``Gd(n0)`` of classes
A..H = 16, 64, 256, 1024, 4096, 16384, 65536, 262144 x 1e-6 m^3, over the band
0.011..2.83 cycles/m (wavelengths about 0.35..91 m). The profile is
``h(x) = sum_i sqrt(2 Gd(n_i) dn) cos(2 pi n_i x + phi_i)`` on an even grid of ``n_i`` with
spacing ``dn``, ``phi_i ~ U(0, 2 pi)`` from the given generator: its one-sided PSD is
``Gd(n)`` on the band (tested against the formula).
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
    """A step of ``height`` m rising from ``start`` to ``start + edge`` m along half a raised
    cosine (the tyre's envelope of the edge; see the module)."""
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
    """A random ISO 8608 road of ``road_class`` (A..H) at the distances ``x`` (m): ``waves``
    sinusoids on the band, computed every ``ISO8608_DX`` m and linear in between (so a fine
    record and a coarse fit see one road); the first ``taper_m`` metres are faded in with a
    half cosine so the car starts at rest on a level road."""
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
