"""Fuzzing the loader: random YAML documents, random expressions and mutations of the valid
example files. The only outcomes allowed are a valid Mechanism or an InputError whose every
problem is located (the file, a line inside it, a message). Validation only, but for the last
two tests (slow): what validation accepts is compiled and run, mutated examples (each a
compile) and values varied on each example's own build (one compile each, seeded)."""

from __future__ import annotations

import copy
import os
import random
import re
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from nemc.errors import InputError
from nemc.front.mechanism import Mechanism
from nemc.front.reader import JOINT_KEYS, JOINT_TYPES, LOAD_KEYS
from nemc.front.validate import TOP_KEYS, validate_text

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = {p.stem: p.read_text() for p in sorted((ROOT / "examples").glob("*.yaml"))}
FILE = "fuzz.yaml"

FUZZ = settings(derandomize=True, deadline=None, max_examples=150, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])

# the words a mechanism file is made of, so random documents get past the first checks
WORDS = sorted({*TOP_KEYS, *JOINT_TYPES, *(k for keys in JOINT_KEYS.values() for k in keys),
                *(k for keys in LOAD_KEYS.values() for k in keys), "mass", "inertia", "com",
                "points", "ground", "origin", "b1", "b2", "A", "B", "q1", "q2", "m", "L", "P",
                "t", "pi", "RK45", "Radau", "reactions", "energy", "expressions", "t_span",
                "initial", "t_eval", "step", "method", "rtol", "atol", "a", "b", "k", "length",
                "damping", "rest", "frame", "body", "reaction"})
EXPRESSION_ALPHABET = "mLq12.e+-*/()^ ,_tpisncoxdabqr'\"[]{}:;#\\\t\x00é"


def expressions() -> st.SearchStrategy[str]:
    tokens = st.sampled_from(["m", "L", "q1", "t", "pi", "dot(q1)", "sin(", "max(", "sqrt(",
                              "(", ")", "+", "-", "*", "/", "**", "^", ",", "1", "0", "2.5e3",
                              "1e999", "1e-999", "10**10**10", ".", "__import__", "'x'", " "])
    return st.one_of(st.lists(tokens, max_size=12).map("".join),
                     st.text(EXPRESSION_ALPHABET, max_size=20))


def scalars() -> st.SearchStrategy[object]:
    return st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30),
                     st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(WORDS),
                     expressions(), st.text(max_size=8))


def documents() -> st.SearchStrategy[object]:
    keys = st.one_of(st.sampled_from(WORDS), st.text(max_size=6))
    return st.recursive(scalars(), lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(keys, inner, max_size=5)), max_leaves=30)


def assert_clean(text: str | bytes) -> Mechanism | None:
    """Validate; the outcome must be a Mechanism or a located InputError."""
    size = text.count(b"\n" if isinstance(text, bytes) else "\n") + 1
    try:
        return validate_text(text, FILE)
    except InputError as error:
        assert error.problems
        for problem in error.problems:
            assert problem.file == FILE and 1 <= problem.line <= size, problem
            assert problem.message and "Node(" not in problem.message, problem
            assert str(problem).startswith(f"{FILE}:{problem.line}: ")
        return None


@FUZZ
@given(documents())
def test_random_documents(document: object) -> None:
    assert_clean(yaml.safe_dump(document, allow_unicode=True))


@FUZZ
@given(st.dictionaries(st.sampled_from(["mass", "inertia", "com", "points", "mas"]),
                       st.one_of(scalars(), st.lists(scalars(), max_size=3)), max_size=4),
       st.sampled_from(["b1", "ground", "dot", "int", "x0", "1b"]))
