"""An FMU's XML: modelDescription.xml (FMI 2.0 and 3.0) and FMI 3.0's buildDescription.xml,
from a build's model.json, the FMU's variables (fmu_variables.Layout) and its dependencies.

Units are the YAML's labels (model.json's unit_labels); where the YAML's units are kg, m and s
each also gets its SI base-unit exponents. Every runtime parameter is tunable; the inputs are
continuous inputs, the outputs calculated outputs, the states exact (a closed loop's approx:
assembled at initialization) with their derivatives named der(...).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..emit.units import ANGULAR, DIMENSIONS
from ..vocabulary import NEMC_VERSION
from .fmu_variables import FmuDefaults, Layout, Variable

SI = {"length": "m", "mass": "kg", "time": "s"}
LOG_CATEGORIES = (("logEvents", "events, impacts, projections and stops as they happen"),
                  ("logStatusDiscard", "evaluations the model cannot make at a state"),
                  ("logStatusError", "errors: wrong calls, values or states"))


@dataclass(frozen=True)
class Dependencies:
    """Which states (by index) and inputs each derivative and output depends on; None: on all
    (no pattern known, a closed loop's)."""

    derivatives: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] | None = None
    outputs: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...] | None = None


@dataclass(frozen=True)
class Description:
    """What modelDescription.xml says beyond the variables."""

    meta: Mapping[str, Any]
    layout: Layout
    defaults: FmuDefaults
    dependencies: Dependencies
    fmi: int
    kind: str
    token: str
    sources: tuple[str, ...]
    directional: bool
    stop_events: bool


