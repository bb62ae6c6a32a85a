"""The `nemc` command: compile, simulate, show, check, bench, stress.

Exit status: 0 success; 2 bad input (`FILE:LINE: key.path: what is wrong`, no traceback);
1 any other failure (e.g. the C compiler failed: the message names the C file and its error);
130 interrupted (Ctrl-C; `simulate` prints the states it has first).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from .errors import BuildError, InputError

EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a command stopped by Ctrl-C


def parse_assignment(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    name = name.strip()
    try:
        return name, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name}: expected a number, got {value!r}") from None


def finite_number(text: str) -> float:
    """An option's value: a finite number (argparse reports anything else, exit status 2)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive_number(text: str) -> float:
    value = finite_number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="nemc", description="Newton-Euler Mechanism Compiler")
    commands = parser.add_subparsers(dest="command", required=True)
    comp = commands.add_parser("compile", help="derive, emit C, compile; write DIR/<name>/")
    comp.add_argument("mechanism")
    comp.add_argument("-o", "--output", default="generated", help="output folder (generated)")
    sim = commands.add_parser("simulate", help="run the scene and print the table")
    sim.add_argument("mechanism")
    sim.add_argument("--t-end", type=finite_number,
                     help="end time (the scene's t_span end by default)")
    sim.add_argument("--method", help="nemc.DOP853 nemc.Radau nemc.Vern9 (native), or scipy's"
                     " RK45 RK23 DOP853 Radau BDF LSODA (default: the scene's, else nemc.DOP853)")
    sim.add_argument("--rtol", type=positive_number)
    sim.add_argument("--atol", type=positive_number)
    sim.add_argument("--set", dest="params", type=parse_assignment, action="append", default=[],
                     metavar="NAME=VALUE", help="override a parameter (repeatable)")
    sim.add_argument("--csv", help="also write the table to this CSV file")
    sim.add_argument("--plot", help="write the book-style figure to this file (PNG, PDF, SVG)")
    sim.add_argument("--error-estimate", action="store_true",
                     help="also print the run's error against DOP853 at rtol/1000, atol/1000")
    show = commands.add_parser("show", help="print the derived equations of motion")
    show.add_argument("mechanism")
    show.add_argument("--latex", action="store_true")
    check = commands.add_parser("check", help="validate only")
    check.add_argument("mechanism")
    bench = commands.add_parser("bench", help="run the benchmark suite (benchmarks/)")
    bench.add_argument("--quick", action="store_true", help="the quick mode (under 2 minutes)")
    bench.add_argument("--sizes", help="chain sizes, comma-separated (e.g. 2,4,8)")
    bench.add_argument("--scaling", action="store_true",
                       help="the scaling benchmark (benchmarks/scaling.py) instead of the suite")
    add_stress_parser(commands)
    return parser


def add_stress_parser(commands: argparse._SubParsersAction) -> None:
    stress = commands.add_parser(
        "stress", help="measure accuracy, energy drift, sensitivity, stiffness, conditioning")
    stress.add_argument("mechanism", nargs="?", help="the YAML file (or --suite)")
    stress.add_argument("--suite", choices=["book"], help="the book's four systems + an index")
    stress.add_argument("--out", default="generated/stress",
                        help="folder for the Markdown and PNG (generated/stress)")
    stress.add_argument("--horizon", type=float, default=1000.0,
                        help="long horizon for energy drift of conservative scenes (1000 s)")
    stress.add_argument("--set", dest="params", type=parse_assignment, action="append",
                        default=[], metavar="NAME=VALUE", help="override a parameter")


