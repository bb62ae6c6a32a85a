"""The `nemc` command: compile, simulate, show, check, bench, stress, animate, sweep
(sweep_cli.py), linearize (plant_cli.py), export (fmu_cli.py), fit (fit_cli.py).

Exit status: 0 success; 2 bad input (`FILE:LINE: key.path: what is wrong`, no traceback);
1 any other failure (e.g. the C compiler failed: the message names the C file and its error);
130 interrupted (Ctrl-C; `simulate` prints the states it has first).
"""

from __future__ import annotations

import argparse
import fnmatch
import importlib.metadata
import math
import os
import re
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

from ..errors import BuildError, InputError, OutputRefused
from .files import output_refusal
from .fit_cli import add_fit_parser, cmd_fit
from .fmu_cli import add_export_parser, cmd_export
from .plant_cli import add_linearize_parser, cmd_linearize
from .start import start_values
from .sweep_cli import add_sweep_parser, cmd_sweep

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


def relative_tolerance(text: str) -> float:
    value = finite_number(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected a number > 0 and < 1, got {text!r}")
    return value


def figure_path(text: str) -> str:
    """--plot's file: its suffix names a format matplotlib writes, so the file written is
    exactly the one named (a name without one got '.png' added: the message named another)."""
    from matplotlib.backend_bases import FigureCanvasBase

    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    suffix = Path(text).suffix.lower().lstrip(".")
    if suffix not in formats:
        raise argparse.ArgumentTypeError(
            f"expected a file name ending in a figure format ({', '.join(formats)}), got {text!r}")
    return text


def installed_version() -> str:
    """nemc's version from the package metadata pip wrote, or the source tree's own
    (vocabulary.NEMC_VERSION) when nemc runs from a tree it was not installed from."""
    from ..vocabulary import NEMC_VERSION

    try:
        return importlib.metadata.version("nemc")
    except importlib.metadata.PackageNotFoundError:
        return NEMC_VERSION


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="nemc", description="Newton-Euler Mechanism Compiler")
    parser.add_argument("--version", action="version", version=f"nemc {installed_version()}")
    commands = parser.add_subparsers(dest="command", required=True)
    comp = commands.add_parser("compile", help="derive, emit C, compile; write DIR/<name>/")
    comp.add_argument("mechanism")
    comp.add_argument("-o", "--output", default="generated", help="output folder (generated)")
    comp.add_argument("--jacobian", action="store_true", default=None,
                      help="also build the analytic Jacobian and the mass matrix (for nemc.Radau, "
                      "model.jacobian, model.mass_matrix)")
    comp.add_argument("--taylor", action="store_true", default=None,
                      help="also build nemc.Taylor's coefficient code")
    comp.add_argument("--linearization", action="store_true",
                      help="also build the exact linearization (model.linearize, trim)")
    comp.add_argument("--sensitivities", action="store_true",
                      help="also build the variational equations (simulate(sensitivities=),"
                      " nemc.fit)")
    sim = commands.add_parser("simulate", help="run the scene and print the table")
    sim.add_argument("mechanism")
    add_run_options(sim)
    sim.add_argument("--t-eval", type=t_eval_spec, metavar="STEP|T1,T2,...",
                     help="the table's times: a step (0.5) or a list (0,0.5,2; one time: 2,)"
                     " (default: the scene's t_eval, else the solver's steps)")
    sim.add_argument("--outputs", type=name_list, metavar="NAMES",
                     help="the outputs to print, write and plot: names or patterns, comma-"
                     "separated (A.*,energy.total), or none (default: every output)")
    sim.add_argument("--csv", help="also write the table to this CSV file (units in headers)")
    sim.add_argument("--mat", help="also write the table to this MATLAB file (ts, xs, each"
                     " column, names, units)")
    sim.add_argument("--plot", type=figure_path,
                     help="write the report figure to this file (.png, .pdf, .svg, ...)")
    sim.add_argument("--panels", type=panel_list, metavar="KINDS",
                     help="what --plot draws, comma-separated: state, reactions, drives, loads,"
                     " energy, points, accelerations, expressions (default: all)")
    sim.add_argument("--x", metavar="NAME",
                     help="what --plot draws the curves against: t (default), a state entry"
                     " (q1, 'dot(q1)') or an output (A.drive)")
    sim.add_argument("--title", help="the figure's title (default: the model, method and "
                     "tolerances)")
    sim.add_argument("--size", type=figure_size, metavar="W,H",
                     help="the figure's size in inches (default: from its panels)")
    sim.add_argument("--only", type=name_list, metavar="NAMES",
                     help="the curves --plot draws: coordinates and outputs, names or patterns,"
                     " comma-separated (q1,A.*); panels left empty are left out")
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
    add_animate_parser(commands)
    add_sweep_parser(commands, parse_assignment, finite_number, positive_number)
    add_linearize_parser(commands, parse_assignment, parse_initial)
    add_export_parser(commands)
    add_fit_parser(commands, parse_assignment, figure_path)
    return parser


