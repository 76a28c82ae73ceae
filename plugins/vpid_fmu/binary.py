"""The FMU's binary in this process (a supervised worker: a crash or a hang costs one run),
loaded with ctypes, one instance reset between simulations, the step loop in :mod:`.kernels`.

Not fmpy's ``FMU2Slave``/``FMU3Slave``: they bind every function of the standard (refusing an
FMI 3.0 binary without an optional one), change the working directory while loading, and
cannot be called from compiled code. Only the functions a simulation calls are bound, pointer
arguments as ``size_t``.
"""

from __future__ import annotations

import ctypes
import logging
from ctypes import CFUNCTYPE, c_bool, c_char_p, c_double, c_int, c_size_t, c_void_p
from pathlib import Path
from typing import Any

import numpy as np

from . import kernels

log = logging.getLogger(__name__)
#: Most messages of one FMU passed on to the log (a chatty FMU cannot flood the terminal).
MAX_MESSAGES = 20
STATUS = ("OK", "warning", "discard", "error", "fatal", "an event (not supported)",
          "a step size too small")

P = c_size_t  # a pointer argument (see the module)
LOGGER2 = CFUNCTYPE(None, c_void_p, c_char_p, c_int, c_char_p, c_char_p)
LOGGER3 = CFUNCTYPE(None, c_void_p, c_int, c_char_p, c_char_p)


class FmuRuntimeError(RuntimeError):
    """The binary could not be instantiated or initialised (one line saying which call)."""


class _Callbacks2(ctypes.Structure):
    _fields_ = [("logger", LOGGER2), ("allocateMemory", c_void_p), ("freeMemory", c_void_p),
                ("stepFinished", c_void_p), ("componentEnvironment", c_void_p)]


def _logged(message: bytes | None) -> None:
    _logged.count = getattr(_logged, "count", 0) + 1
    if _logged.count <= MAX_MESSAGES:
        text = (message or b"").decode("utf-8", "replace")[:300]
        log.info("FMU: %s", " ".join(text.split()))


@LOGGER2
def _logger2(env, name, status, category, message):  # noqa: ARG001 (the C signature)
    _logged(message)


@LOGGER3
def _logger3(env, status, category, message):  # noqa: ARG001
    _logged(message)


def _bind(lib: ctypes.CDLL, name: str, res: Any, *args: Any) -> Any:
    try:
        fn = getattr(lib, name)
    except AttributeError:
        raise FmuRuntimeError(f"the FMU's binary has no function {name}") from None
    fn.restype, fn.argtypes = res, list(args)
    return fn


