"""`nemc fit MECH.yaml DATA.csv --fit NAME ... [--observed NAME ...]`: the mechanism fitted to
measured data (nemc.fit): a CSV with a header row, a column `t` and a column per observed state
entry or output; prints the estimates with their standard errors and correlation; `--out`
writes them (.json) and `--plot` the fit's figure (the data, the fitted model, the residuals;
fit_figures.py) only once the fit succeeded (nothing written half). Every bad input (a
column that is not a state entry or output, a value that is not a number or not finite, an
unknown name, a parameter the data cannot identify, a fit that does not converge) is one line
on stderr and exit status 2."""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

TIME_COLUMN = "t"


class DataError(ValueError):
    """A CSV that cannot be read as the measurements."""


def add_fit_parser(commands: argparse._SubParsersAction, assignment: Any,
                   figure_path: Any) -> None:
    fit = commands.add_parser("fit", help="estimate parameters and initial values from "
                              "measured data, with standard errors (nemc.fit)")
    fit.add_argument("mechanism")
    fit.add_argument("data", help="CSV: a header row, a column t, a column per observed "
                     "state entry or output (units as the model's)")
    fit.add_argument("--fit", nargs="+", required=True, metavar="NAME",
                     help="what to estimate: parameters, inputs (constants), initial values "
                     "(state names) or y0")
    fit.add_argument("--observed", nargs="+", metavar="NAME",
                     help="the data's columns to fit (default: every column but t)")
    fit.add_argument("--start", type=assignment, action="append", default=[],
                     metavar="NAME=VALUE", help="where a fitted name starts (repeatable)")
    fit.add_argument("--bounds", type=bound, action="append", default=[],
                     metavar="NAME=LOW:HIGH", help="bounds of a fitted name (repeatable)")
    fit.add_argument("--set", dest="params", type=assignment, action="append", default=[],
                     metavar="NAME=VALUE", help="override a parameter not fitted")
    fit.add_argument("--input", dest="inputs", type=assignment, action="append", default=[],
                     metavar="NAME=VALUE", help="an input's constant value (repeatable)")
    fit.add_argument("--sigma", type=float, metavar="S",
                     help="the data's noise standard deviation, taken as known (default: "
                     "estimated from the residuals)")
    fit.add_argument("--method", default="auto", help="the runs' method (default auto: "
                     "nemc.Vern9 or nemc.DOP853; scipy's methods too)")
    fit.add_argument("--rtol", type=float, default=1e-10, help="the runs' rtol (1e-10)")
    fit.add_argument("--shots", type=int, default=1, metavar="K",
                     help="multiple shooting: cut the run into K shots whose starts are "
                     "fitted too, joined by continuity defects (a chaotic mechanism; "
                     "default 1: one run)")
    fit.add_argument("--out", help="also write the estimates to this .json file")
    fit.add_argument("--plot", type=figure_path, metavar="FILE",
                     help="also draw the fit to this figure (.png, .pdf, .svg, ...): each "
                     "observed column's data with the fitted model, its residuals below")


def bound(text: str) -> tuple[str, tuple[float, float]]:
    name, sep, rest = text.partition("=")
    low, colon, high = rest.partition(":")
    try:
        if not (sep and colon):
            raise ValueError
        return name.strip(), (float(low), float(high))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=LOW:HIGH, got {text!r}") from None


def read_data(path: Path) -> tuple[list[str], list[list[float]]]:
    """The CSV's header and rows of numbers (every value finite)."""
    try:
        with path.open(newline="") as handle:
            rows = [row for row in csv.reader(handle) if row and any(v.strip() for v in row)]
    except UnicodeDecodeError:
        raise DataError("not a text CSV file") from None
    if len(rows) < 2:
        raise DataError("expected a header row and at least one row of values")
    header = [name.strip() for name in rows[0]]
    values = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise DataError(f"line {line}: {len(row)} values for {len(header)} columns")
        numbers = []
        for name, text in zip(header, row):
            try:
                number = float(text)
            except ValueError:
                raise DataError(f"line {line}: column {name!r}: not a number: {text!r}") \
                    from None
            if not math.isfinite(number):
                raise DataError(f"line {line}: column {name!r}: {text.strip()} is not a "
                                "finite number (remove the row)")
            numbers.append(number)
        values.append(numbers)
    return header, values


