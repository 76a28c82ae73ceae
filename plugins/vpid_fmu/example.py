"""Build the example quarter-car FMU (docs/fmu.md's worked example, the tests' model) from
``sources/quarter_car.c`` with gcc and the FMI headers fmpy ships: ``python -m
vpid_fmu.example quarter_car.fmu`` (FMI 2.0, both interfaces; ``--fmi 3``: FMI 3.0
co-simulation), and test variants (a crash, a hang, no binary, no input interpolation,
another token). Parameters ``ms, mu, ks, cs`` (identified) and ``kt`` (known), input ``h``
(m), outputs ``zsdd``, ``zudd`` (m/s²), ``stroke`` (m); start values: the golden car.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

import numpy as np

SOURCE = Path(__file__).with_name("sources") / "quarter_car.c"
GUID = "{8c4e810f-3df3-4a00-8276-176fa3c9f000}"
IDENTIFIER = "quarter_car"
#: name, value reference, start, (min, max) or None, unit, description
PARAMETERS = (
    ("ms", 0, 250.0, (125.0, 375.0), "kg", "sprung mass"),
    ("mu", 1, 37.5, (18.75, 56.25), "kg", "unsprung mass"),
    ("ks", 2, 15825.0, (7912.5, 23737.5), "N/m", "suspension stiffness"),
    ("cs", 3, 1500.0, (750.0, 2250.0), "N.s/m", "suspension damping"),
    ("kt", 4, 163250.0, None, "N/m", "tyre stiffness"),
)
INPUT = ("h", 5, "m")
OUTPUTS = (("zsdd", 6, "m/s2"), ("zudd", 7, "m/s2"), ("stroke", 8, "m"))
STATES = (("zs", 9, "m"), ("zu", 10, "m"), ("vs", 11, "m/s"), ("vu", 12, "m/s"))
UNITS = {"s": (0, 0, 1), "kg": (1, 0, 0), "N/m": (1, 0, -2), "N.s/m": (1, 0, -1), "m": (0, 1, 0),
         "m/s": (0, 1, -1), "m/s2": (0, 1, -2)}


#: The car ``--record`` makes its record with (not the FMU's start values: the fit must move).
RECORD_TRUTH = {"ms": 280.0, "mu": 33.0, "ks": 17000.0, "cs": 1300.0}


class BuildError(RuntimeError):
    """gcc is missing or failed."""


def fmi_headers() -> Path:
    """The folder of the FMI headers fmpy ships (``fmpy/c-code``)."""
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def compiler() -> str | None:
    """The path of gcc, or ``None`` when this machine has none."""
    return shutil.which("gcc")


def _unit_definitions() -> str:
    rows = [f'    <Unit name="{u}"><BaseUnit kg="{kg}" m="{m}" s="{s}"/></Unit>'
            for u, (kg, m, s) in UNITS.items()]
    return "  <UnitDefinitions>\n" + "\n".join(rows) + "\n  </UnitDefinitions>\n"


def _fmi2_description(guid: str, interpolate: bool, kinds: tuple[str, ...]) -> str:
    var, index = [], {}

    def add(name: str, body: str) -> None:
        var.append(body)
        index[name] = len(var)

    for name, vr, start, box, unit, what in PARAMETERS:
        lim = f' min="{box[0]!r}" max="{box[1]!r}"' if box else ""
        add(name, f'    <ScalarVariable name="{name}" valueReference="{vr}" description="{what}" '
                  f'causality="parameter" variability="{"tunable" if box else "fixed"}">'
                  f'<Real start="{start!r}" unit="{unit}"{lim}/></ScalarVariable>')
    name, vr, unit = INPUT
    add(name, f'    <ScalarVariable name="{name}" valueReference="{vr}" causality="input" '
              f'variability="continuous"><Real start="0.0" unit="{unit}"/></ScalarVariable>')
    for name, vr, unit in OUTPUTS:
        add(name, f'    <ScalarVariable name="{name}" valueReference="{vr}" causality="output" '
                  f'variability="continuous"><Real unit="{unit}"/></ScalarVariable>')
    for name, vr, unit in STATES:
        add(name, f'    <ScalarVariable name="{name}" valueReference="{vr}" causality="local" '
                  f'variability="continuous" initial="exact"><Real start="0.0" unit="{unit}"/>'
                  '</ScalarVariable>')
    for name, vr, _ in STATES:
        add(f"der({name})", f'    <ScalarVariable name="der({name})" valueReference="{vr + 4}" '
            f'causality="local" variability="continuous"><Real derivative="{index[name]}"/>'
            '</ScalarVariable>')
    outs = "".join(f'<Unknown index="{index[n]}"/>' for n, _, _ in OUTPUTS)
    ders = "".join(f'<Unknown index="{index[f"der({n})"]}"/>' for n, _, _ in STATES)
    me = (f'  <ModelExchange modelIdentifier="{IDENTIFIER}"/>\n' if "me" in kinds else "")
    cs = (f'  <CoSimulation modelIdentifier="{IDENTIFIER}" '
          'canHandleVariableCommunicationStepSize="true" '
          f'canInterpolateInputs="{"true" if interpolate else "false"}"/>\n'
          if "cs" in kinds else "")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<fmiModelDescription fmiVersion="2.0" modelName="QuarterCar" guid="{guid}" '
            'generationTool="vpid_fmu.example" numberOfEventIndicators="0">\n'
            f"{me}{cs}{_unit_definitions()}"
            "  <ModelVariables>\n" + "\n".join(var) + "\n  </ModelVariables>\n"
            f"  <ModelStructure>\n    <Outputs>{outs}</Outputs>\n"
            f"    <Derivatives>{ders}</Derivatives>\n"
            f"    <InitialUnknowns>{outs}{ders}</InitialUnknowns>\n  </ModelStructure>\n"
            "</fmiModelDescription>\n")


def _fmi3_description(guid: str) -> str:
    var = ['    <Float64 name="time" valueReference="99" causality="independent" '
           'variability="continuous" unit="s"/>']
    for name, vr, start, box, unit, what in PARAMETERS:
        lim = f' min="{box[0]!r}" max="{box[1]!r}"' if box else ""
        var.append(f'    <Float64 name="{name}" valueReference="{vr}" description="{what}" '
                   f'causality="parameter" variability="{"tunable" if box else "fixed"}" '
                   f'start="{start!r}" unit="{unit}"{lim}/>')
    name, vr, unit = INPUT
    var.append(f'    <Float64 name="{name}" valueReference="{vr}" causality="input" '
               f'variability="continuous" start="0.0" unit="{unit}"/>')
    for name, vr, unit in OUTPUTS:
        var.append(f'    <Float64 name="{name}" valueReference="{vr}" causality="output" '
                   f'variability="continuous" unit="{unit}"/>')
    outs = "".join(f'<Output valueReference="{vr}"/>' for _, vr, _ in OUTPUTS)
    inits = "".join(f'<InitialUnknown valueReference="{vr}"/>' for _, vr, _ in OUTPUTS)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<fmiModelDescription fmiVersion="3.0" modelName="QuarterCar" '
            f'instantiationToken="{guid}" generationTool="vpid_fmu.example">\n'
            f'  <CoSimulation modelIdentifier="{IDENTIFIER}" '
            'canHandleVariableCommunicationStepSize="true"/>\n'
            f"{_unit_definitions()}"
            "  <ModelVariables>\n" + "\n".join(var) + "\n  </ModelVariables>\n"
            f"  <ModelStructure>\n    {outs}\n    {inits}\n  </ModelStructure>\n"
            "</fmiModelDescription>\n")


def compile_binary(out: Path, fmi: int = 2, variant: str | None = None,
                   guid: str = GUID) -> None:
    """Compile ``sources/quarter_car.c`` into the shared library ``out`` (gcc, ``-O2``)."""
    gcc = compiler()
    if gcc is None:
        raise BuildError("no C compiler: gcc is not on PATH")
    flags = ["-DFMI3"] if fmi == 3 else []
    if variant is not None:
        flags.append({"crash": "-DCRASH", "hang": "-DHANG"}[variant])
    cmd = [gcc, "-shared", "-fPIC", "-O2", f"-I{fmi_headers()}", *flags,
           f'-DGUID="{guid}"', str(SOURCE), "-o", str(out), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise BuildError(f"gcc failed: {done.stderr.strip()[:400]}")


def build(out: str | Path, fmi: int = 2, kinds: tuple[str, ...] = ("cs", "me"),
          variant: str | None = None, binary: bool = True, interpolate: bool = True,
          binary_guid: str | None = None) -> Path:
    """Write the example FMU to ``out`` and return its path (see the module)."""
    import fmpy

    out = Path(out)
    description = (_fmi3_description(GUID) if fmi == 3
                   else _fmi2_description(GUID, interpolate, kinds))
    folder = f"binaries/{fmpy.platform_tuple if fmi == 3 else fmpy.platform}"
    with tempfile.TemporaryDirectory() as tmp:
        lib = Path(tmp) / f"{IDENTIFIER}{fmpy.sharedLibraryExtension}"
        if binary:
            compile_binary(lib, fmi, variant, binary_guid or GUID)
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", description)
            z.write(SOURCE, f"sources/{SOURCE.name}")
            if binary:
                z.write(lib, f"{folder}/{lib.name}")
    return out


def road(t: np.ndarray, seed: int = 0, rms: float = 0.02) -> np.ndarray:
    """A random road height (m) at the times ``t``: 40 sines from 0.5 to 25 Hz with random
    phases and amplitudes falling as ``1/f`` (a rough road met at speed), eased in from 0 over
    the first 0.5 s, scaled to ``rms``."""
    rng = np.random.default_rng(seed)
    f = np.geomspace(0.5, 25.0, 40)
    phase = rng.uniform(0, 2 * np.pi, f.size)
    h = np.sum(np.sin(2 * np.pi * f[:, None] * t[None] + phase[:, None]) / f[:, None], axis=0)
    ramp = np.clip(t / 0.5, 0.0, 1.0)  # from rest: the road eased in over 0.5 s
    h *= ramp * ramp * (3 - 2 * ramp)
    return rms * h / np.sqrt(np.mean(h**2))


def write_record(fmu: str | Path, out: str | Path, truth: dict[str, float] | None = None,
                 duration: float = 4.0, rate: float = 500.0, noise: float = 0.03,
                 seed: int = 0, fine_step: float = 1e-4) -> Path:
    """A record (CSV ``t, h, zsdd, zudd``) of the example FMU at ``rate`` Hz made independently
    of vpid-bench's importer (fmpy's ``simulate_fmu`` at ``fine_step`` s), plus white noise
    of ``noise`` times each channel's rms."""
    from fmpy import simulate_fmu

    n = int(round(duration * rate))
    t = np.arange(n) / rate
    h = road(t, seed)
    signal = np.zeros(n, dtype=[("time", float), ("h", float)])
    # fmpy holds the input over each fine step at its value at the step's start: the times
    # moved half a step earlier make that the value at the step's middle (no lag)
    signal["time"], signal["h"] = t - 0.5 * fine_step, h
    every = int(round(1.0 / (rate * fine_step)))
    result = simulate_fmu(str(fmu), fmi_type="CoSimulation", start_values=dict(truth or {}),
                          input=signal, step_size=fine_step, output_interval=fine_step,
                          stop_time=t[-1], output=["zsdd", "zudd"])
    rng = np.random.default_rng([seed, 1])
    columns = [t, h]
    for name in ("zsdd", "zudd"):
        y = np.asarray(result[name])[::every][:n]
        columns.append(y + noise * np.sqrt(np.mean(y**2)) * rng.standard_normal(n))
    out = Path(out)
    np.savetxt(out, np.column_stack(columns), delimiter=",", header="t,h,zsdd,zudd",
               comments="", fmt="%.17g")
    return out


def main(argv: list[str] | None = None) -> None:
    """``python -m vpid_fmu.example OUT.fmu [--fmi 2|3] [--record OUT.csv]``."""
    ap = argparse.ArgumentParser(description="Build the example quarter-car FMU (gcc).")
    ap.add_argument("out")
    ap.add_argument("--fmi", type=int, choices=(2, 3), default=2)
    ap.add_argument("--record", help="also write a 4 s record at 500 Hz with 3 %% noise, made "
                    "by the FMU with ms 280, mu 33, ks 17000, cs 1300 (CSV)")
    args = ap.parse_args(argv)
    print(build(args.out, fmi=args.fmi, kinds=("cs",) if args.fmi == 3 else ("cs", "me")))
    if args.record:
        print(write_record(args.out, args.record, RECORD_TRUTH))


if __name__ == "__main__":
    main()
