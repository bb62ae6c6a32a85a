"""What forward sensitivities cost (issue 47): the double pendulum's run with its sensitivities
to its 4 initial values and 5 parameters against the plain run, and against heyoka's var_ode_sys.

Run: `python benchmarks/sensitivities.py [--quick | --smoke] [--out DIR]`; part of `make bench`.
Results: benchmarks/results/sensitivities-latest.{json,md} (smoke: a temporary folder).

System: the book's double pendulum (5.2) over [0, 20] at rtol 1e-10 (atol 1e-12), the state at
t = 20 only. Contenders: nemc.Vern9 and nemc.DOP853 (the sensitivity system in C, in the same
error control as the state), nemc.Taylor (the columns' series the tangent of the state's, in
one expansion), in full mode nemc.Radau (its Newton matrix diag(J_y, ..., J_y), factored once
per block) and scipy's DOP853 on the same C right-hand side, each with and without the 9
sensitivity columns; heyoka's var_ode_sys (first order, by the initial values and
the parameters, heyoka's Taylor method at tol 1e-10; its JIT time reported apart) and its own
plain run, when heyoka is installed (the `peers` extra). Every contender's error is its
sensitivities' largest error at t = 20 over the largest entry, against scipy's DOP853 at rtol
1e-13 (the same error for all: "at equal error" is read from the table). The with/without pairs
are timed interleaved (common.interleaved: calibrated loops, rounds rotating the order); ratio =
median with / median without, with the range of the per-round ratios; the load average is
recorded at the start and the end, all timed work pinned to one CPU (common.one_cpu). Then
(quick and full modes) where the time goes: the calls, one call's cost timed in a C loop and the
drivers' own work per call (sensitivity_breakdown.py), and the floor they leave.
"""

from __future__ import annotations

import functools
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import common  # noqa: E402 (the benchmarks folder is not a package)
import sensitivity_breakdown  # noqa: E402
from common import ROOT, fmt_time  # noqa: E402

import nemc  # noqa: E402

BOOK = ROOT / "examples" / "double_pendulum.yaml"
RTOL, ATOL = 1e-10, 1e-12
TARGET = 4.0  # the bound on sensitivities / plain run
NAMES = ["y0", "m1", "m2", "L1", "L2", "g"]  # 4 initial values, 5 parameters: 9 columns


@dataclass(frozen=True)
class Config:
    mode: str
    t_end: float
    methods: tuple[str, ...]
    rounds: int
    sample_seconds: float
    heyoka: bool
    breakdown: bool  # where the time goes (sensitivity_breakdown.py): one call timed in C


MODES = {
    "full": Config("full", 20.0, ("nemc.Vern9", "nemc.DOP853", "nemc.Taylor", "nemc.Radau",
                                  "DOP853"), 15, 0.2, True, True),
    "quick": Config("quick", 20.0, ("nemc.Vern9", "nemc.DOP853", "nemc.Taylor"), 7, 0.1, True,
                    True),
    "smoke": Config("smoke", 2.0, ("nemc.Vern9",), 2, 0.01, False, False),
}


def final_sensitivities(res: Any) -> np.ndarray:
    """The 4 x 9 sensitivities at the run's last time, in NAMES' order."""
    return np.column_stack([res.sensitivities["y0"][:, :, -1],
                            *(res.sensitivities[name][:, -1:] for name in NAMES[1:])])


def relative_error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(ours - reference).max() / np.abs(reference).max())


def nemc_pair(model: Any, method: str, span: tuple[float, float], reference: np.ndarray,
              config: Config) -> dict[str, Any]:
    """One method with and without the sensitivities, timed interleaved."""
    options = {"method": method, "rtol": RTOL, "atol": ATOL, "t_eval": [span[1]]}
    with_ = model.simulate(span, sensitivities=NAMES, **options)
    without = model.simulate(span, **options)
    assert with_.success and without.success, (with_.message, without.message)
    times = common.interleaved({
        "plain": (lambda: model.simulate(span, **options), 1),
        "sensitivities": (lambda: model.simulate(span, sensitivities=NAMES, **options), 1),
    }, config.rounds, config.sample_seconds)
    ratios = [b / a for a, b in zip(times["plain"]["values"], times["sensitivities"]["values"])]
    return {"contender": method, "plain": times["plain"], "sensitivities":
            times["sensitivities"], "ratio": times["sensitivities"]["median"] /
            times["plain"]["median"], "ratio_range": [min(ratios), max(ratios)],
            "nfev": [without.nfev, with_.nfev],
            "error": relative_error(final_sensitivities(with_), reference)}


