"""The rows of the parameter block of :func:`.kernel.dynamic_single_track`, by name: in a module
of their own so that a problem reads the layout without loading numba (the kernel's import)."""

from __future__ import annotations

#: Each axle's Magic Formula (``B, C, D, E`` and the horizontal and vertical shifts ``Sh``,
#: ``Sv``), the drive (``Cm1, Cm2``), the resistance (``Cr0, Cr2``) and the yaw inertia.
DYNAMIC_ROWS = ("Bf", "Cf", "Df", "Ef", "Shf", "Svf", "Br", "Cr", "Dr", "Er", "Shr", "Svr",
                "Cm1", "Cm2", "Cr0", "Cr2", "Iz")