def add_stress_parser(commands: argparse._SubParsersAction) -> None:
    stress = commands.add_parser(
        "stress", help="measure accuracy, energy drift, sensitivity, stiffness, conditioning")
    stress.add_argument("mechanism", nargs="?", help="the YAML file (or --suite)")
    stress.add_argument("--suite", choices=["book"], help="the book's four systems + an index")
    stress.add_argument("--out", default="generated/stress",
                        help="folder for the Markdown and PNG (generated/stress)")
    stress.add_argument("--horizon", type=positive_number, default=1000.0,
                        help="long horizon for energy drift of conservative scenes (1000 s)")
    stress.add_argument("--set", dest="params", type=parse_assignment, action="append",
                        default=[], metavar="NAME=VALUE", help="override a parameter")


def frame_rate(text: str) -> float:
    """--fps: 0.01 to 1000 frames a second (a GIF holds a frame at most 655 s; 1e-9 gave an
    OverflowError)."""
    value = finite_number(text)
    if not 0.01 <= value <= 1000:
        raise argparse.ArgumentTypeError(f"expected frames per second from 0.01 to 1000, got "
                                         f"{text!r}")
    return value


def add_animate_parser(commands: argparse._SubParsersAction) -> None:
    animate = commands.add_parser("animate", help="run the scene and draw the mechanism moving")
    animate.add_argument("mechanism")
    animate.add_argument("--out", help="the file: .gif, .mp4 (needs ffmpeg) or .html "
                         "(default: generated/<name>.gif)")
    add_run_options(animate)
    animate.add_argument("--fps", type=frame_rate, default=25.0,
                         help="frames per second, 0.01 to 1000 (25)")
    animate.add_argument("--speed", type=positive_number, default=1.0,
                         help="model time per second of animation (1: real time)")
    animate.add_argument("--trace", type=name_list, metavar="POINTS",
                         help="points whose path is drawn, comma-separated (link2.D); default:"
                         " the scene's output points")


def cmd_animate(args: argparse.Namespace) -> int:
    from ..pipeline import compile_mechanism
    from ..runtime.model import ModelError
    from .animate import animate_result

    model = compile_mechanism(args.mechanism).model
    out = Path(args.out) if args.out else Path("generated") / f"{model.name}.gif"
    if out.suffix.lower() not in (".gif", ".mp4", ".html", ".htm"):
        print(f"{args.mechanism}: --out: choose a .gif, .mp4 or .html file, got {out}",
              file=sys.stderr)
        return 2
    try:
        run = run_settings(model, args)
        result = model.simulate(run["t_span"], run["y0"], method=args.method, rtol=args.rtol,
                                atol=args.atol, params=dict(args.params),
                                inputs=dict(args.inputs) or None)
        out.parent.mkdir(parents=True, exist_ok=True)
        animate_result(result, out, fps=args.fps, speed=args.speed, traces=args.trace)
    except (ModelError, ValueError) as error:
        print(f"{args.mechanism}: --set/options: {error}", file=sys.stderr)
        return 2
    print(f"animation written to {out} ({result.method}, t = {result.t[0]:g} .. "
          f"{result.t[-1]:g})")
    if not result.success:
        print(failure_line(result.message), file=sys.stderr)
        return 1
    return 0