def heyoka_system(model: Any) -> tuple[Any, list[Any], list[float]]:
    """The double pendulum in heyoka from nemc's own M and f (runtime symbols: the parameters
    as heyoka's pars, in nemc's order), qdd by LDL^T (benchmarks/peers.py's ldl_solve)."""
    import heyoka as hy
    import sympy
    from peers import ldl_solve

    from nemc.derive.equations import derive
    from nemc.front.validate import validate_text

    eqs = derive(validate_text(BOOK.read_bytes(), BOOK.name))
    mass, forcing = eqs.mass_forcing
    n = eqs.n
    variables = hy.make_vars(*[f"y{k}" for k in range(2 * n)])
    smap = {**{q: variables[2 * k] for k, q in enumerate(eqs.coordinates)},
            **{u: variables[2 * k + 1] for k, u in enumerate(eqs.speeds)},
            **{p: hy.par[k] for k, p in enumerate(eqs.parameters)}}
    def convert(expr: Any) -> Any:  # heyoka takes no rational 1/3: a double of it
        floats = {r: sympy.Float(r, 17) for r in expr.atoms(sympy.Rational) if not r.is_Integer}
        return hy.from_sympy(expr.xreplace(floats), s_dict=smap)

    m = [[convert(mass[max(i, j), min(i, j)]) for j in range(n)] for i in range(n)]
    f = [convert(forcing[i]) for i in range(n)]
    qdd = ldl_solve(m, f, lambda e: e)
    system = [eq for k in range(n) for eq in ((variables[2 * k], variables[2 * k + 1]),
                                              (variables[2 * k + 1], qdd[k]))]
    pars = [model.parameters[p.name] for p in eqs.parameters]
    return system, variables, pars


def heyoka_pair(model: Any, span: tuple[float, float], reference: np.ndarray,
                config: Config) -> dict[str, Any]:
    """heyoka's var_ode_sys and its plain run at tol RTOL, timed interleaved; JIT apart."""
    import heyoka as hy

    system, _, pars = heyoka_system(model)
    y0 = list(model.initial_state())
    start = time.perf_counter()
    plain = hy.taylor_adaptive(system, y0, pars=pars, tol=RTOL)
    jit_plain = time.perf_counter() - start
    start = time.perf_counter()
    variational = hy.taylor_adaptive(
        hy.var_ode_sys(system, hy.var_args.vars | hy.var_args.params, order=1), y0, pars=pars,
        tol=RTOL)
    jit_variational = time.perf_counter() - start
    initial_plain, initial_var = plain.state.copy(), variational.state.copy()

    def run(ta: Any, state: np.ndarray) -> Callable[[], Any]:
        def call() -> Any:
            ta.time = span[0]
            ta.state[:] = state
            return ta.propagate_until(span[1])
        return call

    run(variational, initial_var)()
    columns = np.zeros((len(y0), len(y0) + len(pars)))
    vslice = variational.get_vslice(order=1)
    for index in range(vslice.start, vslice.stop):
        mindex = variational.get_mindex(index)
        columns[mindex[0], int(np.argmax(mindex[1:]))] = variational.state[index]
    error = relative_error(columns, reference)
    times = common.interleaved({"plain": (run(plain, initial_plain), 1),
                                "sensitivities": (run(variational, initial_var), 1)},
                               config.rounds, config.sample_seconds)
    ratios = [b / a for a, b in zip(times["plain"]["values"], times["sensitivities"]["values"])]
    return {"contender": "heyoka var_ode_sys (taylor)", "plain": times["plain"],
            "sensitivities": times["sensitivities"], "ratio": times["sensitivities"]["median"]
            / times["plain"]["median"], "ratio_range": [min(ratios), max(ratios)],
            "nfev": [None, None], "error": error,
            "jit_seconds": {"plain": jit_plain, "var_ode_sys": jit_variational}}


def run(config: Config) -> dict[str, Any]:
    env = common.environment(config.mode)
    started = time.perf_counter()
    model = nemc.compile(BOOK)
    span = (0.0, config.t_end)
    build = time.perf_counter()
    model.simulate(span, sensitivities=NAMES, method="nemc.Vern9", t_eval=[span[1]])
    first_call = time.perf_counter() - build  # the part "sensitivities" and the drivers
    tight = model.simulate(span, sensitivities=NAMES, method="DOP853", rtol=1e-13, atol=1e-15,
                           t_eval=[span[1]])
    reference = final_sensitivities(tight)
    rows: list[dict[str, Any]] = []
    heyoka_note = None
    with common.one_cpu(env):
        for method in config.methods:
            rows.append(nemc_pair(model, method, span, reference, config))
            print(f"  {method}: {rows[-1]['ratio']:.2f}x the plain run", flush=True)
        if config.heyoka:
            try:
                rows.append(heyoka_pair(model, span, reference, config))
                print(f"  heyoka: {rows[-1]['ratio']:.2f}x its plain run", flush=True)
            except ImportError:
                heyoka_note = "heyoka is not installed (pip install '.[peers]')"
        parts = where_the_time_goes(model, rows, config)
    common.finish_environment(env, started)
    return {"environment": env, "config": config.__dict__, "rows": rows, "target": TARGET,
            "first_call_seconds": first_call, "heyoka": heyoka_note, "breakdown": parts}


