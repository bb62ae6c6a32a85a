"""`nemc linearize`: the model's exact linearization at a state, as tables: A, B, C, D (the
state-space form about the point) and the modes (natural frequencies in Hz, damping ratios);
`--out` writes them to .npz, .mat or .json."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .start import start_values

OUT_SUFFIXES = (".npz", ".mat", ".json")


def add_linearize_parser(commands: argparse._SubParsersAction, assignment: Any,
                         initial: Any) -> None:
    linearize = commands.add_parser(
        "linearize", help="A, B, C, D and the modes at a state (exact, from the derivation)")
    linearize.add_argument("mechanism")
    linearize.add_argument("--at", type=initial, action="append", default=[],
                           metavar="NAME=VALUE", help="a coordinate or rate of the state "
                           "(repeatable; the others: the scene's initial state; a closed "
                           "loop's solved, the values given kept)")
    linearize.add_argument("--input", dest="inputs", type=assignment, action="append",
                           default=[], metavar="NAME=VALUE",
                           help="an input's value (repeatable; the others: the YAML's)")
    linearize.add_argument("--set", dest="params", type=assignment, action="append",
                           default=[], metavar="NAME=VALUE", help="override a parameter")
    linearize.add_argument("--time", type=float, default=0.0,
                           help="the time (driven joints make A depend on it; 0)")
    linearize.add_argument("--trim", action="store_true",
                           help="at the equilibrium found from the state (Model.trim)")
    linearize.add_argument("--independent", metavar="NAMES", help="a closed loop's independent "
                           "coordinates, comma-separated (default: chosen by QR)")
    linearize.add_argument("--out", help="also write the matrices and modes (.npz, .mat, "
                           ".json)")


def cmd_linearize(args: argparse.Namespace) -> int:
    from ..pipeline import compile_mechanism
    from ..runtime.failures import ModelError

    if args.out and Path(args.out).suffix.lower() not in OUT_SUFFIXES:
        print(f"{args.mechanism}: --out: choose a {', '.join(OUT_SUFFIXES)} file, got "
              f"{args.out}", file=sys.stderr)
        return 2
    model = compile_mechanism(args.mechanism).model
    params = dict(args.params)
    try:
        # a closed loop's: the values kept, the others solved (an array was projected,
        # moving the values --at set)
        y = start_values(model, params, args.at, "--at") if args.at else \
            model.initial_state(params)
        u = dict(args.inputs) or None
        if args.trim:
            op = model.trim(y, u, t=args.time, params=params)
            y, u = op.y, dict(zip(model.input_names, op.u)) or None
            print(f"equilibrium: {op}")
        independent = args.independent.split(",") if args.independent else None
        lin = model.linearize(y, u, t=args.time, params=params, independent=independent)
    except ModelError as error:
        print(f"{args.mechanism}: {error}", file=sys.stderr)
        return 2
    print(report(lin, model.metadata.get("unit_labels", {})))
    if args.out:
        write(lin, Path(args.out))
        print(f"written to {args.out}")
    return 0


def matrix_table(name: str, matrix: Any, rows: tuple[str, ...], columns: tuple[str, ...],
                 units: Mapping[str, str] | None = None) -> str:
    """One matrix as a table: its columns' names, beneath them their units where known (as
    `[m/s]`), and each row named with its unit."""
    if not matrix.size:
        return f"{name}: empty ({len(rows)} x {len(columns)})"
    units = units or {}

    def unit(entry: str) -> str:
        return f"[{units[entry]}]" if units.get(entry) else ""

    width = max(12, *(len(c) + 2 for c in columns), *(len(unit(c)) + 2 for c in columns))
    row_names = [f"{r} {unit(r)}".rstrip() for r in rows]
    label = max(len(r) for r in row_names) + 2
    head = " " * label + "".join(f"{c:>{width}}" for c in columns)
    lines = [f"{name} ({len(rows)} x {len(columns)})", head]
    if any(unit(c) for c in columns):
        lines.append((" " * label + "".join(f"{unit(c):>{width}}" for c in columns)).rstrip())
    lines += [f"{r:>{label}}" + "".join(f"{v + 0.0:>{width}.6g}" for v in row)
              for r, row in zip(row_names, matrix)]
    return "\n".join(lines)


def report(lin: Any, units: Mapping[str, str] | None = None) -> str:
    """A, B, C, D as tables and the modes, about the state and inputs they were taken at;
    the rows' and columns' UNITS (the model's unit labels) where known."""
    point = ", ".join(f"{n}={v:.6g}" for n, v in zip(lin.full_state_names, lin.y))
    inputs = ", ".join(f"{n}={v:.6g}" for n, v in zip(lin.input_names, lin.u))
    parts = [f"linearization at t={lin.t:g}: {point}" + (f"; {inputs}" if inputs else "")]
    if units and any(units.get(n) for n in (*lin.state_names, *lin.output_names)):
        parts[0] += ("\nunits: an entry of A or B is its row's unit over its column's, per "
                     "time unit; of C or D, its row's over its column's")
    if lin.dependent:
        parts.append(f"a closed loop: independent coordinates {lin.state_names[0::2]}, "
                     f"following them {lin.dependent}")
    parts.append(matrix_table("A = d(dy/dt)/dy", lin.A, lin.state_names, lin.state_names,
                              units))
    if lin.input_names:
        parts.append(matrix_table("B = d(dy/dt)/du", lin.B, lin.state_names, lin.input_names,
                                  units))
    if lin.output_names:
        parts.append(matrix_table("C = d out/dy", lin.C, lin.output_names, lin.state_names,
                                  units))
        if lin.input_names:
            parts.append(matrix_table("D = d out/du", lin.D, lin.output_names,
                                      lin.input_names, units))
    parts.append("modes (eigenvalues of A):\n" + repr(lin.modes()))
    return "\n\n".join(parts)


def write(lin: Any, path: Path) -> None:
    import numpy as np

    modes = lin.modes()
    data = {"A": lin.A, "B": lin.B, "C": lin.C, "D": lin.D, "t": lin.t, "y": lin.y,
            "u": lin.u, "state_names": list(lin.state_names),
            "input_names": list(lin.input_names), "output_names": list(lin.output_names),
            "eigenvalues_real": modes.eigenvalues.real, "eigenvalues_imag":
            modes.eigenvalues.imag, "frequencies_hz": modes.hertz, "damping": modes.damping}
    suffix = path.suffix.lower()
    if suffix == ".npz":
        np.savez(path, **{k: np.asarray(v) for k, v in data.items()})
    elif suffix == ".mat":
        from scipy.io import savemat

        savemat(path, {k: np.asarray(v, dtype=object if isinstance(v, list) else None)
                       for k, v in data.items()})
    else:
        path.write_text(json.dumps({k: np.asarray(v).tolist() if not isinstance(v, list)
                                    else v for k, v in data.items()}, indent=1) + "\n")
