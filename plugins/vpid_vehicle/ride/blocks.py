"""Filling a block of the shared core (:mod:`.codegen`'s, :mod:`.kernel`) from per-candidate
tables: the compiled code the generated time loops share."""

from __future__ import annotations

import numba


@numba.njit(cache=True, nogil=True)
def load_block(T, w0, j0, blk, lanes, st):  # pragma: no cover - compiled
    """Copy candidates ``j0 ...`` of ``T`` and ``w0`` into ``blk``; lanes past the last: zeros."""
    n, R, S = T.shape
    s = w0.shape[1]
    blk[:] = 0.0
    for lane in range(min(lanes, n - j0)):
        c = j0 + lane
        for row in range(R):
            for m in range(S):
                blk[(row * S + m) * lanes + lane] = T[c, row, m]
        for m in range(s):
            blk[st + m * lanes + lane] = w0[c, m]