def cmd_compile(args: argparse.Namespace) -> int:
    from ..build.builder import export
    from ..pipeline import compile_mechanism

    compiled = compile_mechanism(args.mechanism, args.jacobian, taylor=args.taylor,
                                 mass_matrix=bool(args.jacobian),
                                 linearization=args.linearization,
                                 sensitivities=args.sensitivities)
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
    from ..pipeline import compile_mechanism
    from ..runtime.model import ModelError
    from ..runtime.runs import INTERRUPTED
    from ..vocabulary import SCIPY_METHODS
    from . import report

    model = compile_mechanism(args.mechanism).model
    params = dict(args.params)
    try:
        run = run_settings(model, args)
        outputs = chosen_outputs(model, args.outputs)
        checked_x(model, args.x)

        def simulate(method: str | None) -> Any:
            return model.simulate(run["t_span"], run["y0"], method=method, rtol=args.rtol,
                                  atol=args.atol, params=params, t_eval=run["t_eval"],
                                  inputs=dict(args.inputs) or None)

        if model.scene.get("method") in SCIPY_METHODS:  # its import outside the time measured
            import scipy.integrate  # noqa: F401
        result, seconds = timed(simulate, args.method)
    except (ModelError, ValueError) as error:
        print(f"{args.mechanism}: --set/options: {error}", file=sys.stderr)
        return 2
    print(report.table(model, result, outputs))
    if result.status == INTERRUPTED:  # Ctrl-C: what was computed is printed (and written)
        if args.csv:
            with writing(Path(args.csv)):
                report.write_csv(model, result, Path(args.csv), outputs)
        print(f"nemc: {result.message}", file=sys.stderr)
        return EXIT_INTERRUPTED
    if args.error_estimate and result.success:
        print_error_estimate(model, result, params)
    if args.csv:
        with writing(Path(args.csv)):
            report.write_csv(model, result, Path(args.csv), outputs)
    if args.mat:
        with writing(Path(args.mat)):
            report.write_mat(model, result, Path(args.mat), outputs)
    if args.plot:
        with writing(Path(args.plot)):
            report.plot(result, Path(args.plot), panels=args.panels, outputs=outputs, x=args.x,
                        title=args.title, size=args.size, only=args.only)
        print(f"figure written to {args.plot}")
    if not result.success:
        print(failure_line(result.message), file=sys.stderr)
        return 1
    if args.method is None:  # last: what was asked for is written before the extra run
        note_native_speed(result, seconds, simulate)
    return 0


def failure_line(message: str) -> str:
    """The line saying a run failed, MESSAGE's prefix not doubled (a run whose equations could
    not be evaluated says "integration failed: ..." itself)."""
    prefix = "integration failed: "
    return message if message.startswith(prefix) else prefix + message


def add_run_options(command: argparse.ArgumentParser) -> None:
    """The options that set up a run: time, method, tolerances, parameters, initial state."""
    command.add_argument("--t-end", type=finite_number,
                         help="end time (the scene's t_span end by default)")
    command.add_argument("--method", help="nemc.DOP853 nemc.Radau nemc.Vern9 nemc.Taylor "
                         "(native), scipy's RK45 RK23 DOP853 Radau BDF LSODA, or auto (default: "
                         "the scene's, else auto: nemc chooses, named in the output)")
    command.add_argument("--rtol", type=relative_tolerance)
    command.add_argument("--atol", type=positive_number)
    command.add_argument("--set", dest="params", type=parse_assignment, action="append",
                         default=[], metavar="NAME=VALUE",
                         help="override a parameter (repeatable)")
    command.add_argument("--initial", type=parse_initial, action="append", default=[],
                         metavar="NAME=VALUE", help="an initial coordinate or rate, e.g. "
                         "theta=0 or 'dot(q1)=0.5' (repeatable; the others: the scene's)")
    command.add_argument("--input", dest="inputs", type=parse_assignment, action="append",
                         default=[], metavar="NAME=VALUE",
                         help="an input held at a value (repeatable; the others: the YAML's)")


def parse_initial(text: str) -> tuple[str, float]:
    """NAME=VALUE for --initial: VALUE a number or a name-free expression (-pi/4)."""
    name, sep, value = text.partition("=")
    name = re.sub(r"\s+", "", name)
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    try:
        number = float(value)
    except ValueError:
        number = constant_expression(value)
    if not math.isfinite(number):
        raise argparse.ArgumentTypeError(f"{name}: expected a finite number, got {value!r}")
    return name, number


def constant_expression(text: str) -> float:
    """A name-free expression (2*pi/3) by nemc's expression grammar, never eval'ed."""
    from ..front.expr import ExprError, Scope, parse_expression

    try:
        return float(parse_expression(text, Scope(where="here (a number is expected)")))
    except (ExprError, TypeError, ValueError) as error:
        raise argparse.ArgumentTypeError(f"expected a number or an expression of numbers "
                                         f"and pi, got {text!r} ({error})") from None


def t_eval_spec(text: str) -> tuple[str, list[float]]:
    """--t-eval: ("step", [h]) for a number, ("times", [...]) for a comma-separated list."""
    parts = [part.strip() for part in text.split(",")]
    if len(parts) == 1:
        return "step", [positive_number(parts[0])]
    try:
        return "times", [finite_number(part) for part in parts if part]
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"a list of times: {error}") from None


def name_list(text: str) -> list[str]:
    return [] if text.strip() == "none" else [p.strip() for p in text.split(",") if p.strip()]