def test_random_bodies_on_a_valid_frame(body: dict, name: str) -> None:
    """Random body fields where everything else is right, so validation goes deep."""
    document = {"name": "fuzz", "parameters": {"m": 1, "L": 2},
                "bodies": {name: body, "b2": {"mass": 1, "inertia": 1}},
                "joints": {"A": {"type": "revolute", "parent": "ground", "child": name,
                                 "coordinate": "q1"},
                           "B": {"type": "revolute", "parent": name, "child": "b2",
                                 "coordinate": "q2"}},
                "loads": [{"torque": "m*dot(q1)", "body": "b2"}]}
    assert_clean(yaml.safe_dump(document))


@FUZZ
@given(expressions(), st.sampled_from(["bodies.b1.mass", "loads.torque", "parameters.k",
                                       "simulation.t_span", "gravity"]))
def test_random_expressions_in_every_kind_of_field(expression: str, field: str) -> None:
    quoted = yaml.safe_dump(expression, default_style="'").strip()
    text = EXAMPLES["double_pendulum"]
    replacements = {
        "bodies.b1.mass": ("mass: m1", f"mass: {quoted}"),
        "loads.torque": ("outputs:", f"loads:\n  - torque: {quoted}\n    body: link1\noutputs:"),
        "parameters.k": ("parameters:\n", f"parameters:\n  k: {quoted}\n"),
        "simulation.t_span": ("t_span: [0, 5]", f"t_span: [0, {quoted}]"),
        "gravity": ("gravity: [0, -g]", f"gravity: [{quoted}, -g]"),
    }
    old, new = replacements[field]
    assert old in text, old
    assert_clean(text.replace(old, new, 1))


@st.composite
def mutated_examples(draw: st.DrawFn) -> str:
    """A valid example with a few lines deleted, duplicated, swapped, cut or scribbled on."""
    lines = EXAMPLES[draw(st.sampled_from(sorted(EXAMPLES)))].splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        kind = draw(st.sampled_from(["delete", "duplicate", "swap", "cut", "insert", "word"]))
        if kind == "delete" and len(lines) > 1:
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "cut":
            at = draw(st.integers(0, len(lines[i])))
            lines[i] = lines[i][:at] + "\n"
        elif kind == "insert":
            at = draw(st.integers(0, len(lines[i])))
            junk = draw(st.text("[]{}:,-&*!|>'\"#%@` \t\n0.eN" + "abq", max_size=4))
            lines[i] = lines[i][:at] + junk + lines[i][at:]
        else:  # replace one word by another mechanism word
            words = re.findall(r"[A-Za-z_]\w*", lines[i])
            if words:
                lines[i] = lines[i].replace(draw(st.sampled_from(words)),
                                            draw(st.sampled_from(WORDS)), 1)
    return "".join(lines)


@FUZZ
@given(mutated_examples())
def test_mutated_examples(text: str) -> None:
    assert_clean(text)


