"""Hostile input: every file under tests/hostile/ is refused through the command line with
exit status 2 and ``FILE:LINE: key.path: message`` (nothing written to the output folder or
the cache, nothing run), except valid_*.yaml, which must work."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from children import HANG

import nemc
from nemc.tools.cli import main

ROOT = Path(__file__).resolve().parent.parent
HOSTILE = ROOT / "tests" / "hostile"
VALID_C_NAMES = HOSTILE / "valid_c_names.yaml"

# file stem -> (line, key path, part of the message): a line of stderr must read
# "FILE:LINE: KEY: ...MESSAGE..." (or "FILE:LINE: ...MESSAGE..." for an empty key path).
EXPECTED: dict[str, tuple[int, str, str]] = {
    # code in expressions: refused by the grammar, never evaluated
    "code_import_os": (5, "bodies.b1.mass", "strings are not allowed in expressions"),
    "code_import_name": (5, "bodies.b1.mass", "unknown name '__import__'"),
    "code_import_call": (5, "bodies.b1.mass", "unknown function '__import__'"),
    "code_attribute": (5, "bodies.b1.mass", "attribute access is not part of the expression"),
    "code_lambda": (5, "bodies.b1.mass", "unexpected character ':'"),
    "code_eval": (5, "bodies.b1.mass", "unknown function 'eval'"),
    "code_exec": (5, "bodies.b1.inertia", "unknown function 'exec' (did you mean 'exp'?)"),
    "code_dunder_name": (5, "bodies.b1.mass", "unknown name '__builtins__'"),
    "code_string": (5, "bodies.b1.mass", "strings are not allowed in expressions"),
    "code_subscript": (5, "bodies.b1.mass", "unexpected '[': use parentheses"),
    "code_c_statement": (5, "bodies.b1.mass", "unexpected character ';'"),
    "code_c_comment": (5, "bodies.b1.mass", "expected a number, a name or '(', got '*'"),
    "code_unicode_name": (5, "bodies.b1.mass", "unexpected character 'μ'"),
    "code_in_load": (11, "loads[0].torque", "unknown function 'open'"),
    "caret": (5, "bodies.b1.mass", "'^' is not an operator here; write '**' for a power"),
    "yaml_python_tag": (2, "name", "expected an identifier naming the generated module, "
                                   "got a list of 1"),  # tags are never constructed
    # undefined symbols
    "undefined_name": (5, "bodies.b1.mass", "unknown name 'mm' (did you mean 'm'?)"),
    "undefined_function": (5, "bodies.b1.inertia", "unknown function 'sni' (did you mean 'sin'?)"),
    "undefined_in_gravity": (10, "gravity[1]", "unknown name 'g'"),
    "coordinate_in_body": (5, "bodies.b1.mass", "'q1' is a coordinate, not allowed in body"),
    # names colliding with functions, t, pi, ground, dot and each other
    "name_function_parameter": (3, "parameters.exp", "'exp' is reserved"),
    "name_sin_parameter": (3, "parameters.sin", "'sin' is reserved"),
    "name_function_coordinate": (9, "joints.B.coordinate", "'cos' is reserved"),
    "name_t_parameter": (3, "parameters.t", "'t' is reserved"),
    "name_t_coordinate": (8, "joints.A.coordinate", "'t' is reserved"),
    "name_pi_constant": (10, "constants.pi", "'pi' is reserved"),
    "name_ground_body": (6, "bodies.ground", "'ground' is reserved"),
    "name_dot_joint": (9, "joints.dot", "'dot' is reserved"),
    "name_body_is_parameter": (5, "bodies.b1", "'b1' is already used by the parameter"),
    "name_coordinate_is_joint": (9, "joints.B.coordinate", "'A' is already used by the joint"),
    "name_coordinate_twice": (9, "joints.B.coordinate", "'q1' is already used by the coordinate"),
    "name_output_is_parameter": (10, "outputs.expressions.L", "'L' is already used by the "
                                                              "parameter"),
    # the model name names a Python module and prefixes C functions
    "model_name_class": (2, "name", "not a Python keyword (it names a module), got 'class'"),
    "model_name_import": (2, "name", "not a Python keyword (it names a module), got 'import'"),
    "model_name_path": (2, "name", "expected an identifier [A-Za-z_][A-Za-z0-9_]*"),
    "model_name_absolute_path": (2, "name", "got '/etc/passwd'"),
    "model_name_space": (2, "name", "got 'my model'"),
    "model_name_json": (2, "name", "'json' is the name of a Python module"),
    "model_name_numpy": (2, "name", "'numpy' is the name of a Python module"),
    "model_name_number": (2, "name", "got number 12"),
    # unknown and misspelled keys and words: the closest valid word is offered
    "unknown_top_key": (4, "bodys", "unknown key 'bodys' (did you mean 'bodies'?)"),
    "unknown_body_key": (6, "bodies.b2.mas", "unknown key 'mas' (did you mean 'mass'?)"),
    "unknown_joint_key": (8, "joints.A.chidl", "unknown key 'chidl' (did you mean 'child'?)"),
    "unknown_load_key": (12, "loads[0].bdy", "unknown key 'bdy' (did you mean 'body'?)"),
    "unknown_simulation_key": (10, "simulation.methd", "unknown key 'methd' (did you mean "
                                                       "'method'?)"),
    "misspelled_joint_type": (8, "joints.A.type", "unknown joint type 'revolut' (did you mean "
                                                  "'revolute'?)"),
    "misspelled_parent": (9, "joints.B.parent", "unknown body 'b11' (did you mean 'b1'?)"),
    "misspelled_point": (9, "joints.B.at", "body 'b1' has no point 'p' (did you mean 'P'?)"),
    "misspelled_method": (10, "simulation.method", "unknown method 'rk45' (did you mean "
                                                   "'RK45'?)"),
    # wrong types
    "type_mass_list": (5, "bodies.b1.mass", "expected a number or an expression, got a list"),
    "type_mass_bool": (5, "bodies.b1.mass", "got boolean true"),
    "type_bodies_list": (5, "bodies", "expected a mapping body name -> body"),
    "type_joint_string": (9, "joints.B", "expected a joint mapping, got 'revolute'"),
    "type_coordinate_list": (8, "joints.A.coordinate", "must be an identifier"),
    "type_energy_yes": (10, "outputs.energy", "expected true or false, got 'yes'"),
    "type_document_list": (2, "", "expected a mapping of top-level keys"),
    "type_document_scalar": (2, "", "expected a mapping of top-level keys"),
    # vector lengths
    "vector_com_3": (6, "bodies.b2.com", "expected a vector [x, y] of 2 entries, got a list of 3"),
    "vector_gravity_1": (10, "gravity", "2 entries, got a list of 1"),
    "vector_at_1": (8, "joints.A.at", "2 entries, got a list of 1"),
    "vector_force_3": (11, "loads[0].force", "2 entries, got a list of 3"),
    "vector_free_2": (8, "joints.A.coordinates", "a list of 3 coordinate names"),
    # joint graphs
    "graph_cycle": (8, "joints.A.parent", "form a cycle (child -> parent: b1 -> b2 -> b1)"),
    "graph_self_parent": (9, "joints.B.parent", "form a cycle"),
    "graph_two_parents": (9, "joints.B.child", "body 'b1' is already the child of joint 'A'"),
    "graph_unknown_parent": (9, "joints.B.parent", "unknown body 'b3'"),
    "graph_unknown_point": (9, "joints.B.at", "body 'b1' has no point 'Q'"),
    "graph_free_not_on_ground": (9, "joints.B.parent", "a free joint's parent must be ground"),
    "graph_ground_child": (9, "joints.B.child", "ground is not allowed here"),
    # closed loops (constraints) and driven joints (motion), format version 2
    "loop_unknown_point": (13, "constraints.C.a", "body 'rocker' has no point 'Q'"),
    "loop_unknown_body": (13, "constraints.C.a", "unknown body 'rockr' (did you mean 'rocker'?)"),
    "loop_same_body": (13, "constraints.C.b", "a and b are both on 'rocker'"),
    "loop_overconstrained": (13, "constraints", "the constraints add 4 equations but the joints "
                                                "leave only 3 free coordinates"),
    "loop_misspelled_type": (13, "constraints.C.type", "unknown constraint type 'revolut' (did "
                                                       "you mean 'revolute'?)"),
    "loop_slot_zero_axis": (13, "constraints.C.axis", "axis must not be [0, 0]"),
    "loop_missing_b": (13, "constraints.C.b", "missing required key 'b'"),
    "motion_on_free": (7, "joints.F.motion", "key 'motion' does not apply to a free joint"),
    "motion_on_weld": (9, "joints.W.motion", "key 'motion' does not apply to a weld joint"),
    "motion_absolute_moving_parent": (9, "joints.B.motion", "a driven revolute joint with angle: "
                                                            "absolute needs the ground as its "
                                                            "parent"),
    "motion_uses_coordinate": (9, "joints.A.motion", "'q2' is a coordinate, not allowed in a "
                                                     "joint's motion"),
    "driven_in_initial": (15, "simulation.initial.q1", "q1 is driven (joints.A.motion): its "
                                                       "value is prescribed"),
    "guess_driven": (15, "simulation.guess.q1", "q1 is driven (joints.A.motion)"),
    "guess_unknown": (15, "simulation.guess.q4", "unknown coordinate 'q4' (did you mean 'q3'?)"),
    "guess_rate": (15, "simulation.guess.dot(q2)", "unknown coordinate 'dot(q2)'"),
    "drives_undriven": (15, "outputs.drives[0]", "joint 'A' is not driven (it has no motion:)"),
    # masses, inertias and parameters at load time
    "mass_zero": (6, "bodies.b2", "joint 'B' would move nothing"),
    "mass_negative": (5, "bodies.b1.mass", "must be >= 0, got -1.5"),
    "mass_nan": (5, "bodies.b1.mass", "expected a finite number, got nan"),
    "mass_inf": (5, "bodies.b1.mass", "expected a finite number, got inf"),
    "mass_overflow": (5, "bodies.b1.mass", "expected a finite number, got inf"),
    "mass_overflow_expression": (5, "bodies.b1.mass", "out of range"),
    "mass_divide_by_zero": (5, "bodies.b1.mass", "expression is not finite"),
    "mass_complex": (5, "bodies.b1.mass", "does not evaluate to a finite real number"),
    "mass_zero_from_parameter": (6, "bodies.b2", "(0 at the default parameter values)"),
    "inertia_zero": (5, "bodies.b1", "have no inertia"),
    "inertia_negative": (5, "bodies.b1.inertia", "must be >= 0, got -2"),
    "parameter_nan": (3, "parameters.L", "expected a finite number, got nan"),
    "parameter_inf": (3, "parameters.L", "expected a finite number, got -inf"),
    "parameter_cycle": (3, "parameters.m", "definitions form a cycle: m -> L -> m"),
    "parameter_huge_integer": (3, "parameters.k", "integer literal has more than 1000 digits"),
    "parameter_huge_power": (3, "parameters.k", "power is too large to compute exactly"),
    "parameter_minmax_flood": (3, "parameters.k", "min() and max() take at most 16 arguments"),
    # the file itself
    "empty": (1, "", "file is empty"),
    "whitespace_only": (1, "", "file is empty"),
    "comment_only": (1, "", "file is empty"),
    "null_document": (2, "", "expected a mapping of top-level keys"),
    "non_utf8": (9, "", "file is not valid UTF-8 (byte 0xe9 at offset 270)"),
    "utf16": (1, "", "file is not valid UTF-8"),
    "nul_byte": (1, "", "invalid character in YAML"),
    "control_character": (10, "", "invalid character in YAML"),
    "tab_indent": (6, "", "tabs are not allowed in YAML indentation; use spaces"),
    "unclosed_bracket": (5, "", "YAML syntax error: while parsing a flow sequence"),
    "unclosed_quote": (10, "", "YAML syntax error: while scanning a quoted scalar"),
    "two_documents": (10, "", "expected a single document"),
    "duplicate_key": (6, "bodies.b2.mass", "duplicate key (first at line 6)"),
    "complex_key": (2, "", "a mapping key must be a plain word"),
    "recursive_alias": (10, "", "recursive alias"),
    "alias_bomb": (3, "", "document expands to more than 100000 nodes"),
    "deep_parentheses": (5, "bodies.b1.mass", "expression is nested too deeply"),
    "deep_yaml": (3, "", "YAML is nested more than 64 levels deep"),
    # round 2 (issue 21): names that clash with the package's own files, or are too long
    "model_name_native": (2, "name", "'_native' is the name of a module or file inside every"),
    "model_name_rhs_call": (2, "name", "'_rhs_call' is the name of a module or file inside"),
    "model_name_nemc_drivers": (2, "name", "'nemc_drivers' is the name of a module or file"),
    "model_name_nemc_run": (2, "name", "'nemc_run' is the name of a module or file inside"),
    "model_name_runtime_package": (2, "name", "'_nemc' is the name of a module or file inside"),
    "model_name_model": (2, "name", "'model' is the name of a module or file inside"),
    "model_name_init": (2, "name", "'__init__' is the name of a module or file inside"),
    "model_name_build_ok": (2, "name", "'BUILD_OK' is the name of a module or file inside"),
    "model_name_dunder_main": (2, "name", "has the form of a Python special name"),
    "model_name_300_characters": (2, "name", "a model name has at most 64 characters"),
    # YAML that PyYAML reads another way than YAML 1.2, or than an editor numbers it
    "yaml_merge_key": (6, "bodies.b1.<<", "YAML merge keys ('<<') are not supported"),
    "unicode_nel": (6, "", "character U+0085 (NEL) is not allowed"),
    "unicode_line_separator": (3, "", "character U+2028 (LINE SEPARATOR) is not allowed"),
    "unicode_paragraph_separator": (6, "", "character U+2029 (PARAGRAPH SEPARATOR) is not"),
    "line_lone_carriage_return": (6, "bodies.b1.mass", "must be >= 0, got -1"),  # PyYAML: 7
    # numbers C cannot hold as a double, and depths the later stages cannot take
    "number_huge_integer_in_load": (11, "loads[0].torque", "a number in the expression is out"),
    "number_tiny_rational_in_load": (11, "loads[0].torque", "a number in the expression is out"),
    "deep_expression_tree": (11, "loads[0].torque", "nested too deeply: 103 levels, at most 100"),
    "parameter_chain_too_deep": (16, "parameters.p10", "nested too deeply: 101 levels once the "
                                                       "parameters and constants it uses"),
}


def generated_cases() -> dict[str, tuple[bytes, tuple[int, str, str]]]:
    """Large files, made here rather than stored."""
    base = (HOSTILE / "caret.yaml").read_text().replace("m^2", "m")
    flood = ", ".join(f"k{i}: '" + "+".join(f"sin({j})" for j in range(i, i + 60)) + "'"
                      for i in range(300))
    return {
        "too_large": (b"#" * 1_000_001, (1, "", "file is too large (1000001 bytes")),
        "flat_list_flood": (("name: x\nbodies: [" + ",".join(["0"] * 120_000) + "]\n").encode(),
                            (2, "", "document has more than 100000 nodes")),
        "token_flood": (base.replace("{m: 1, L: 2}", "{m: 1, L: 2, " + flood + "}").encode(),
                        (3, "", "the file's expressions have more than 50000 tokens")),
        "comments_near_the_limit": (base.encode() + b"#" * 99 + b"\n" * 9_000, (0, "", "")),
        # round 2: each took minutes, or died with RecursionError, before issue 21
        "parameter_chain_3000": (parameter_chain(3000, "parameters", "p{i}: p{j}*m + 1").encode(),
                                 (54, "parameters.p2950", "nested too deeply: 101 levels")),
        "constant_chain_3000": (parameter_chain(3000, "constants", "c{i}: sin(c{j})").encode(),
                                (104, "constants.c2900", "nested too deeply: 101 levels")),
        "loads_flood_with_5000_names": (names_and_loads(5000, 15000).encode(),
                                        (5006, "loads[0].torque", "stopped after 100 problems")),
        "chain_of_2000_bodies": (chain_yaml(2000).encode(),
                                 (5, "bodies", "2000 bodies: nemc builds at most 1000")),
    }


def parameter_chain(count: int, section: str, definition: str) -> str:
    """COUNT + 1 definitions, each made of the next (DEFINITION.format(i=..., j=...)), the
    last a number, listed last first (a resolver in file order needs a pass for each)."""
    lines = ["name: chained", f"{section}:", "  m: 2", f"  {definition[0]}{count}: 1"]
    lines += [f"  {definition.format(i=i, j=i + 1)}" for i in reversed(range(count))]
    lines += ["bodies: {b: {mass: 1, inertia: 1}}",
              "joints: {A: {type: revolute, parent: ground, child: b, coordinate: q}}"]
    return "\n".join(lines) + "\n"


def names_and_loads(names: int, loads: int) -> str:
    """Many parameters and many loads naming an unknown one: the scope of every expression
    was made again from every name (quadratic), and every problem got a suggestion."""
    lines = ["name: flood", "parameters:", *(f"  p{i}: 1" for i in range(names)),
             "bodies: {b: {mass: 1, inertia: 1}}",
             "joints: {A: {type: revolute, parent: ground, child: b, coordinate: q}}", "loads:"]
    lines += ["  - {torque: -qq, body: b}"] * loads
    return "\n".join(lines) + "\n"


def chain_yaml(bodies: int) -> str:
    lines = ["name: long_chain", "parameters: {m: 1, L: 1}", "gravity: [0, -9.81]", "bodies:"]
    lines += [f"  link{i}: {{mass: m, inertia: m*L**2/12, com: [L/2, 0], points: {{tip: [L, 0]}}}}"
              for i in range(bodies)]
    lines.append("joints:")
    lines += [f"  J{i}: {{type: revolute, parent: {'ground' if i == 0 else f'link{i - 1}'}, "
              f"child: link{i}, at: {'[0, 0]' if i == 0 else 'tip'}, coordinate: q{i}}}"
              for i in range(bodies)]
    return "\n".join(lines) + "\n"


@pytest.fixture
def folders(tmp_path: Path, nemc_cache: Path) -> tuple[Path, Path, set[str]]:
    """The output folder (must stay absent), the cache and its contents before."""
    nemc_cache.mkdir(exist_ok=True)
    return tmp_path / "out", nemc_cache, {p.name for p in nemc_cache.iterdir()}


def check_refused(file: Path, where: tuple[int, str, str], folders, capsys) -> None:
    out, cache, before = folders
    line, key, message = where
    prefix = f"{file}:{line}: {key}: " if key else f"{file}:{line}: "
    for command in (["check", str(file)], ["compile", str(file), "-o", str(out)]):
        assert main(command) == 2, command
        captured = capsys.readouterr()
        assert captured.out == ""
        lines = captured.err.splitlines()
        assert all(re.match(rf"{re.escape(str(file))}:\d+: ", text) for text in lines), lines
        assert any(text.startswith(prefix) and message in text for text in lines), \
            f"no {prefix!r}...{message!r} in:\n{captured.err}"
    assert not out.exists()
    assert {p.name for p in cache.iterdir()} == before


def test_the_table_covers_every_file() -> None:
    stems = {p.stem for p in HOSTILE.glob("*.yaml") if not p.stem.startswith("valid_")}
    assert stems == set(EXPECTED)


@pytest.mark.parametrize("stem", sorted(EXPECTED))
def test_hostile_file_is_refused(stem: str, folders, capsys, tmp_path: Path,
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # anything a file managed to run would land here
    check_refused(HOSTILE / f"{stem}.yaml", EXPECTED[stem], folders, capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", sorted(generated_cases()))
def test_large_file_is_handled_with_work_linear_in_it_and_bounded_memory(name: str,
                                                                         tmp_path: Path) -> None:
    """In a child process: its peak memory is its own. The checker's work (Python calls,
    tests/budgets.py, after a first check has imported what it needs) is at most 100 a byte
    of the file (up to 48 now: linear), where the unbounded loader of before issue 21 took
    minutes (quadratic resolving, exponential aliases) and gigabytes. The timeout only guards
    against a hang."""
    data, where = generated_cases()[name]
    file = tmp_path / f"{name}.yaml"
    file.write_bytes(data)
    code = ("import resource, sys; from budgets import work_of; from nemc.tools.cli import main;"
            " main(['check', sys.argv[2]]);"
            " work = work_of(lambda: main(['check', sys.argv[1]]), memory=False);"
            " print(work.result, work.calls, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,"
            " file=sys.__stdout__)")
    path = os.pathsep.join([str(ROOT), str(ROOT / "tests")])
    done = subprocess.run([sys.executable, "-c", code, str(file),
                           str(ROOT / "examples" / "double_pendulum.yaml")], capture_output=True,
                          text=True, timeout=HANG, env={**os.environ, "PYTHONPATH": path})
    status, calls, peak_kb = done.stdout.split()[-3:]
    assert "Traceback" not in done.stderr
    line, key, message = where
    if message:
        assert status == "2" and done.stderr.startswith(f"{file}:{line}: ") and \
            message in done.stderr, done.stderr
    else:
        assert status == "0", done.stderr
    assert int(calls) <= 100 * len(data) and int(peak_kb) < 1_000_000


@pytest.mark.parametrize("stem", ["code_import_os", "yaml_python_tag", "non_utf8",
                                  "alias_bomb", "model_name_path"])
def test_real_exit_status_and_no_traceback(stem: str, tmp_path: Path) -> None:
    file = HOSTILE / f"{stem}.yaml"
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "nemc.tools.cli", "compile", str(file),
                           "-o", str(out)],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env={**os.environ, "PYTHONPATH": str(ROOT),
                               "NEMC_CACHE": str(tmp_path / "cache")})
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.startswith(f"{file}:") and "Traceback" not in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no output, no cache, no PWNED


# C/C++ keywords and libc names are only names: they never reach C as identifiers.
PLAIN = {"double": "plain_twin", "int": "a1", "return": "a2", "static": "a3", "main": "a4",
         "printf": "a5", "NULL": "a6", "errno": "a7", "x0": "a8", "x1": "a9", "y": "a10",
         "p": "a11", "M_PI": "a12", "this": "a13", "new": "a14", "delete": "a15",
         "const": "a16", "struct": "body1", "union": "body2", "goto": "tip", "switch": "J1",
         "case": "J2", "float": "qa", "while": "qb", "char": "o1", "sizeof": "o2"}


def plain(text: str) -> str:
    words = re.compile(r"\b(" + "|".join(map(re.escape, PLAIN)) + r")\b")
    return words.sub(lambda match: PLAIN[match.group(1)], text)


def plain_twin(text: str) -> str:
    return "name: plain_twin\n" + plain(text.split("\n", 3)[3])  # without the description


def test_c_keywords_and_libc_names_work(tmp_path: Path) -> None:
    """valid_c_names.yaml compiles and runs exactly like its twin with plain names."""
    twin = tmp_path / "plain_twin.yaml"
    twin.write_text(plain_twin(VALID_C_NAMES.read_text()))
    hostile, twin_model = nemc.compile(VALID_C_NAMES), nemc.compile(twin)
    assert hostile.state_names == ("float", "dot(float)", "while", "dot(while)")
    assert twin_model.state_names == ("qa", "dot(qa)", "qb", "dot(qb)")
    rng = np.random.default_rng(8)
    for y in rng.uniform(-2, 2, size=(5, 4)):
        np.testing.assert_allclose(hostile.rhs(0.3, y), twin_model.rhs(0.3, y), rtol=1e-12)
        overrides = {"int": 2.5, "errno": 0.1}
        np.testing.assert_allclose(hostile.rhs(0.3, y, params=overrides),
                                   twin_model.rhs(0.3, y, params={plain(k): v for k, v in
                                                                  overrides.items()}), rtol=1e-12)
        renamed = {plain(k): v for k, v in hostile.outputs(0.3, y).items()}
        twin_outputs = twin_model.outputs(0.3, y)
        assert renamed.keys() == twin_outputs.keys()
        np.testing.assert_allclose(list(renamed.values()), list(twin_outputs.values()),
                                   rtol=1e-12, atol=1e-14)
    result = hostile.simulate()
    assert result.success and result.t[-1] == 1.0
    twin_result = twin_model.simulate()
    np.testing.assert_allclose(result.y[:, -1], twin_result.y[:, -1], rtol=1e-6, atol=1e-9)


def test_c_keyword_model_exports_and_imports_alone(tmp_path: Path, nemc_cache: Path) -> None:
    assert main(["compile", str(VALID_C_NAMES), "-o", str(tmp_path)]) == 0
    c_text = (tmp_path / "double" / "double.c").read_text()
    assert "rm -rf" in c_text and c_text.count("*/") == c_text.count("/*")  # comments stay shut
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import double; "
            "print(double.rhs(0.0, [0.3, 0.0, 0.0, -0.2]).tolist())")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True,
                          text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    expected = nemc.compile(VALID_C_NAMES).rhs(0.0, [0.3, 0.0, 0.0, -0.2]).tolist()
    assert done.stdout.strip() == repr(expected)


@pytest.mark.parametrize("assignment, message", [
    ("int=nan", "must be finite"),
    ("int=inf", "must be finite"),
    ("int=-1", "bodies.struct.mass must be >= 0"),
    ("main=-1", "bodies.union.inertia must be >= 0"),
    ("itn=1", "did you mean 'int'"),
])
def test_bad_parameters_at_run_time(assignment: str, message: str, capsys) -> None:
    assert main(["simulate", str(VALID_C_NAMES), "--set", assignment]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith(f"{VALID_C_NAMES}: --set")
    assert message in captured.err


def test_parameters_that_leave_a_joint_nothing_to_move_are_refused_at_run_time(capsys) -> None:
    """Masses and inertias may be 0 (format v3), but not everything a joint moves: the file's
    defaults pass, the overrides that empty joint 'switch' are refused before any run."""
    zeroed = ["--set", "int=0", "--set", "printf=0", "--set", "main=0"]
    assert main(["simulate", str(VALID_C_NAMES), *zeroed]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith(f"{VALID_C_NAMES}: --set")
    assert "joints.switch (mass or inertia of body 'struct' and what it carries) must be > 0" \
        in captured.err