def panel_list(text: str) -> list[str]:
    from .figures import PANEL_KINDS

    kinds = name_list(text)
    unknown = [kind for kind in kinds if kind not in PANEL_KINDS]
    if unknown or not kinds:
        named = ", ".join(unknown) if unknown else repr(text)
        raise argparse.ArgumentTypeError(f"unknown panel kind(s) {named}; choose from "
                                         f"{', '.join(PANEL_KINDS)}")
    return kinds


def run_settings(model, args: argparse.Namespace) -> dict:
    """t_span, y0 and t_eval of a run from the options; ValueError names what is wrong."""
    import numpy as np

    span = model.scene["t_span"] or [0.0, 10.0]
    t_span = (span[0], args.t_end) if args.t_end is not None else None
    end = t_span[1] if t_span is not None else span[1]
    if not end > span[0]:
        raise ValueError(f"--t-end: must be after the start time {span[0]:g}, got {end:g}")
    y0 = None
    if args.initial:  # a closed loop's: the values kept, the others solved by the run
        y0 = start_values(model, dict(args.params), args.initial, "--initial")
    t_eval = None
    if getattr(args, "t_eval", None) is not None:
        kind, values = args.t_eval
        if kind == "step":  # at most checks.MAX_STEP_TIMES, counted before any is made
            from ..runtime.checks import step_times
            from ..runtime.failures import ModelError

            try:
                t_eval = step_times((span[0], end), values[0])
            except ModelError as error:
                raise ValueError(f"--t-eval: {error}") from None
        else:
            t_eval = np.array(values)
            if np.any(t_eval < span[0]) or np.any(t_eval > end) or np.any(np.diff(t_eval) <= 0):
                raise ValueError(f"--t-eval: times must increase within [{span[0]:g}, {end:g}]")
    return {"t_span": t_span, "y0": y0, "t_eval": t_eval}


def chosen_outputs(model, patterns: list[str] | None) -> list[str] | None:
    """The outputs --outputs names (None: all); a name or pattern matching none is an error."""
    if patterns is None:
        return None
    chosen = []
    for pattern in patterns:
        found = [n for n in model.output_names if fnmatch.fnmatchcase(n, pattern)]
        if not found:
            known = ", ".join(model.output_names) or "none: the YAML requests no outputs"
            raise ValueError(f"--outputs: no output {pattern!r}; the outputs: {known}")
        chosen += [n for n in found if n not in chosen]
    return chosen


@contextmanager
def writing(path: Path) -> Iterator[None]:
    """Writing PATH: a failure names it (a full disk's error names no file) and removes the
    part written, when the file did not exist before."""
    existed = os.path.lexists(path)
    try:
        yield
    except OSError as error:
        if not existed:
            with suppress(OSError):
                path.unlink()
        raise OSError(error.errno, error.strerror or str(error), str(path)) from None


# scipy's methods whose native port takes the same steps, to rounding (tests/test_native.py): a
# scene naming the scipy one still runs scipy's; `nemc simulate` notes what the port takes
SCIPY_PORTS = {"DOP853": "nemc.DOP853", "Radau": "nemc.Radau"}


def figure_size(text: str) -> tuple[float, float]:
    """--size W,H: two positive numbers of inches."""
    parts = text.split(",")
    try:
        width, height = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected W,H in inches (8,6), got {text!r}") from None
    if not (0 < width <= 100 and 0 < height <= 100):
        raise argparse.ArgumentTypeError(f"W and H must be in (0, 100] inches, got {text!r}")
    return width, height


def checked_x(model: Any, name: str | None) -> None:
    """--x names t, a state entry or an output (ValueError otherwise, listing them)."""
    known = ("t", *model.state_names, *model.output_names)
    if name is not None and name not in known:
        raise ValueError(f"--x: no state entry or output {name!r}; choose from "
                         f"{', '.join(known)}")


def timed(call: Callable[[Any], Any], argument: Any) -> tuple[Any, float]:
    """call(argument) and its wall time in seconds."""
    start = time.perf_counter()
    value = call(argument)
    return value, time.perf_counter() - start


