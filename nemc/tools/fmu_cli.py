"""`nemc export MECH.yaml --fmu OUT.fmu [--fmi 2|3] [--kind me|cs]`: the mechanism as an FMU
(Model.export_fmu; docs/fmu.md): model exchange or co-simulation, FMI 2.0 or 3.0, from the same
generated C compiled without Python."""

from __future__ import annotations

import argparse
import sys
import time


def add_export_parser(commands: argparse._SubParsersAction) -> None:
    export = commands.add_parser(
        "export", help="an FMU (FMI 2.0 or 3.0, model exchange or co-simulation) from the C")
    export.add_argument("mechanism")
    export.add_argument("--fmu", required=True, metavar="OUT.fmu",
                        help="the FMU file to write (replaced only if nemc wrote it)")
    export.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                        help="the FMI version (default 2)")
    export.add_argument("--kind", choices=("me", "cs"), default="me",
                        help="model exchange (the importer integrates; default) or "
                        "co-simulation (nemc's own integrator inside)")


def cmd_export(args: argparse.Namespace) -> int:
    from ..pipeline import compile_mechanism
    from ..runtime.failures import ModelError

    if not args.fmu.endswith(".fmu"):
        print(f"{args.mechanism}: --fmu: name a .fmu file, got {args.fmu}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    model = compile_mechanism(args.mechanism).model
    try:
        path = model.export_fmu(args.fmu, fmi=args.fmi, kind=args.kind)
    except ModelError as error:
        print(f"{args.mechanism}: {error}", file=sys.stderr)
        return 2
    kind = "model exchange" if args.kind == "me" else "co-simulation"
    print(f"{path}: FMI {args.fmi}.0 {kind} FMU of {model.name} "
          f"({time.perf_counter() - start:.1f} s)")
    return 0
