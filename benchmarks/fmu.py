"""What an FMU costs (issue 48): the model-exchange FMU's derivatives against the model's own C
right-hand side, and FMPy simulating the double pendulum's FMUs against nemc's own run.

1. Derivatives: a C loop compiled here from the FMU's sources/ (the model's C and the FMI 2.0
   wrapper, builder.py's flags) calls, chained as an integrator's stages are (each state waits
   for the last derivative), either `<name>_rhs` directly or, on an initialized instance in
   continuous-time mode, fmi2SetContinuousStates then fmi2GetDerivatives: what an importer's
   integrator pays per evaluation, against what nemc's own integrators pay.
2. A run: FMPy's `simulate_fmu` of the model-exchange FMU (CVode at rtol 1e-10) and of the
   co-simulation FMU (nemc.DOP853 inside, the scene's tolerances, one FMU step per output
   point), against `model.simulate` at the same output times (nemc.Radau and nemc.DOP853 at
   rtol 1e-10; nemc.DOP853 at the scene's tolerances as the co-simulation FMU runs it), each
   with its largest difference from nemc.Radau at rtol 1e-12.

Run: `python benchmarks/fmu.py [--rounds 5] [--example double_pendulum]` (about a minute).
Prints Markdown tables (median (min-max)) and the load average; writes nothing. docs/fmu.md
and docs/decisions/0033-fmu-export.md quote one run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from common import ROOT, interleaved, spread  # noqa: E402

import nemc  # noqa: E402
from nemc.build.builder import CFLAGS, DRIVERS_CFLAGS, UNIT_CFLAGS, compiler  # noqa: E402

BENCH_C = r"""
#include <stddef.h>
#include "NAME.h"
#include "fmi2Functions.h"

static void quiet(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c,
                  fmi2String m, ...)
{
    (void)e; (void)n; (void)s; (void)c; (void)m;
}

/* An instance in continuous-time mode (NULL if anything fails). */
void *bench_instance(const char *guid)
{
    static const fmi2CallbackFunctions callbacks = {quiet, NULL, NULL, NULL, NULL};
    fmi2Component c = fmi2Instantiate("bench", fmi2ModelExchange, guid, "", &callbacks, 0, 0);
    fmi2EventInfo info;
    if (!c || fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) || fmi2EnterInitializationMode(c)
        || fmi2ExitInitializationMode(c) || fmi2NewDiscreteStates(c, &info)
        || fmi2EnterContinuousTimeMode(c))
        return NULL;
    return c;
}

/* CALLS derivatives chained: each state is one of STATES plus 0.0 times the last derivative;
 * through the FMU (c) or the model's rhs (c NULL, parameters p). */
