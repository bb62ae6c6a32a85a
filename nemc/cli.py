"""The `nemc` command: compile, simulate, show, check, bench.

Exit status: 0 success; 2 bad input (`FILE:LINE: key.path: what is wrong`, no traceback);
1 any other failure (e.g. the C compiler failed: the message names the C file and its error).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from .errors import BuildError, InputError


def parse_assignment(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    name = name.strip()
    try:
        return name, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name}: expected a number, got {value!r}") from None


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="nemc", description="Newton-Euler Mechanism Compiler")
    commands = parser.add_subparsers(dest="command", required=True)
    comp = commands.add_parser("compile", help="derive, emit C, compile; write DIR/<name>/")
    comp.add_argument("mechanism")
    comp.add_argument("-o", "--output", default="generated", help="output folder (generated)")
    sim = commands.add_parser("simulate", help="run the scene and print the table")
    sim.add_argument("mechanism")
    sim.add_argument("--t-end", type=float, help="end time (the scene's t_span end by default)")
    sim.add_argument("--method", help="RK45 RK23 DOP853 Radau BDF LSODA")
    sim.add_argument("--rtol", type=float)
    sim.add_argument("--atol", type=float)
    sim.add_argument("--set", dest="params", type=parse_assignment, action="append", default=[],
                     metavar="NAME=VALUE", help="override a parameter (repeatable)")
    sim.add_argument("--csv", help="also write the table to this CSV file")
    sim.add_argument("--plot", help="write the book-style figure to this file (PNG, PDF, SVG)")
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
    return parser


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
    from .runtime import ModelError

    model = compile_mechanism(args.mechanism).model
    params = dict(args.params)
    span = model.scene["t_span"] or [0.0, 10.0]
    t_span = (span[0], args.t_end) if args.t_end is not None else None
    try:
        result = model.simulate(t_span, method=args.method, rtol=args.rtol, atol=args.atol,
                                params=params)
    except ModelError as error:
        print(f"{args.mechanism}: --set/options: {error}", file=sys.stderr)
        return 2
    print(report.table(model, result))
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
    import runpy

    script = "scaling.py" if args.scaling else "run.py"
    suite = Path(__file__).resolve().parent.parent / "benchmarks" / script
    if not suite.is_file():
        print(f"the benchmark suite is not here: {suite}", file=sys.stderr)
        return 1
    sys.argv = [str(suite)] + (["--quick"] if args.quick else []) + (
        ["--sizes", args.sizes] if args.sizes else [])
    try:
        runpy.run_path(str(suite), run_name="__main__")
    except SystemExit as done:
        return int(done.code or 0)
    return 0


COMMANDS = {
    "compile": cmd_compile,
    "simulate": cmd_simulate,
    "show": cmd_show,
    "check": cmd_check,
    "bench": cmd_bench,
}


def main(argv: Sequence[str] | None = None) -> int:
    args = make_parser().parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except InputError as error:
        print(error, file=sys.stderr)
        return 2
    except BuildError as error:
        print(f"nemc: build failed: {error}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # e.g. `nemc simulate ... | head`
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