def measurements(header: list[str], values: list[list[float]], model: Any,
                 observed: list[str] | None) -> tuple[list[float], dict[str, list[float]]]:
    """The times and the observed columns, checked against the model's names."""
    if TIME_COLUMN not in header:
        raise DataError(f"no column {TIME_COLUMN!r} (the times); columns: {header}")
    known = (*model.state_names, *model.output_names)
    unknown = [name for name in header if name != TIME_COLUMN and name not in known]
    if unknown:
        raise DataError(f"columns {unknown} are neither state entries "
                        f"{list(model.state_names)} nor outputs of {model.name}")
    columns = {name: [row[k] for row in values] for k, name in enumerate(header)}
    chosen = observed or [name for name in header if name != TIME_COLUMN]
    missing = [name for name in chosen if name not in columns]
    if missing:
        raise DataError(f"--observed {missing}: no such column; columns: {header}")
    return columns[TIME_COLUMN], {name: columns[name] for name in chosen}


def cmd_fit(args: argparse.Namespace) -> int:
    from ..pipeline import compile_mechanism
    from ..runtime.failures import ModelError
    from ..runtime.fitting import fit

    where = f"{args.mechanism}: {args.data}"
    if args.out and Path(args.out).suffix.lower() != ".json":
        print(f"{where}: --out: choose a .json file, got {args.out}", file=sys.stderr)
        return 2
    model = compile_mechanism(args.mechanism).model
    try:
        header, values = read_data(Path(args.data))
        times, data = measurements(header, values, model, args.observed)
        weights = None if args.sigma is None else 1.0 / args.sigma
        result = fit(model, times, data, args.fit, list(data), weights=weights,
                     bounds=dict(args.bounds), start=dict(args.start),
                     params=dict(args.params), inputs=dict(args.inputs) or None,
                     method=args.method, rtol=args.rtol,
                     absolute_sigma=args.sigma is not None, shots=args.shots)
    except (DataError, ModelError) as error:
        print(f"{where}: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"{where}: cannot read the data: {error.strerror or error}", file=sys.stderr)
        return 2
    print(report(result, model.metadata.get("unit_labels", {})))
    if args.out:
        write(result, Path(args.out))
        print(f"written to {args.out}")
    if args.plot:
        try:
            draw(result, Path(args.plot))
        except OSError as error:
            print(f"{where}: --plot {args.plot}: cannot write: {error.strerror or error}",
                  file=sys.stderr)
            return 2
        print(f"figure written to {args.plot}")
    return 0


def estimates(result: Any, units: Mapping[str, str]) -> str:
    """The fit's table of estimates (its repr), with a unit column when any fitted value has a
    unit (an initial value's, from the YAML's `units:`; parameters and inputs have none)."""
    text = repr(result)
    known = [units.get(name, "") for name in result.names]
    if not any(known):
        return text
    lines = text.splitlines()
    marked = [f"{lines[0]}  unit"]
    marked += [f"{line}  [{unit}]" if unit else line
               for line, unit in zip(lines[1:1 + len(known)], known)]
    return "\n".join([*marked, *lines[1 + len(known):]])


def report(result: Any, units: Mapping[str, str] | None = None) -> str:
    """The estimates (with their units where known) and their correlation."""
    lines = [estimates(result, units or {}), "correlation:"]
    width = max(10, *(len(name) + 2 for name in result.names))
    lines.append(" " * width + "".join(f"{name:>{width}}" for name in result.names))
    for name, row in zip(result.names, result.correlation):
        lines.append(f"{name:>{width}}" + "".join(f"{v:>{width}.4f}" for v in row))
    if result.defects.size:
        lines.append(f"shots joined: largest continuity defect {abs(result.defects).max():.2g}")
    return "\n".join(lines)


def write(result: Any, path: Path) -> None:
    data = {"names": list(result.names), "values": result.values, "stderr": result.stderr,
            "covariance": result.covariance.tolist(),
            "correlation": result.correlation.tolist(), "rms": result.rms, "dof": result.dof,
            "nfev": result.nfev, "message": result.message}
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(json.dumps(data, indent=1) + "\n")
    temporary.replace(path)


def draw(result: Any, path: Path) -> None:
    """The fit's figure written to PATH whole or not at all (a temporary file renamed)."""
    from .fit_figures import DPI, fit_figure

    temporary = path.with_name(path.name + ".tmp")
    try:
        fit_figure(result).savefig(temporary, format=path.suffix.lower().lstrip("."), dpi=DPI)
        temporary.replace(path)
    finally:
        temporary.unlink(missing_ok=True)