int bench_chained(void *c, const double *p, int count, const double *states, long calls)
{
    double y[N_STATE], dy[N_STATE] = {0};
    const double *state = states, *end = states + (long)count * N_STATE;
    int status = 0;
    for (long k = 0; k < calls; ++k) {
        for (int i = 0; i < N_STATE; ++i)
            y[i] = state[i] + 0.0 * dy[i];
        if (c) {
            status |= fmi2SetContinuousStates(c, y, N_STATE);
            status |= fmi2GetDerivatives(c, dy, N_STATE);
        } else {
            status |= PREFIXrhs(0.0, y, p, dy);
        }
        state = state + N_STATE == end ? states : state + N_STATE;
    }
    return status;
}
"""


def derivative_loops(model: nemc.Model, fmu: Path, states: np.ndarray, folder: Path
                     ) -> dict[str, tuple[Any, int]]:
    """The chained loops, compiled from the FMU's sources with builder.py's flags."""
    import cffi

    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
        guid = archive.read("modelDescription.xml").decode().split('guid="')[1].split('"')[0]
    sources = folder / "sources"
    (sources / "bench.c").write_text(BENCH_C.replace("NAME", model.name).replace(
        "PREFIX", model.compiled.prefix))
    objects = []
    for c_file in sorted(sources.glob("*.c")):
        flags = DRIVERS_CFLAGS if c_file.name == "nemc_drivers.c" else (
            UNIT_CFLAGS if "_unit" in c_file.name or "_spectrum" in c_file.name else CFLAGS)
        objects.append(c_file.with_suffix(".o"))
        subprocess.run([*compiler(), *flags, "-I", str(sources), "-c", str(c_file), "-o",
                        str(objects[-1])], check=True)
    library = folder / "bench.so"
    subprocess.run([*compiler(), "-shared", *map(str, objects), "-o", str(library), "-lm"],
                   check=True)
    ffi = cffi.FFI()
    ffi.cdef("void *bench_instance(const char *);"
             "int bench_chained(void *, const double *, int, const double *, long);")
    lib = ffi.dlopen(str(library))
    instance = lib.bench_instance(guid.encode())
    assert instance != ffi.NULL
    rows = np.ascontiguousarray(states)
    p = model.parameter_vector()
    keep = (ffi.from_buffer("double[]", rows), ffi.from_buffer("double[]", p))
    calls = len(rows)

    def chained(through: Any) -> Any:
        def call() -> None:
            if lib.bench_chained(through, keep[1], len(rows), keep[0], calls):
                raise RuntimeError("an evaluation failed")
        return call

    return {"the model's C rhs, chained": (chained(ffi.NULL), calls),
            "fmi2SetContinuousStates + fmi2GetDerivatives, chained": (chained(instance),
                                                                      calls)}


def run_contenders(model: nemc.Model, me: Path, cs: Path) -> tuple[dict, dict[str, float]]:
    """FMPy's runs of both FMUs and nemc's own at the scene's output times, and each one's
    largest difference from nemc.Radau at rtol 1e-12."""
    from fmpy import simulate_fmu

    start, stop = model.scene["t_span"] or (0.0, 10.0)
    step = model.scene["t_eval_step"] or (stop - start) / 100
    times = np.linspace(start, stop, int(round((stop - start) / step)) + 1)
    rtol, atol = model.scene["rtol"] or 1e-6, model.scene["atol"] or 1e-9
    names = list(model.state_names)
    reference = model.simulate(method="nemc.Radau", rtol=1e-12, atol=1e-12, t_eval=times).y
    runs = {
        "FMPy, model-exchange FMU (CVode, rtol 1e-10)": lambda: simulate_fmu(
            str(me), relative_tolerance=1e-10, output=names, output_interval=step,
            stop_time=stop),
        f"FMPy, co-simulation FMU (nemc.DOP853 inside, rtol {rtol:g})": lambda: simulate_fmu(
            str(cs), output=names, output_interval=step, stop_time=stop),
        "model.simulate, nemc.Radau, rtol 1e-10": lambda: model.simulate(
            method="nemc.Radau", rtol=1e-10, atol=1e-10, t_eval=times),
        "model.simulate, nemc.DOP853, rtol 1e-10": lambda: model.simulate(
            method="nemc.DOP853", rtol=1e-10, atol=1e-10, t_eval=times),
        f"model.simulate, nemc.DOP853, rtol {rtol:g} (the co-simulation's method)":
            lambda: model.simulate(method="nemc.DOP853", rtol=rtol, atol=atol, t_eval=times),
    }
    errors = {}
    for name, run in runs.items():
        result = run()
        states = result.y if hasattr(result, "y") else np.array([result[n] for n in names])
        errors[name] = float(np.abs(states - reference).max())
    return {name: (run, 1) for name, run in runs.items()}, errors


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--example", default="double_pendulum")
    args = parser.parse_args()
    model = nemc.compile(ROOT / "examples" / f"{args.example}.yaml")
    folder = tempfile.TemporaryDirectory(prefix="nemc-fmu-bench-")
    where = Path(folder.name)
    me = model.export_fmu(where / "me.fmu")
    cs = model.export_fmu(where / "cs.fmu", kind="cs")
    along = model.simulate((0.0, 20.0), method="nemc.DOP853", rtol=1e-10, atol=1e-12,
                           t_eval=np.linspace(0.0, 20.0, 1000)).y.T
    print(f"load average at start: {os.getloadavg()}")
    loops = derivative_loops(model, me, along, where / "derivatives")
    times = interleaved(loops, args.rounds, target=0.2)
    print(f"\n{model.name}: derivatives at 1,000 states of a run, per call\n")
    print("| call | time per call, median (min-max) |\n| --- | --- |")
    for name, summary in times.items():
        print(f"| {name} | {spread(summary)} |")
    rhs, fmu = (times[name]["median"] for name in loops)
    print(f"\nthe FMU's derivatives cost {fmu / rhs:.2f}x the model's C rhs")
    contenders, errors = run_contenders(model, me, cs)
    times = interleaved(contenders, args.rounds, target=0.5)
    print(f"\n{model.name}: a run over the scene's span at its output times\n")
    print("| run | time, median (min-max) | largest difference from nemc.Radau at rtol 1e-12 |"
          "\n| --- | --- | --- |")
    for name, summary in times.items():
        print(f"| {name} | {spread(summary)} | {errors[name]:.1e} |")
    folder.cleanup()
    print(f"\nload average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
