"""The code's shape, as docs/architecture.md describes it: the package's folders are the
pipeline's stages, and no module imports a later stage's or takes part in an import circle; a
joint, load or constraint kind lives in one module of its registry and nothing else tests a kind
by its name; the C interface is the model's header and nemc_run.h (what every model shares),
whose declarations are the cffi cdef; the printer names arrays only through its layout macros;
the build key covers the modules that make builds and nothing else."""

from __future__ import annotations

import ast
import dataclasses
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy

import nemc
from nemc.build import builder as build
from nemc.derive.equations import derive, with_diagnostics, with_taylor
from nemc.emit.emitted import emit
from nemc.emit.optimize import optimize_equations
from nemc.emit.printing import symbol_table
from nemc.front.validate import validate_text
from nemc.kinds.constraints import CONSTRAINT_KINDS, Constraint, PointPair
from nemc.kinds.joints import JOINT_KINDS, Joint, Revolute, joint_kind
from nemc.kinds.loads import LOAD_KINDS, Load

NEMC = Path(nemc.__file__).resolve().parent
EXAMPLES = NEMC.parent / "examples"
KINDS = NEMC / "kinds"
REGISTRIES = ("joints", "loads", "constraints")
KIND_NAMES = set(JOINT_KINDS) | set(LOAD_KINDS) | set(CONSTRAINT_KINDS)
KIND_CLASSES = {kind.__name__ for kind in (*JOINT_KINDS.values(), *LOAD_KINDS.values(),
                                           *CONSTRAINT_KINDS.values())}
# The stages, lowest first: a module may import its own stage's modules and earlier stages'.
# The vocabulary and the errors are the words every stage shares; the kinds are the vocabulary
# of mechanisms (the front end reads them, the derivation asks them); the runtime knows a
# model only by its built package; the pipeline runs the stages; the tools present and drive.
STAGES = ("vocabulary", "errors", "kinds", "front", "derive", "emit", "build", "runtime",
          "pipeline", "tools", "__init__")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(NEMC.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(path): path for path in sorted(NEMC.rglob("*.py"))}


def imported_modules(name: str) -> set[str]:
    """Every nemc module NAME imports, wherever the import stands (module level, functions,
    TYPE_CHECKING): `from .x import y` counts y when y is a module, else x."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - (node.level - 1)]
                base = ".".join(parts + ([base] if base else []))
            for alias in node.names:
                found.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {module for module in found if module in MODULES and module != name}


def stage(name: str) -> int:
    parts = name.split(".")
    return STAGES.index(parts[1] if len(parts) > 1 else "__init__")


def test_the_folders_are_the_stages() -> None:
    """Every module lives in a stage's folder or is one of the few the stages share."""
    top = {path.stem for path in NEMC.glob("*.py")}
    folders = {path.parent.name for path in NEMC.glob("*/__init__.py")} - {"templates"}
    assert top | folders == set(STAGES)


def test_no_module_imports_a_later_stage() -> None:
    back = sorted(f"{name} -> {target}" for name in MODULES for target in imported_modules(name)
                  if stage(target) > stage(name))
    assert back == []


def import_circles() -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    graph = {name: imported_modules(name) for name in MODULES}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        while work:
            node, targets = work[-1]
            target = next(targets, None)
            if target is not None:
                if target not in index:
                    index[target] = low[target] = len(index)
                    stack.append(target)
                    work.append((target, iter(sorted(graph[target]))))
                elif target in stack:
                    low[node] = min(low[node], index[target])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                circle = set()
                while True:
                    member = stack.pop()
                    circle.add(member)
                    if member == node:
                        break
                if len(circle) > 1:
                    circles.append(circle)
    return circles


def test_no_import_circle() -> None:
    assert import_circles() == []


def test_the_import_checks_can_fail(monkeypatch: pytest.MonkeyPatch) -> None:
    """A back edge and a circle are found: derive importing the runtime, and it derive."""
    real = imported_modules

    def with_a_circle(name: str) -> set[str]:
        extra = {"nemc.derive.equations": {"nemc.runtime.model"},
                 "nemc.runtime.model": {"nemc.derive.equations"}}
        return real(name) | extra.get(name, set())

    monkeypatch.setitem(globals(), "imported_modules", with_a_circle)
    assert any({"nemc.derive.equations", "nemc.runtime.model"} <= c for c in import_circles())
    assert stage("nemc.runtime.model") > stage("nemc.derive.equations")