def note_native_speed(result: Any, seconds: float, simulate: Callable[[Any], Any]) -> None:
    """When the scene names one of scipy's methods, its loop in Python over the compiled C, one
    line on stderr with what the native choice takes on the same run, measured now: the
    native port (the same steps to rounding, SCIPY_PORTS) or else the default, auto (decision
    0037). A scipy name still means scipy's method: the note only says what it costs, and a
    native run that fails or is refused gives no note."""
    from ..vocabulary import AUTO, SCIPY_METHODS

    if result.method not in SCIPY_METHODS:
        return
    from ..runtime.model import ModelError

    port = SCIPY_PORTS.get(result.method)
    try:  # twice, the faster: the first native run in a process also imports what it needs
        native, native_seconds = min((timed(simulate, port or AUTO) for _ in range(2)),
                                     key=lambda run: run[1])
    except (ModelError, ArithmeticError):  # the scene's own run stands; no note to give
        return
    if not native.success:
        return
    what = (f"{port} takes the same steps in C" if port else
            f"the default, auto ({native.method} here), at the same tolerances")
    fix = f"write `method: {port}`, or leave method out for auto" if port else (
        "leave method out for auto")
    print(f"nemc: note: the scene's method {result.method} is scipy's, its loop in Python: "
          f"{1e3 * seconds:.3g} ms; {what}: {1e3 * native_seconds:.3g} ms, "
          f"{seconds / max(native_seconds, 1e-9):.0f}x faster ({fix})", file=sys.stderr)


def print_error_estimate(model, result, params: dict) -> None:
    """The run's estimated error, each state entry's with its unit (the table's)."""
    from .report import unit_of
    from .stress import error_estimate

    errors, rtol, atol = error_estimate(model, result, params)
    listed = ", ".join(f"{name} {value:.2g} {unit_of(model, name)}".rstrip()
                       for name, value in errors.items())
    print(f"# error estimate (max |y - y_ref| over the table's times; y_ref: DOP853 at rtol "
          f"{rtol:g}, atol {atol:g}): {listed}")


def cmd_stress(args: argparse.Namespace) -> int:
    from ..runtime.model import ModelError
    from . import stress_report

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
    from ..front.validate import load_mechanism
    from .show import show

    print(show(load_mechanism(args.mechanism), latex=args.latex))
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    from ..derive.assembly import check_assembly
    from ..front.validate import load_mechanism

    mech = load_mechanism(args.mechanism)
    assembly = check_assembly(mech)
    loops = (f", {counted(len(mech.constraints), 'loop constraint')} "
             f"({counted(assembly.equations, 'equation')})" if mech.constraints else "")
    driven = f", {counted(len(mech.driven), 'driven joint')}" if mech.driven else ""
    contacts = f", {counted(len(mech.contacts), 'contact')}" if mech.contacts else ""
    print(f"{args.mechanism}: OK: {mech.name}, {counted(len(mech.bodies), 'body', 'bodies')}, "
          f"{counted(len(mech.coordinates), 'coordinate')}{driven}{loops}{contacts}, "
          f"{counted(assembly.freedom, 'degree', 'degrees')} of freedom"
          f"{'' if assembly.motion == assembly.freedom else ' of position, '}"
          f"{'' if assembly.motion == assembly.freedom else f'{assembly.motion} of motion'}, "
          f"state {list(mech.state_names)}")
    return 0


def counted(count: int, one: str, many: str | None = None) -> str:
    return f"{count} {one if count == 1 else many or one + 's'}"


def cmd_bench(args: argparse.Namespace) -> int:
    """Run a benchmark script's main() with this command's options (the scripts live in
    benchmarks/, beside the package in a source checkout)."""
    import runpy

    script = "scaling.py" if args.scaling else "run.py"
    suite = Path(__file__).resolve().parents[2] / "benchmarks" / script
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
    "animate": cmd_animate,
    "sweep": cmd_sweep,
    "linearize": cmd_linearize,
    "export": cmd_export,
    "fit": cmd_fit,
}


def one_line_warning(message: Warning | str, category: type[Warning], filename: str,
                     lineno: int, file: Any = None, line: str | None = None) -> None:
    """A warning during a command, one line on stderr (Python's names the user's line, which
    for a command is nemc's own `sys.exit(main())`, and prints it too)."""
    print(f"nemc: warning: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; every expected failure is one message on stderr, never a traceback;
    a warning one line."""
    with warnings.catch_warnings():
        warnings.showwarning = one_line_warning
        return command(argv)


def command(argv: Sequence[str] | None) -> int:
    """main's command, its expected failures each one message on stderr."""
    # The command's arrays are small, and its threads are nemc's own (runs in C, Dask workers):
    # numpy's BLAS threads would only spin, OpenBLAS's one per core for about 0.1 s of CPU
    # after numpy's import (benchmarks/startup.py). Set before numpy is imported; the user's
    # own setting wins.
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    args = make_parser().parse_args(argv)
    refusal = output_refusal(args)
    if refusal:
        print(f"nemc: {refusal}", file=sys.stderr)
        return 2
    try:
        return COMMANDS[args.command](args)
    except InputError as error:
        print(error, file=sys.stderr)
        return 2
    except OutputRefused as error:  # -o names a folder nemc did not write
        print(f"nemc: {error}", file=sys.stderr)
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