def where_the_time_goes(model: Any, rows: list[dict[str, Any]], config: Config
                        ) -> list[dict[str, Any]]:
    """The native rows' ratios split into calls, one call's cost and the drivers' work
    (nemc.Taylor's apart: its expansions are no calls of the right-hand side)."""
    native = [row for row in rows if row["contender"].startswith("nemc.")
              and row["contender"] != "nemc.Taylor"]
    if not config.breakdown or not native:
        return []
    loops = sensitivity_breakdown.call_loops(model, NAMES)
    parts = []
    for row in native:
        span = (0.0, config.t_end)
        options = {"method": row["contender"], "rtol": RTOL, "atol": ATOL, "t_eval": [span[1]]}
        plain = functools.partial(model.simulate, span, **options)
        with_ = functools.partial(model.simulate, span, sensitivities=NAMES, **options)
        times = common.interleaved({"plain": (plain, 1), "sensitivities": (with_, 1), **loops},
                                   config.rounds, config.sample_seconds)
        parts.append(sensitivity_breakdown.breakdown(row["contender"], times, row["nfev"], 9))
    return parts


def markdown(result: dict[str, Any]) -> str:
    config = result["config"]
    lines = ["# Sensitivities: the double pendulum's 4 initial values and 5 parameters", "",
             *common.md_environment(result["environment"]), "",
             f"Over [0, {config['t_end']:g}] at rtol {RTOL:g}, atol {ATOL:g}; the state at the "
             "end only. Ratio = median time with the 9 sensitivity columns / without (range: "
             f"the per-round ratios). The issue's target: <= {TARGET:g}x. Error: the "
             "sensitivities at the end against scipy's DOP853 at rtol 1e-13, largest entry "
             "error / largest entry. nemc.Taylor's rhs calls are its expansions (one a step).",
             "",
             "| contender | plain | with sensitivities | ratio (range) | rhs calls plain / "
             "with | error |", "| --- | --- | --- | --- | --- | --- |"]
    for row in result["rows"]:
        low, high = row["ratio_range"]
        nfev = " / ".join("-" if v is None else str(v) for v in row["nfev"])
        lines.append(f"| {row['contender']} | {common.spread(row['plain'])} | "
                     f"{common.spread(row['sensitivities'])} | {row['ratio']:.2f}x ({low:.2f}"
                     f"–{high:.2f}) | {nfev} | {row['error']:.1e} |")
    by_name = {row["contender"]: row for row in result["rows"]}
    heyoka = by_name.get("heyoka var_ode_sys (taylor)")
    lines += ["", f"First call with sensitivities (the part \"sensitivities\" and the drivers "
              f"for its size, compiled once, then cached): "
              f"{fmt_time(result['first_call_seconds'])}."]
    if heyoka is not None:
        jit = heyoka["jit_seconds"]
        lines.append(f"heyoka's JIT: {fmt_time(jit['plain'])} (plain), "
                     f"{fmt_time(jit['var_ode_sys'])} (var_ode_sys), apart from the times above.")
        for name in ("nemc.Vern9", "nemc.DOP853", "nemc.Taylor"):
            if name in by_name:
                faster = heyoka["sensitivities"]["median"] / by_name[name]["sensitivities"][
                    "median"]
                lines.append(f"{name} with sensitivities vs heyoka's var_ode_sys: "
                             f"{faster:.2f}x as fast (errors {by_name[name]['error']:.1e} vs "
                             f"{heyoka['error']:.1e}).")
    elif result["heyoka"]:
        lines.append(result["heyoka"] + ".")
    if result.get("breakdown"):
        lines += ["", *sensitivity_breakdown.markdown_lines(result["breakdown"])]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = common.mode_parser(__doc__.splitlines()[0], "fewer rounds, nemc's methods and "
                                "heyoka", "a short span, one method (tests)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    mode = common.mode_of(args)
    print(f"nemc sensitivities benchmark, {mode} mode", flush=True)
    result = run(MODES[mode])
    common.write_results(result, common.results_folder(args, "nemc-bench-sensitivities-"),
                         "sensitivities", markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