def cmd_compile(args: argparse.Namespace) -> int:
    from .build import export
    from .pipeline import compile_mechanism

    compiled = compile_mechanism(args.mechanism)
    target = export(compiled.package, Path(args.output), compiled.model.name)
    print(target)
    state = "cached build loaded" if compiled.cached else "built"
    stages = ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in compiled.timings.items())
    print(f"{compiled.model.name}: {state}; {stages}")
    functions = compiled.model.metadata["generated"]
    print(f"generated C functions: {', '.join(functions)}")
    if "outputs" not in functions:
        print("no outputs requested: no output code generated")
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    from . import report
    from .pipeline import compile_mechanism
    from .runs import INTERRUPTED
    from .runtime import ModelError

    model = compile_mechanism(args.mechanism).model
    params = dict(args.params)
    span = model.scene["t_span"] or [0.0, 10.0]
    t_span = (span[0], args.t_end) if args.t_end is not None else None
    if t_span is not None and not t_span[1] > t_span[0]:
        print(f"{args.mechanism}: --t-end: must be after the start time {span[0]:g}, got "
              f"{args.t_end:g}", file=sys.stderr)
        return 2
    try:
        result = model.simulate(t_span, method=args.method, rtol=args.rtol, atol=args.atol,
                                params=params)
    except ModelError as error:
        print(f"{args.mechanism}: --set/options: {error}", file=sys.stderr)
        return 2
    print(report.table(model, result))
    if result.status == INTERRUPTED:  # Ctrl-C: what was computed is printed (and written)
        if args.csv:
            report.write_csv(model, result, Path(args.csv))
        print(f"nemc: {result.message}", file=sys.stderr)
        return EXIT_INTERRUPTED
    if args.error_estimate and result.success:
        print_error_estimate(model, result, params)
    if args.csv:
        report.write_csv(model, result, Path(args.csv))
    if args.plot:  # smooth curves: the same run, sampled densely
        dense = model.simulate(t_span, method=args.method, rtol=args.rtol, atol=args.atol,
                               params=params, t_eval=report.dense_times(result))
        report.plot(model, dense, Path(args.plot))
        print(f"figure written to {args.plot}")
    if not result.success:
        print(f"integration failed: {result.message}", file=sys.stderr)
        return 1
    return 0


def print_error_estimate(model, result, params: dict) -> None:
    from .stress import error_estimate

    errors, rtol, atol = error_estimate(model, result, params)
    listed = ", ".join(f"{name} {value:.2g}" for name, value in errors.items())
    print(f"# error estimate (max |y - y_ref| over the table's times; y_ref: DOP853 at rtol "
          f"{rtol:g}, atol {atol:g}): {listed}")


def cmd_stress(args: argparse.Namespace) -> int:
    from . import stress_report
    from .runtime import ModelError

    if (args.mechanism is None) == (args.suite is None):
        print("nemc stress: give a mechanism file or --suite book (not both)", file=sys.stderr)
        return 2
    out = Path(args.out)
    finished = stress_report.Finished(Path(args.mechanism or "book").stem)
    try:
        if args.suite:
            stress_report.run_suite(out, args.horizon)
            return 0
        study = stress_report.study(args.mechanism, args.horizon, params=dict(args.params),
                                    finished=finished)
    except ModelError as error:
        print(f"{args.mechanism or args.suite}: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # keep what is finished
        if not args.suite:
            print(f"nemc: interrupted; what was measured: "
                  f"{stress_report.write_partial(finished, out)}", file=sys.stderr)
        else:
            print("nemc: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    print(f"{study.name}: measured in {study.seconds:.1f} s -> {stress_report.write(study, out)}")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    from .show import show
    from .validate import load_mechanism

    print(show(load_mechanism(args.mechanism), latex=args.latex))
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from .validate import load_mechanism

    mech = load_mechanism(args.mechanism)
    print(f"{args.mechanism}: OK: {mech.name}, {len(mech.bodies)} bodies, "
          f"{len(mech.coordinates)} coordinates, state {list(mech.state_names)}")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    """Run a benchmark script's main() with this command's options (the scripts live in
    benchmarks/, beside the package in a source checkout)."""
    import runpy

    script = "scaling.py" if args.scaling else "run.py"
    suite = Path(__file__).resolve().parent.parent / "benchmarks" / script
    if not suite.is_file():
        print(f"the benchmark suite is not here: {suite} (it ships with nemc's source, not "
              "with an installed wheel)", file=sys.stderr)
        return 1
    argv = (["--quick"] if args.quick else []) + (["--sizes", args.sizes] if args.sizes else [])
    return int(runpy.run_path(str(suite))["main"](argv) or 0)


COMMANDS = {
    "compile": cmd_compile,
    "simulate": cmd_simulate,
    "show": cmd_show,
    "check": cmd_check,
    "bench": cmd_bench,
    "stress": cmd_stress,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; every expected failure is one message on stderr, never a traceback."""
    args = make_parser().parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except InputError as error:
        print(error, file=sys.stderr)
        return 2
    except BuildError as error:
        print(f"nemc: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C outside a run (a run returns what it has)
        print("nemc: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # e.g. `nemc simulate ... | head`
        sys.stderr.close()
        return 0
    except OSError as error:  # e.g. --csv or --plot into a folder that cannot be written
        where = f" {error.filename}" if error.filename else ""
        print(f"nemc: cannot write{where}: {error.strerror or error}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