@FUZZ
@given(st.sampled_from(sorted(EXAMPLES)), st.integers(0, 10**6), st.binary(max_size=3))
def test_byte_level_damage(example: str, position: int, junk: bytes) -> None:
    data = EXAMPLES[example].encode()
    at = position % (len(data) + 1)
    assert_clean(data[:at] + junk + data[at + len(junk) // 2:])


def test_every_example_is_valid() -> None:
    """The mutations start from valid files (else the fuzz would only test refusals)."""
    for name, text in EXAMPLES.items():
        assert isinstance(assert_clean(text), Mechanism), name


# ---- compiled and run (issue 51): what check accepts never ends in a traceback ---------------

# each accepted mutant is a compile (2 to 5 s): the value fuzz below varies values on shared
# builds for the bulk of the files run
RUN_FUZZ = settings(FUZZ, max_examples=int(os.environ.get("NEMC_FUZZ_RUNS", "60")))


@pytest.mark.slow
@RUN_FUZZ
@given(mutated_examples())
def test_what_check_accepts_compiles_and_runs(text: str) -> None:
    """A mutated example that `check` accepts is compiled and run briefly (its first 1% of
    t_span, at most 20,000 steps) by its scene's method: the outcome is a result (successful
    or not, with a message) or nemc's own ModelError, never another exception."""
    import nemc
    from nemc.runtime.model import ModelError

    mechanism = assert_clean(text)
    assume(mechanism is not None)
    with tempfile.TemporaryDirectory() as folder:
        file = Path(folder) / FILE
        file.write_text(text)
        try:
            model = nemc.compile(file)
        except InputError:  # refused by a later stage: located, as check's
            event("refused at compile")
            return
        t0, t1 = model.scene["t_span"] or (0.0, 10.0)
        try:
            run = model.simulate((t0, t0 + (t1 - t0) / 100), max_steps=20_000)
        except ModelError as error:
            event("run refused")
            assert str(error)
            return
    event("ran" if run.success else "failed with a message")
    assert run.success or run.message


# ---- values fuzzed on each example's own build (issue 51): a few hundred accepted files -------

VALUES_PER_EXAMPLE = int(os.environ.get("NEMC_FUZZ_VALUES", "10"))
HOSTILE_NUMBERS = (0.0, -1.0, 1e-12, 1e-6, 0.5, 3.0, 1e3, 1e6, 1e12, -1e6, 1e150, -1e-300)
FUZZ_METHODS = ("auto", "nemc.DOP853", "nemc.Vern9", "nemc.Radau", "nemc.Taylor", "RK45",
                "LSODA", "BDF")
# the format's version-3 items, each in the examples the value fuzz must have run (a friction
# list, a coupling, a rolling disc, a knife edge, a particle (inertia 0), an input)
V3_EXAMPLES = {"friction": "coulomb_block", "coupling": "gear_train", "rolling": "planetary",
               "knife edge": "chaplygin_sleigh", "particle": "wheel_on_platform",
               "inputs": "cart_pole"}


class Yaml12Loader(yaml.SafeLoader):
    """PyYAML's safe loader with YAML 1.2's booleans (true, false), as nemc reads: `on:` (a
    rolling disc's) stays a key, not True."""


Yaml12Loader.yaml_implicit_resolvers = {
    first: [(tag, pattern) for tag, pattern in resolvers if tag != "tag:yaml.org,2002:bool"]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
Yaml12Loader.add_implicit_resolver("tag:yaml.org,2002:bool", re.compile(r"^(?:true|false)$"),
                                   list("tf"))


def numbers_in(section: object) -> list[str]:
    """The keys of SECTION (a mapping) whose values are plain numbers: what a variant sets."""
    if not isinstance(section, dict):
        return []
    return [key for key, value in section.items()
            if isinstance(value, (int, float)) and not isinstance(value, bool)]


def value_variant(document: dict, rng: random.Random) -> tuple[dict, dict]:
    """A copy of an example's DOCUMENT with one to three of its values changed (a parameter, an
    initial value, an input, the method, rtol) to hostile numbers, and simulate's arguments
    that make the same changes on the example's own build."""
    variant = copy.deepcopy(document)
    scene = variant.setdefault("simulation", {}) or {}
    variant["simulation"] = scene
    change: dict = {"params": {}, "initial": {}, "inputs": {}}
    places = [("params", variant.get("parameters"), key)
              for key in numbers_in(variant.get("parameters"))]
    places += [("initial", scene.get("initial"), key) for key in numbers_in(scene.get("initial"))]
    places += [("inputs", variant.get("inputs"), key) for key in numbers_in(variant.get("inputs"))]
    for _ in range(rng.randint(1, 3)):
        kind = rng.choice(["value", "value", "method", "rtol"] if places else ["method", "rtol"])
        if kind == "method":
            scene["method"] = change["method"] = rng.choice(FUZZ_METHODS)
        elif kind == "rtol":
            scene["rtol"] = change["rtol"] = rng.choice([1e-3, 1e-8, 1e-13, 0.5, 1e-300])
        else:
            where, section, key = rng.choice(places)
            value = rng.choice(HOSTILE_NUMBERS) * (1 if rng.random() < 0.7 else section[key])
            section[key] = change[where][key] = value
    return variant, change


def run_variant(model, change: dict) -> str:
    """The example's MODEL run as the variant says (its first 1% of t_span, at most 20,000
    steps): 'ran', 'failed' (a result with a message) or 'refused' (nemc's ModelError)."""
    from nemc.runtime.model import ModelError
    from nemc.tools.start import start_values

    t0, t1 = model.scene["t_span"] or (0.0, 10.0)
    try:
        y0 = start_values(model, change["params"], list(change["initial"].items()),
                          "--initial") if change["initial"] else None
        run = model.simulate((t0, t0 + (t1 - t0) / 100), y0=y0, params=change["params"] or None,
                             inputs=change["inputs"] or None, method=change.get("method"),
                             rtol=change.get("rtol"), max_steps=20_000)
    except ModelError as error:
        assert str(error) and "\n" not in str(error).strip(), error
        return f"refused: {error}"
    assert run.success or run.message, run
    return "ran" if run.success else "failed"


def assert_check_refuses(mechanism: Mechanism, refusal: str) -> None:
    """What a run refuses of a file's values (the start a closed loop cannot take), `nemc
    check` refuses at its line (a method the mechanism cannot run is the run's to refuse,
    naming the item that forbids it)."""
    from nemc.derive.assembly import check_assembly

    if " cannot run a mechanism " in refusal or " is not available for " in refusal:
        return
    with pytest.raises(InputError) as refused:
        check_assembly(mechanism)
    assert all(problem.file == FILE and problem.line >= 1 for problem in refused.value.problems)


@pytest.mark.slow
def test_values_check_accepts_run_on_the_examples_own_builds(tmp_path: Path) -> None:
    """Each example compiled once; VALUES_PER_EXAMPLE seeded variants of it (a parameter, an
    initial value, an input, the method or rtol set to 0, -1, 1e-12, 1e12, 1e150, ...) that
    validation accepts are run on that build with the same values (simulate's params, y0 as
    --initial makes it, inputs, method, rtol): the outcome is a result or nemc's one-line
    ModelError, never another exception, and a start the run refuses `check` refuses too
    (its assembly, at a line). Every example's variants run, the format's version-3
    items among them, a few hundred accepted files in all (NEMC_FUZZ_VALUES sets the count)."""
    import nemc

    outcomes: dict[str, list[str]] = {}
    for name in sorted(EXAMPLES):
        rng = random.Random(f"51 {name}")  # each example's own: an added one changes no other's
        document = yaml.load(EXAMPLES[name], Loader=Yaml12Loader)
        model = nemc.compile(ROOT / "examples" / f"{name}.yaml")
        for _ in range(VALUES_PER_EXAMPLE):
            variant, change = value_variant(document, rng)
            mechanism = assert_clean(yaml.safe_dump(variant, sort_keys=False))
            if isinstance(mechanism, Mechanism):
                outcome = run_variant(model, change)
                if outcome.startswith("refused: "):
                    assert_check_refuses(mechanism, outcome)
                    outcome = "refused"
                outcomes.setdefault(name, []).append(outcome)
    accepted = sum(map(len, outcomes.values()))
    print(f"\nvalue fuzz: {accepted} accepted variants of {len(outcomes)} examples run: "
          f"{sum(o.count('ran') for o in outcomes.values())} ran, "
          f"{sum(o.count('failed') for o in outcomes.values())} failed with a message, "
          f"{sum(x == 'refused' for o in outcomes.values() for x in o)} refused by the run "
          "as by check")
    missing = {item: name for item, name in V3_EXAMPLES.items() if name not in outcomes}
    assert not missing, missing
    assert accepted >= len(EXAMPLES) * VALUES_PER_EXAMPLE // 2, outcomes