def modules_outside_registries() -> list[Path]:
    return [path for path in MODULES.values()
            if path.parent.name not in REGISTRIES or path.parent.parent != KINDS]


def names_a_kind(node: ast.AST) -> bool:
    """A string constant that is a kind's name, or a tuple/list/set of them."""
    if isinstance(node, ast.Constant):
        return node.value in KIND_NAMES
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(names_a_kind(item) for item in node.elts)
    return False


def is_kind_attribute(node: ast.AST) -> bool:
    """`x.type`: a joint's kind name (other objects' `.kind`, as a token's, are not kinds)."""
    return isinstance(node, ast.Attribute) and node.attr == "type"


def kind_tests(tree: ast.AST) -> list[int]:
    """Lines that test a joint's or a load's kind: `x.type == "revolute"`, `"free" in ...`,
    `isinstance(load, Torque)`, a dict keyed by kind names, a match on a kind."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            if any(names_a_kind(o) for o in operands) or any(is_kind_attribute(o)
                                                             for o in operands):
                lines.append(node.lineno)
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") == "isinstance":
            if any(name.id in KIND_CLASSES for name in ast.walk(node.args[1])
                   if isinstance(name, ast.Name)):
                lines.append(node.lineno)
        elif isinstance(node, ast.Dict) and any(k is not None and names_a_kind(k)
                                                for k in node.keys):
            lines.append(node.lineno)
        elif isinstance(node, ast.Match) and is_kind_attribute(node.subject):
            lines.append(node.lineno)
    return lines


def test_no_module_outside_the_registries_tests_a_kind_by_its_name() -> None:
    found = {str(path.relative_to(NEMC)): kind_tests(ast.parse(path.read_text()))
             for path in modules_outside_registries()}
    assert {name: lines for name, lines in found.items() if lines} == {}


def test_the_kind_test_finds_kind_tests() -> None:
    """The check above can fail: it finds each form of a kind test."""
    samples = ['joint.type == "revolute"', 'kind in ("free", "weld")',
               "isinstance(load, Torque)", '{"spring": 1}', 'load.kind != "force"',
               "match joint.type:\n    case _: pass"]
    assert all(kind_tests(ast.parse(sample)) for sample in samples)
    assert not kind_tests(ast.parse('name == "forces" or token.kind == "op"'))


@pytest.mark.parametrize("registry, table, base", [("joints", JOINT_KINDS, Joint),
                                                   ("loads", LOAD_KINDS, Load),
                                                   ("constraints", CONSTRAINT_KINDS,
                                                    Constraint)])
def test_every_kind_module_is_in_its_table(registry: str, table: dict, base: type) -> None:
    """One module per kind, each kind in the table under the name the YAML uses."""
    modules = {path.stem for path in (KINDS / registry).glob("*.py")} - {"__init__", "base"}
    owners = {kind.__module__.rsplit(".", 1)[1]: kind for kind in table.values()}
    assert set(owners) == modules
    assert all(issubclass(kind, base) for kind in table.values())


def test_an_unknown_kind_fails_loudly() -> None:
    assert joint_kind("revolute") is Revolute
    with pytest.raises(ValueError, match="unknown joint kind 'helical'"):
        joint_kind("helical")


def test_a_kind_that_answers_nothing_fails_loudly() -> None:
    """A new kind that does not say where it puts its child is an error, not a silent weld."""

    @dataclasses.dataclass(frozen=True)
    class Mute(Joint):
        type = "mute"
        keys = ("at", "coordinate")
        coordinate_key = "coordinate"
        coordinate_kinds = ("angle",)

    mech = validate_text((EXAMPLES / "compound_pendulum.yaml").read_bytes(), "compound.yaml")
    joint = mech.joints[0]
    mute = Mute(joint.name, joint.parent, joint.child, joint.coordinates, joint.loc, joint.at)
    with pytest.raises(NotImplementedError):
        derive(dataclasses.replace(mech, joints=(mute,)))


def equations(name: str):
    mech = validate_text((EXAMPLES / f"{name}.yaml").read_bytes(), f"{name}.yaml")
    eqs = with_taylor(with_diagnostics(derive(mech)))
    return eqs, optimize_equations(eqs)


@pytest.mark.parametrize("name", ["double_pendulum", "free_body_on_spring"])
def test_the_printer_names_arrays_only_through_layout_macros(name: str) -> None:
    eqs, block = equations(name)
    names = symbol_table(eqs, block)
    arrays = {symbol: c for symbol, c in names.items() if not re.fullmatch(r"[a-z]\w*", c)}
    assert arrays and all(re.fullmatch(r"[A-Z_]+\(\d+\)", c) for c in arrays.values())
    code = emit(eqs, block)
    run_header = dict(code.shared_headers)["nemc_run.h"]
    defined = set(re.findall(r"#define (\w+)\(", code.header + run_header))
    used = set(re.findall(r"\b([A-Z_]+)\(\d+\)", code.c_source))
    assert {"Q", "DQ", "P", "QDD"} <= used <= defined | {"TAYLOR_ROW"}
    # the state's layout is spelled in nemc_run.h alone, which the model's header includes
    assert "2 * (i)" in run_header and '#include "nemc_run.h"' in code.header
    assert all("2 * i" not in c for c in (code.c_source, code.header, code.drivers))


def test_the_cdef_is_the_headers_text() -> None:
    """The cdef is nemc_run.h's declarations (what every model shares) and then the model
    header's, word for word."""
    eqs, block = equations("double_pendulum")
    code = emit(eqs, block)
    shared, model = code.cdef.split("/* dy/dt at (t, y)", 1)
    assert shared in dict(code.shared_headers)["nemc_run.h"] and "} nemc_run;" in shared
    assert "/* dy/dt at (t, y)" + model in code.header and "double_pendulum_integrate(" in model
    assert "#define" not in code.cdef  # cffi's part: declarations only
    package_c = code.c_source + code.spectrum + "".join(code.units)  # every C file's text
    for function in re.findall(r"\b(double_pendulum_\w+)\(", code.cdef):
        assert re.search(rf"\n\w+ {function}\(", package_c), function  # each one defined