class Simulator:
    """One instance of one interface (``cs`` or ``me``) of the FMU extracted at ``folder``."""

    def __init__(self, fmu: Any, folder: Path, kind: str, name: str = "vpid") -> None:
        import fmpy

        self.fmu, self.kind, self.major = fmu, kind, fmu.major
        lib_path = folder / fmu.binaries[kind]
        self.lib = ctypes.CDLL(str(lib_path))
        self.resources = (folder / "resources").as_uri() + "/"
        self._name = name.encode()
        self._fmpy = fmpy
        self.c = 0
        self._bind()

    # --- binding ------------------------------------------------------------------------
    def _bind(self) -> None:
        lib, b = self.lib, _bind
        if self.major == 2:
            self.f_inst = b(lib, "fmi2Instantiate", P, c_char_p, c_int, c_char_p, c_char_p,
                            c_void_p, c_int, c_int)
            self.f_free = b(lib, "fmi2FreeInstance", None, P)
            self.f_setup = b(lib, "fmi2SetupExperiment", c_int, P, c_int, c_double, c_double,
                             c_int, c_double)
            self.f_enter = b(lib, "fmi2EnterInitializationMode", c_int, P)
            self.f_exit = b(lib, "fmi2ExitInitializationMode", c_int, P)
            self.f_reset = b(lib, "fmi2Reset", c_int, P)
            self.f_set = b(lib, "fmi2SetReal", c_int, P, P, P, P)
            self.f_get = b(lib, "fmi2GetReal", c_int, P, P, P, P)
            if self.kind == "cs":
                self.f_step = b(lib, "fmi2DoStep", c_int, P, c_double, c_double, c_int)
                self.f_der = (b(lib, "fmi2SetRealInputDerivatives", c_int, P, P, P, P, P)
                              if self.fmu.description.coSimulation.canInterpolateInputs
                              else None)
            else:
                self.f_time = b(lib, "fmi2SetTime", c_int, P, c_double)
                self.f_states = b(lib, "fmi2SetContinuousStates", c_int, P, P, P)
                self.f_getstates = b(lib, "fmi2GetContinuousStates", c_int, P, P, P)
                self.f_deriv = b(lib, "fmi2GetDerivatives", c_int, P, P, P)
                self.f_completed = b(lib, "fmi2CompletedIntegratorStep", c_int, P, c_int, P, P)
                self.f_newdiscrete = b(lib, "fmi2NewDiscreteStates", c_int, P, P)
                self.f_continuous = b(lib, "fmi2EnterContinuousTimeMode", c_int, P)
        else:
            self.f_inst = b(lib, "fmi3InstantiateCoSimulation", P, c_char_p, c_char_p,
                            c_char_p, c_bool, c_bool, c_bool, c_bool, c_void_p, c_size_t,
                            c_void_p, LOGGER3, c_void_p)
            self.f_free = b(lib, "fmi3FreeInstance", None, P)
            self.f_enter = b(lib, "fmi3EnterInitializationMode", c_int, P, c_bool, c_double,
                             c_double, c_bool, c_double)
            self.f_exit = b(lib, "fmi3ExitInitializationMode", c_int, P)
            self.f_reset = b(lib, "fmi3Reset", c_int, P)
            self.f_set = b(lib, "fmi3SetFloat64", c_int, P, P, P, P, P)
            self.f_get = b(lib, "fmi3GetFloat64", c_int, P, P, P, P, P)
            self.f_step = b(lib, "fmi3DoStep", c_int, P, c_double, c_double, c_bool, P, P, P, P)

    # --- life cycle ---------------------------------------------------------------------
    def instantiate(self) -> None:
        """Create the instance (once per process; :meth:`simulate` resets it)."""
        token = self.fmu.token.encode()
        if self.major == 2:
            self._callbacks = _Callbacks2(_logger2, ctypes.cast(self._fmpy.calloc, c_void_p),
                                          ctypes.cast(self._fmpy.free, c_void_p), None, None)
            kind = 1 if self.kind == "cs" else 0
            self.c = self.f_inst(self._name, kind, token, self.resources.encode(),
                                 ctypes.addressof(self._callbacks), 0, 0)
        else:
            self.c = self.f_inst(self._name, token, self.resources.encode(), False, False,
                                 False, False, None, 0, None, _logger3, None)
        if not self.c:
            what = "guid" if self.major == 2 else "instantiationToken"
            call = "fmi2Instantiate" if self.major == 2 else "fmi3InstantiateCoSimulation"
            raise FmuRuntimeError(
                f"the FMU's binary refused to instantiate ({call} returned NULL): its "
                f"modelDescription's {what} {self.fmu.token[:60]} is not the binary's (a GUID "
                "mismatch), or the binary failed to start")
        self._fresh = True

    def close(self) -> None:
        if self.c:
            self.f_free(self.c)
            self.c = 0

    def _set(self, vrs: np.ndarray, values: np.ndarray) -> int:
        if vrs.size == 0:
            return 0
        v = np.ascontiguousarray(values, dtype=float)
        count = () if self.major == 2 else (vrs.size,)  # FMI 3.0 takes the values' count too
        return self.f_set(self.c, vrs.ctypes.data, vrs.size, v.ctypes.data, *count)

    def _get(self, vrs: np.ndarray, out: np.ndarray) -> int:
        count = () if self.major == 2 else (vrs.size,)
        return self.f_get(self.c, vrs.ctypes.data, vrs.size, out.ctypes.data, *count)

    def _start(self, vrs: np.ndarray, values: np.ndarray, t0: float, t1: float,
               u0: np.ndarray, vr_in: np.ndarray, tolerance: float | None) -> str | None:
        """Reset (or create), set the start values and first input, initialise; what failed."""
        if not self.c:
            self.instantiate()
        elif not self._fresh and self.f_reset(self.c) > 1:
            self.close()
            self.instantiate()
        self._fresh = False
        tol_on = tolerance is not None
        if self.major == 2:
            if self.f_setup(self.c, int(tol_on), tolerance or 0.0, t0, 1, t1) > 1:
                return "fmi2SetupExperiment"
            if self._set(vrs, values) > 1:
                return "fmi2SetReal (the start values)"
            if self.f_enter(self.c) > 1:
                return "fmi2EnterInitializationMode"
        else:
            if self._set(vrs, values) > 1:
                return "fmi3SetFloat64 (the start values)"
            if self.f_enter(self.c, tol_on, tolerance or 0.0, t0, True, t1) > 1:
                return "fmi3EnterInitializationMode"
        if self._set(vr_in, u0) > 1:
            return "setting the first input"
        if self.f_exit(self.c) > 1:
            return "ExitInitializationMode"
        return None

    def simulate(self, vrs: np.ndarray, values: np.ndarray, t: np.ndarray, u: np.ndarray,
                 vr_in: np.ndarray, vr_out: np.ndarray, how: dict[str, Any]
                 ) -> tuple[np.ndarray | None, str | None]:
        """The outputs ``(N, p)`` at ``t`` for the start values and inputs, or ``(None, why)``."""
        y = np.empty((t.size, vr_out.size))
        failed = self._start(vrs, values, float(t[0]), float(t[-1]), u[0], vr_in,
                             how.get("rtol") if self.kind == "me" else None)
        if failed is None and self.kind == "me":
            failed = self._event_update()
        if failed is None and self._get(vr_out, y[0]) > 1:
            failed = "reading the outputs at the start"
        if failed is not None:
            self._fresh = False
            return None, failed
        status, k = self._loop(t, u, vr_in, vr_out, y, how)
        if status > 1:
            if status == 4:  # fatal: the instance may not even be reset; a new one next time
                self.close()
            return None, f"{STATUS[min(status, 6)]} at t = {t[min(k, t.size - 1)]:.6g} s"
        return y, None

    def _event_update(self) -> str | None:
        info = np.zeros(4, dtype=np.int64)  # fmi2EventInfo: 5 ints and a double, 32 bytes
        for _ in range(100):
            if self.f_newdiscrete(self.c, info.ctypes.data) > 1:
                return "fmi2NewDiscreteStates"
            if info.view(np.int32)[0] == 0:
                break
        if self.f_continuous(self.c) > 1:
            return "fmi2EnterContinuousTimeMode"
        return None

    def _loop(self, t: np.ndarray, u: np.ndarray, vr_in: np.ndarray, vr_out: np.ndarray,
              y: np.ndarray, how: dict[str, Any]) -> tuple[int, int]:
        t = np.ascontiguousarray(t, dtype=float)
        u = np.ascontiguousarray(u, dtype=float)
        if self.kind == "me":
            nx = int(how["states"])
            x = np.empty(nx)
            if self.f_getstates(self.c, x.ctypes.data, nx) > 1:
                return 3, 0
            fns = (self.f_time, self.f_set, self.f_states, self.f_deriv, self.f_get,
                   self.f_completed)
            return kernels.me2_dopri5(fns, self.c, t, u, x, vr_in, vr_out, y, how["rtol"],
                                      how["atol"], kernels.TABLEAU)
        if self.major == 3:
            flags = np.zeros(16, dtype=np.uint8)
            return kernels.cs3_hold(self.f_step, self.f_set, self.f_get, self.c, t, u,
                                    int(how["substeps"]), vr_in, vr_out, y, flags)
        if how["mode"] == "derivatives":
            order = np.ones(vr_in.size, dtype=np.int32)
            return kernels.cs2_derivatives(self.f_step, self.f_set, self.f_der, self.f_get,
                                           self.c, t, u, vr_in, vr_out, order, y)
        return kernels.cs2_hold(self.f_step, self.f_set, self.f_get, self.c, t, u,
                                int(how["substeps"]), vr_in, vr_out, y)


_SIMULATORS: dict[tuple[int, str], Simulator] = {}


def simulator(fmu: Any, kind: str) -> Simulator:
    """This process's simulator of ``fmu`` and ``kind``, made on first use, then reused."""
    from .archive import extracted

    key = (id(fmu), kind)  # fmu is cached per file state and kept alive by its simulator
    if key not in _SIMULATORS:
        sim = Simulator(fmu, extracted(fmu.path), kind)
        sim.instantiate()
        _SIMULATORS[key] = sim
    return _SIMULATORS[key]