def number(value: float | int) -> str:
    """A value as xs:double or xs:int writes it: the shortest text that reads back the same."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(value)
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        raise ValueError(f"not a finite number: {value}")
    return repr(float(value))


def flag(value: bool) -> str:
    return "true" if value else "false"


# ---- units ----------------------------------------------------------------------------------

def quantity_of(meta: Mapping[str, Any], variable: Variable) -> str | None:
    """The kind of quantity a variable measures (model.json's quantities)."""
    quantities = meta.get("quantities", {})
    if variable.role == "time":
        return quantities.get("t")
    if variable.role == "derivative":
        state = variable.name[4:-1]
        rate = f"ddot({state[4:-1]})" if state.startswith("dot(") else f"dot({state})"
        return quantities.get(rate)
    return quantities.get(variable.name)


def base_units(meta: Mapping[str, Any], kind: str | None) -> dict[str, int]:
    """A quantity's SI exponents (m, kg, s, rad), when the YAML's units are kg, m and s."""
    units = meta.get("units", {})
    if kind is None or any(units.get(q) != unit for q, unit in SI.items()):
        return {}
    if kind in ANGULAR:
        seconds = {"angle": 0, "angular rate": -1, "angular acceleration": -2}[kind]
        return {"rad": 1, **({"s": seconds} if seconds else {})}
    length, mass, time = DIMENSIONS[kind]
    return {k: v for k, v in (("kg", mass), ("m", length), ("s", time)) if v}


def unit_definitions(description: Description) -> dict[str, dict[str, int]]:
    """Every unit label a variable uses, with its SI exponents where known."""
    found: dict[str, dict[str, int]] = {}
    for variable in description.layout.variables:
        if variable.unit and variable.unit not in found:
            found[variable.unit] = base_units(description.meta,
                                              quantity_of(description.meta, variable))
    return found


def add_units(root: ET.Element, description: Description) -> None:
    units = unit_definitions(description)
    if not units:
        return
    element = ET.SubElement(root, "UnitDefinitions")
    for name, exponents in units.items():
        unit = ET.SubElement(element, "Unit", name=name)
        if exponents:
            ET.SubElement(unit, "BaseUnit", {k: str(v) for k, v in exponents.items()})


# ---- the parts every version has ------------------------------------------------------------

def causality(variable: Variable, has_loops: bool) -> dict[str, str]:
    """causality, variability and initial of a variable by its role."""
    if variable.role == "time":
        return {"causality": "independent", "variability": "continuous"}
    if variable.role == "state":
        return {"causality": "local", "variability": "continuous",
                "initial": "approx" if has_loops else "exact"}
    if variable.role in ("derivative", "indicator"):
        return {"causality": "local", "variability": "continuous", "initial": "calculated"}
    if variable.role in ("parameter", "setting"):
        return {"causality": "parameter", "variability": "tunable", "initial": "exact"}
    if variable.role == "input":
        return {"causality": "input", "variability": "continuous"}
    return {"causality": "output", "variability": "continuous", "initial": "calculated"}


def value_attributes(variable: Variable, derivative_of: str | None) -> dict[str, str]:
    """A variable's type attributes: start, unit, bounds, the state it is the derivative of."""
    attributes = {}
    if variable.start is not None:
        attributes["start"] = number(variable.start)
    if variable.unit:
        attributes["unit"] = variable.unit
    if derivative_of is not None:
        attributes["derivative"] = derivative_of
    if variable.minimum is not None:
        attributes["min"] = number(variable.minimum)
    if variable.maximum is not None:
        attributes["max"] = number(variable.maximum)
    return attributes


def add_log_categories(root: ET.Element) -> None:
    element = ET.SubElement(root, "LogCategories")
    for name, text in LOG_CATEGORIES:
        ET.SubElement(element, "Category", name=name, description=text)


def add_experiment(root: ET.Element, defaults: FmuDefaults) -> None:
    attributes = {"startTime": number(defaults.start_time),
                  "stopTime": number(defaults.stop_time), "tolerance": number(defaults.rtol)}
    if defaults.output_step:
        attributes["stepSize"] = number(defaults.output_step)
    ET.SubElement(root, "DefaultExperiment", attributes)


def header(description: Description) -> dict[str, str]:
    meta = description.meta
    attributes = {"fmiVersion": "2.0" if description.fmi == 2 else "3.0",
                  "modelName": meta["name"]}
    attributes["guid" if description.fmi == 2 else "instantiationToken"] = description.token
    if meta.get("description"):
        attributes["description"] = meta["description"]
    attributes.update(generationTool=f"nemc {NEMC_VERSION}", variableNamingConvention="flat")
    return attributes


def unknowns(description: Description) -> list[tuple[Variable, list[Variable] | None, str]]:
    """ModelStructure's entries: (unknown, what it depends on or None for all, output,
    derivative or initial). Model exchange: the outputs on states and inputs, the
    derivatives, and as initial unknowns the outputs, the derivatives and a closed loop's
    states (approx). Co-simulation, whose knowns are its inputs (its states are no continuous
    states to the importer): the outputs on the inputs they feed through, the outputs as
    initial unknowns."""
    layout, deps = description.layout, description.dependencies
    states, inputs = layout.of("state"), layout.of("input")
    exchange = description.kind == "me"

    def known(pattern: tuple[tuple[int, ...], tuple[int, ...]]) -> list[Variable]:
        on_states, on_inputs = pattern
        return ([states[i] for i in on_states] if exchange else []) + [inputs[k] for k in
                                                                       on_inputs]

    outputs = layout.of("output")
    entries: list[tuple[Variable, list[Variable] | None, str]] = [
        (output, None if deps.outputs is None else known(deps.outputs[k]), "output")
        for k, output in enumerate(outputs)]
    if not exchange:
        return entries + [(output, None, "initial") for output in outputs]
    derivatives = layout.of("derivative")
    entries += [(derivative, None if deps.derivatives is None else known(deps.derivatives[i]),
                 "derivative") for i, derivative in enumerate(derivatives)]
    initial = [*outputs, *derivatives]
    if description.meta.get("constraint_equations"):
        initial += states  # approx: assembled at initialization
    return entries + [(v, None, "initial") for v in sorted(initial, key=lambda v: v.vr)]


def dependency_attributes(unknown: Variable, depends: list[Variable] | None,
                          reference: Mapping[int, int], constant: set[tuple[int, int]]
                          ) -> dict[str, str]:
    """dependencies and dependenciesKind: "constant" where a derivative is a state's own rate
    (der(q) = dot(q): CONSTANT's pairs of value references), else "dependent"; REFERENCE maps
    a value reference to how the version refers to it (FMI 2: its index, FMI 3: itself)."""
    if depends is None:
        return {}
    return {"dependencies": " ".join(str(reference[v.vr]) for v in depends),
            "dependenciesKind": " ".join("constant" if (unknown.vr, v.vr) in constant else
                                         "dependent" for v in depends)}


def own_rates(description: Description) -> set[tuple[int, int]]:
    """A tree's (der(q), dot(q)) pairs of value references: der(q) is dot(q), a constant
    dependency (a closed loop's rhs projects first: its are all "dependent")."""
    if description.dependencies.derivatives is None:
        return set()
    states = description.layout.of("state")
    derivatives = description.layout.of("derivative")
    return {(derivatives[i].vr, states[i + 1].vr) for i in range(0, len(states), 2)}


def add_units_log_experiment(root: ET.Element, description: Description) -> None:
    """The elements both versions write before the variables, in their schemas' order."""
    add_units(root, description)
    add_log_categories(root)
    add_experiment(root, description.defaults)


def variable_attributes(variable: Variable, has_loops: bool) -> dict[str, str]:
    """A variable's name, value reference, description and causality (both versions)."""
    attributes = {"name": variable.name, "valueReference": str(variable.vr)}
    if variable.description:
        attributes["description"] = variable.description
    attributes.update(causality(variable, has_loops))
    return attributes


# ---- FMI 2.0 --------------------------------------------------------------------------------

def fmi2_model_description(description: Description) -> str:
    layout, meta = description.layout, description.meta
    root = ET.Element("fmiModelDescription", header(description))
    root.set("numberOfEventIndicators", str(len(layout.of("indicator"))))
    interface = ET.SubElement(root, "ModelExchange" if description.kind == "me" else
                              "CoSimulation", interface_attributes(description))
    files = ET.SubElement(interface, "SourceFiles")
    for name in description.sources:
        if name.endswith(".c"):
            ET.SubElement(files, "File", name=name)
    add_units_log_experiment(root, description)
    index = {v.vr: position for position, v in enumerate(layout.variables, start=1)}
    states = layout.of("state")
    variables = ET.SubElement(root, "ModelVariables")
    has_loops = bool(meta.get("constraint_equations"))
    for variable in layout.variables:
        element = ET.SubElement(variables, "ScalarVariable",
                                variable_attributes(variable, has_loops))
        of = str(index[states[variable.index].vr]) if variable.role == "derivative" \
            and description.kind == "me" else None
        ET.SubElement(element, "Integer" if variable.integer else "Real",
                      value_attributes(variable, of))
    structure = ET.SubElement(root, "ModelStructure")
    sections = {"output": "Outputs", "derivative": "Derivatives", "initial": "InitialUnknowns"}
    elements = {role: ET.Element(tag) for role, tag in sections.items()}
    pairs = own_rates(description)
    for variable, depends, role in unknowns(description):
        ET.SubElement(elements[role], "Unknown", {
            "index": str(index[variable.vr]),
            **dependency_attributes(variable, depends, index, pairs)})
    for role in sections:
        if len(elements[role]):
            structure.append(elements[role])
    return serialized(root)


def interface_attributes(description: Description) -> dict[str, str]:
    """The capabilities of the interface element (FMI 2's ModelExchange or CoSimulation, FMI
    3's likewise)."""
    name = description.meta["name"]
    if description.fmi == 2:
        common = {"modelIdentifier": name, "canNotUseMemoryManagementFunctions": "true",
                  "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
                  "providesDirectionalDerivative": flag(description.directional)}
        if description.kind == "me":
            return {**common, "completedIntegratorStepNotNeeded": "false"}
        return {**common, "canHandleVariableCommunicationStepSize": "true",
                "canInterpolateInputs": "false", "maxOutputDerivativeOrder": "0"}
    common = {"modelIdentifier": name, "canGetAndSetFMUState": "true",
              "canSerializeFMUState": "true",
              "providesDirectionalDerivatives": flag(description.directional),
              "providesAdjointDerivatives": flag(description.directional)}
    if description.kind == "me":
        return {**common, "needsCompletedIntegratorStep": "true"}
    return {**common, "canHandleVariableCommunicationStepSize": "true",
            "mightReturnEarlyFromDoStep": flag(description.stop_events), "hasEventMode": "false"}


# ---- FMI 3.0 --------------------------------------------------------------------------------

def fmi3_model_description(description: Description) -> str:
    layout, meta = description.layout, description.meta
    root = ET.Element("fmiModelDescription", header(description))
    ET.SubElement(root, "ModelExchange" if description.kind == "me" else "CoSimulation",
                  interface_attributes(description))
    add_units_log_experiment(root, description)
    states = layout.of("state")
    variables = ET.SubElement(root, "ModelVariables")
    has_loops = bool(meta.get("constraint_equations"))
    for variable in layout.variables:
        attributes = variable_attributes(variable, has_loops)
        of = str(states[variable.index].vr) if variable.role == "derivative" \
            and description.kind == "me" else None
        attributes.update(value_attributes(variable, of))
        ET.SubElement(variables, "Int32" if variable.integer else "Float64", attributes)
    structure = ET.SubElement(root, "ModelStructure")
    tags = {"output": "Output", "derivative": "ContinuousStateDerivative",
            "initial": "InitialUnknown"}
    identity = {v.vr: v.vr for v in layout.variables}
    pairs = own_rates(description)
    entries = unknowns(description)
    for role in tags:  # the schema's order: outputs, derivatives, initial unknowns
        for variable, depends, entry_role in entries:
            if entry_role == role:
                ET.SubElement(structure, tags[role], {
                    "valueReference": str(variable.vr),
                    **dependency_attributes(variable, depends, identity, pairs)})
    if description.kind == "me":
        for indicator in layout.of("indicator"):
            ET.SubElement(structure, "EventIndicator", valueReference=str(indicator.vr))
    return serialized(root)


def build_description(name: str, source_sets: Sequence[tuple[tuple[str, ...], str]]) -> str:
    """FMI 3.0's sources/buildDescription.xml: the C files in sets by their compiler options
    (nemc's flags: the model at -O2, its long programs' unit files at -O1, the integrators at
    -O3), linked with libm."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    configuration = ET.SubElement(root, "BuildConfiguration", modelIdentifier=name)
    for files, options in source_sets:
        file_set = ET.SubElement(configuration, "SourceFileSet", language="C99",
                                 compilerOptions=options)
        for file in files:
            ET.SubElement(file_set, "SourceFile", name=file)
        ET.SubElement(file_set, "IncludeDirectory", name=".")
    ET.SubElement(configuration, "Library", name="m", description="the C math library")
    return serialized(root)


def serialized(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") \
        + "\n"


def model_description(description: Description) -> str:
    """modelDescription.xml's text for the description's FMI version."""
    if description.fmi == 2:
        return fmi2_model_description(description)
    return fmi3_model_description(description)