def test_the_build_key_covers_what_makes_builds() -> None:
    modules = {path.relative_to(NEMC).as_posix() for path in build.build_modules()}
    assert {"derive/equations.py", "emit/emitted.py", "derive/articulated.py",
            "kinds/joints/revolute.py", "kinds/loads/spring.py", "front/validate.py",
            "vocabulary.py", "build/builder.py"} <= modules
    assert not {module for module in modules if module.startswith(("tools/", "runtime/"))}
    assert {t.name for t in build.template_files()} >= {"model.h.tmpl", "model.c.tmpl"}


def test_a_kind_holds_its_expressions_in_one_place() -> None:
    """map_expressions reaches every expression of every kind (the articulated-body algorithm
    folds constants through it)."""
    mech = validate_text((EXAMPLES / "joint_spring_telescope.yaml").read_bytes(), "t.yaml")
    marker = sympy.Symbol("marker")
    for item in (*mech.joints, *mech.loads):
        mapped = item.map_expressions(lambda e: marker)
        for f in dataclasses.fields(mapped):
            value = getattr(mapped, f.name)
            if isinstance(value, sympy.Basic):
                assert value == marker, (item, f.name)


# A constraint kind added the way docs/architecture.md says: its own class and one line in the
# table. A rod of no mass between two points keeps their distance: Phi = |p_a - p_b| - length,
# its multiplier the rod's tension (the force of b on a along b -> a).
DISTANCE_LINKAGE = """\
name: distance_linkage
parameters: {g: 9.81}
gravity: [0, -g]
bodies:
  crank: {mass: 1, inertia: 1/12, com: [0.5, 0], points: {B: [1, 0]}}
  rocker: {mass: 1, inertia: 4/12, com: [1, 0], points: {C: [2, 0]}}
joints:
  A: {type: revolute, parent: ground, child: crank, coordinate: q1}
  D: {type: revolute, parent: ground, child: rocker, at: [2.5, 0], coordinate: q3}
constraints:
  rod: {type: distance, a: crank.B, b: rocker.C, length: 2.5}
outputs:
  reactions: [rod]
  energy: true
simulation:
  t_span: [0, 5]
  initial: {q1: 1.0}
  guess: {q3: 2.0}
"""


def distance_kind() -> type[Constraint]:
    @dataclasses.dataclass(frozen=True)
    class Distance(PointPair):
        type = "distance"
        keys = ("a", "b", "length")
        equations_count = 1
        length: sympy.Expr = sympy.S.One

        @classmethod
        def read_own(cls, read):
            return {"length": read.fixed("length", sympy.S.One)}

        def separation(self, a, b):
            pa, pb = a.point(self.a.xy), b.point(self.b.xy)
            return pa[0] - pb[0], pa[1] - pb[1]

        def between(self, a, b):
            dx, dy = self.separation(a, b)
            return [sympy.sqrt(dx * dx + dy * dy) - self.length]

        def force(self, a, b, multipliers):
            dx, dy = self.separation(a, b)
            norm = sympy.sqrt(dx * dx + dy * dy)
            return (multipliers[0] * dx / norm, multipliers[0] * dy / norm), sympy.S.Zero

    return Distance


def test_a_new_constraint_kind_needs_its_class_and_a_line_in_the_table(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(CONSTRAINT_KINDS, "distance", distance_kind())
    monkeypatch.setenv("NEMC_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "distance_linkage.yaml"
    path.write_text(DISTANCE_LINKAGE)
    model = nemc.compile(path)
    result = model.simulate(method="nemc.Vern9", rtol=1e-10, atol=1e-12,
                            t_eval=np.linspace(0, 5, 51))
    assert result.success, result.message
    crank_tip = np.array([np.cos(result.y[0]), np.sin(result.y[0])])
    rocker_tip = np.array([2.5 + 2 * np.cos(result.y[2]), 2 * np.sin(result.y[2])])
    np.testing.assert_allclose(np.hypot(*(crank_tip - rocker_tip)), 2.5, atol=1e-12)
    energy = result.outputs["energy.total"]  # the rod does no work
    assert np.ptp(energy) < 1e-8 * abs(energy).max()
    tension = np.hypot(result.outputs["rod.Fx"], result.outputs["rod.Fy"])
    assert np.all(np.isfinite(tension)) and tension.max() > 0.1


def test_every_subpackage_is_in_the_wheel() -> None:
    """pyproject.toml lists the packages a wheel holds: a subpackage left out installs
    nowhere but an editable checkout (nemc.kinds.constraints was, and a wheel could not compile)."""
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    root = Path(nemc.__file__).resolve().parent
    listed = set(tomllib.loads((root.parent / "pyproject.toml").read_text())
                 ["tool"]["setuptools"]["packages"])
    found = {"nemc", *(".".join(init.parent.relative_to(root.parent).parts)
                       for init in root.rglob("*/__init__.py"))}
    assert found <= listed, f"not in pyproject.toml's packages: {sorted(found - listed)}"


# A joint kind of two degrees of freedom added the way docs/architecture.md says: a pin that
# slides in a slot of its parent and turns in it (coordinates: the slide s along `axis` and the
# relative angle th). The articulated-body algorithm projects it through its two axes (D is
# 2 x 2); its slide axis moves with the parent and its pin axis with the child, so it says its
# own bias acceleration.
PIN_IN_SLOT = """\
name: pin_in_slot
parameters: {g: 9.81, k: 3.0}
gravity: [0, -g]
bodies:
  slider: {mass: 0.7, inertia: 0.05, com: [0.1, -0.2], points: {P: [0.3, -0.4]}}
  link: {mass: 1.3, inertia: 0.2, com: [0.5, 0.1], points: {E: [1, 0]}}
joints:
  A: {type: pin_in_slot, parent: ground, child: slider, coordinates: [s, th], axis: [2, 1]}
  B: {type: revolute, parent: slider, child: link, at: P, coordinate: q}
loads:
  - spring: {a: link.E, b: {body: ground, at: [0, 1]}, k: k, length: 0.5}
outputs:
  energy: true
simulation:
  t_span: [0, 3]
  initial: {s: 0.2, th: 0.4, q: -0.7, dot(s): 0.3, dot(th): -1.0, dot(q): 0.5}
"""


def pin_in_slot_kind() -> type[Joint]:
    from nemc.kinds.spatial import add, cross_motion, scale, unit

    @dataclasses.dataclass(frozen=True)
    class PinInSlot(Joint):
        type = "pin_in_slot"
        keys = ("at", "coordinates", "axis")
        coordinate_key = "coordinates"
        coordinate_kinds = ("length", "angle")
        axis: tuple = (sympy.S.One, sympy.S.Zero)

        @classmethod
        def read(cls, read):
            return read.fields(at=read.parent_point("at"), axis=read.axis("axis"))

        def slide_point(self, s):
            ux, uy = unit(self.axis)
            return self.at[0] + ux * s, self.at[1] + uy * s

        def place(self, parent, q):
            return parent.angle + q[1], parent.point(self.slide_point(q[0]))

        def origin_velocity(self, parent, q, u):
            along = scale(parent.rotate(unit(self.axis)), u[0])
            return add(parent.velocity(self.slide_point(q[0])), along)

        def motion_subspace(self, parent, child_origin, parent_velocity, u):
            ax, ay = parent.names(parent.rotate(unit(self.axis)))
            px, py = child_origin
            zero, one = sympy.S.Zero, sympy.S.One
            return [(zero, ax, ay), (one, py, -px)], [u[0], u[1]]

        def bias_acceleration(self, velocity, relative, axes, rates):
            """v x (S rates) takes both axes as moving with the child; the slide's moves with
            the parent: less (pin axis th') x (slide axis s')."""
            pin, slide = scale(axes[1], rates[1]), scale(axes[0], rates[0])
            return add(cross_motion(velocity, relative), scale(cross_motion(pin, slide), -1))

    return PinInSlot


def evaluate(program, values: dict) -> np.ndarray:
    """The program's results at these symbol values (step by step, as the C computes them)."""
    known = dict(values)
    for name, expr in program.assignments():
        known[name] = sympy.Float(expr.xreplace(known).evalf(30), 30)
    return np.array([float(result.xreplace(known)) for result in program.results])


def test_a_joint_kind_of_two_degrees_of_freedom_is_projected_generally(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nemc.derive.articulated import dynamics_program
    from nemc.derive.equations import mass_and_forcing, runtime_values
    from nemc.front import mechanism as m

    monkeypatch.setitem(JOINT_KINDS, "pin_in_slot", pin_in_slot_kind())
    mech = validate_text(PIN_IN_SLOT.encode(), "pin_in_slot.yaml")
    articulated = dynamics_program(mech, runtime_values(mech))
    mass, forcing = mass_and_forcing(mech)  # Newton-Euler from the placement alone
    rng = np.random.default_rng(7)
    for _ in range(5):
        values = {m.symbol("g"): 9.81, m.symbol("k"): 3.0}
        values.update({symbol: rng.uniform(-1.5, 1.5) for name in mech.coordinates
                       for symbol in (m.symbol(name), m.rate_symbol(name))})
        expected = np.linalg.solve(np.array(mass.xreplace(values), dtype=float),
                                   np.array(forcing.xreplace(values), dtype=float).ravel())
        np.testing.assert_allclose(evaluate(articulated, values), expected, rtol=1e-12,
                                   atol=1e-12)
    monkeypatch.setenv("NEMC_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "pin_in_slot.yaml"
    path.write_text(PIN_IN_SLOT)
    result = nemc.compile(path).simulate(method="nemc.Vern9", rtol=1e-11, atol=1e-12)
    assert result.success, result.message
    energy = result.outputs["energy.total"]  # conservative: gravity and a spring
    assert np.ptp(energy) < 1e-8 * abs(energy).max()


# A constraint kind whose Jacobian has a bare parameter (a gear pair: ratio * angle(a) =
# angle(b), its derivative by angle(a) is `ratio` itself); it says how its multiplier acts on
# the two bodies (couples ratio * lambda and -lambda), which is not a reaction at a point.
GEARS = """\
name: gears
parameters: {ratio: 2.0, tau: 1.0}
bodies:
  pinion: {mass: 1, inertia: 0.5}
  wheel: {mass: 2, inertia: 1.5}
joints:
  A: {type: revolute, parent: ground, child: pinion, coordinate: q1}
  B: {type: revolute, parent: ground, child: wheel, at: [3, 0], coordinate: q2}
constraints:
  mesh: {type: angle_ratio, a: pinion.origin, b: wheel.origin, ratio: ratio}
loads:
  - {torque: tau, body: pinion}
simulation:
  t_span: [0, 2]
  initial: {q1: 0.4}
  guess: {q2: 0.8}
"""


def angle_ratio_kind() -> type[Constraint]:
    @dataclasses.dataclass(frozen=True)
    class AngleRatio(PointPair):
        type = "angle_ratio"
        keys = ("a", "b", "ratio")
        equations_count = 1
        ratio: sympy.Expr = sympy.S.One

        @classmethod
        def read_own(cls, read):
            return {"ratio": read.fixed("ratio", sympy.S.One)}

        def between(self, a, b):
            return [self.ratio * a.angle - b.angle]

        def act(self, view, sink, multipliers):
            sink.couple(self.a.body, self.ratio * multipliers[0])
            sink.couple(self.b.body, -multipliers[0])

    return AngleRatio


def test_a_constraint_with_a_bare_parameter_in_its_jacobian_assembles_and_runs(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """check_assembly once crashed on it ('float' object has no attribute 'xreplace'); the
    pinion's acceleration is tau / (I1 + ratio^2 I2) in closed form."""
    from nemc.derive.assembly import check_assembly

    monkeypatch.setitem(CONSTRAINT_KINDS, "angle_ratio", angle_ratio_kind())
    assembly = check_assembly(validate_text(GEARS.encode(), "gears.yaml"))
    assert assembly.freedom == 1 and assembly.coordinates["q2"] == pytest.approx(0.8)
    monkeypatch.setenv("NEMC_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "gears.yaml"
    path.write_text(GEARS)
    times = np.linspace(0, 2, 9)
    result = nemc.compile(path).simulate(method="nemc.Vern9", rtol=1e-11, atol=1e-12,
                                         t_eval=times)
    assert result.success, result.message
    q1 = 0.4 + 0.5 * 1.0 / (0.5 + 2.0**2 * 1.5) * times**2
    np.testing.assert_allclose(result.y[0], q1, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(result.y[2], 2.0 * result.y[0], rtol=1e-9, atol=1e-10)


def own_fields(kind: type, base: type) -> set[str]:
    """The fields a kind declares beyond its registry's base class (and its location)."""
    return ({f.name for f in dataclasses.fields(kind)}
            - {f.name for f in dataclasses.fields(base)} - {"loc"})


def spy_on_kind_fields(monkeypatch: pytest.MonkeyPatch) -> set[tuple[str, str, str]]:
    """Record (kind, field, file) of every read of a kind's own field from a module of nemc
    other than the kind's own (or a kind's it extends: a prismatic constraint is a slot) and
    nemc/kinds/terms.py's generic expression mapping."""
    readers: set[tuple[str, str, str]] = set()
    terms = str(KINDS / "terms.py")
    for table, base in ((JOINT_KINDS, Joint), (LOAD_KINDS, Load), (CONSTRAINT_KINDS, Constraint)):
        for kind in table.values():
            watched = own_fields(kind, base)
            homes = {str(Path(sys.modules[cls.__module__].__file__).resolve())
                     for cls in kind.__mro__ if issubclass(cls, base)} | {terms}

            def spying(self, name, kind=kind, watched=watched, homes=homes):
                if name in watched:
                    caller = str(Path(sys._getframe(1).f_code.co_filename).resolve())
                    if caller.startswith(str(NEMC)) and caller not in homes:
                        readers.add((kind.__name__, name, caller))
                return object.__getattribute__(self, name)

            monkeypatch.setattr(kind, "__getattribute__", spying)
    return readers


def test_a_kinds_own_fields_are_read_in_its_module_alone(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    """Every stage asks a kind (its methods) rather than reading what it holds: through the
    whole pipeline of every example (validate, assemble, derive with every part, emit, show),
    a kind's own fields are read only in its module (and by the generic expression mapping of
    nemc/kinds/terms.py, and Python's dataclass machinery)."""
    from nemc.derive.assembly import check_assembly
    from nemc.derive.equations import with_jacobian, with_mass_matrix
    from nemc.tools.show import show

    readers = spy_on_kind_fields(monkeypatch)
    for path in sorted(EXAMPLES.glob("*.yaml")):
        mech = validate_text(path.read_bytes(), path.name)
        check_assembly(mech)
        eqs = with_mass_matrix(with_taylor(with_jacobian(with_diagnostics(derive(mech)))))
        emit(eqs, optimize_equations(eqs), lanes=4)
        show(mech)
    assert sorted(readers) == []


def test_the_field_check_finds_a_reader(monkeypatch: pytest.MonkeyPatch) -> None:
    """The check above can fail: a stage's line reading a spring's stiffness is caught (code
    compiled as if it stood in nemc/derive/outputs.py), the spring's own module is not."""
    mech = validate_text((EXAMPLES / "damped_spring_pendulum.yaml").read_bytes(), "d.yaml")
    spring = mech.loads[0]
    readers = spy_on_kind_fields(monkeypatch)
    outputs = str(NEMC / "derive" / "outputs.py")
    eval(compile("spring.k", outputs, "eval"), {"spring": spring})  # noqa: S307
    spring.potential  # the kind's own method object: no field read  # noqa: B018
    assert readers == {("Spring", "k", outputs)}
