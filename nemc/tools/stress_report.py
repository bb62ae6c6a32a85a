"""`nemc stress`: run the measurements of `nemc.stress` on a scene and write them up as
Markdown with one PNG figure per scene; `--suite book` does the book's four systems and an
index of the key findings."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..runtime import runs
from ..runtime.model import DEFAULT_T_SPAN, Model, SimulationResult
from . import stress as s
from . import switches as sw

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
BOOK_SUITE = {  # file, the book's section, a second (high-energy) start for the sensitivity study
    "compound_pendulum": ("5.1", None),
    "double_pendulum": ("5.2", {"q1": 2.0, "q2": 2.5}),
    "robot_arm": ("5.3", None),
    "two_link_robot_arm": ("5.4", None),
}
SCENE_SAMPLES, HORIZON_SAMPLES = 401, 2001


@dataclass
class Study:
    """Everything measured on one scene."""

    name: str
    path: str
    model: Model
    reference: s.Reference  # over the scene's t_span
    runs: list[s.Run]
    own: SimulationResult
    own_error: tuple[dict[str, float], float, float]
    agreement: tuple[str, str, float]
    power_ratio: float
    horizon: s.Reference  # the long run (conservative scenes) or the scene's run again
    drifts: list[s.Drift]
    lyapunov: s.Lyapunov | None  # None with friction or contacts (SKIPPED says why)
    divergence: np.ndarray | None
    stiffness: s.Stiffness | None
    conditioning: s.Conditioning
    contrast: tuple[dict, s.Lyapunov] | None = None
    constraints: list[s.ConstraintDrift] = field(default_factory=list)  # closed loops only
    seconds: float = 0.0
    params: dict = field(default_factory=dict)
    switches: sw.Switching | None = None  # friction or contacts: the reference's switches
    balance: s.Balance | None = None  # friction or contacts: the energy balance

    @property
    def conservative(self) -> bool:
        return self.power_ratio < s.CONSERVED


class Finished:
    """A study's measurements as they finish: a progress line on a terminal, and the lines of
    the partial report written when Ctrl-C comes first (partial_markdown)."""

    def __init__(self, name: str):
        self.name = name
        self.lines: list[str] = []
        self.progress = runs.Progress(f"nemc stress {name}", delay=0.0)

    def start(self, what: str) -> None:
        self.progress.update(note=what)

    def done(self, line: str) -> None:
        self.lines.append(line)

    def run(self, run: s.Run) -> None:
        self.done(f"accuracy: {run.method} at rtol {run.rtol:g}, atol {run.atol:g}: max error "
                  f"{run.max_error:.2g}, {run.nfev} rhs calls")
        self.start(f"accuracy, {run.method} done at rtol {run.rtol:g}")


def study(path: str | Path, horizon: float = 1000.0, lyapunov_time: float = 300.0,
          params: Mapping[str, float] | None = None, contrast: dict | None = None,
          finished: Finished | None = None) -> Study:
    """Measure the scene in PATH (energy outputs added when the YAML has none). finished: what
    is done so far (progress on a terminal; a partial report after Ctrl-C, which raises
    KeyboardInterrupt here, runs included)."""
    from ..pipeline import compile_mechanism

    start = time.perf_counter()
    finished = finished or Finished(Path(path).stem)
    try:
        with runs.interrupts_raise():
            return measure(path, horizon, lyapunov_time, dict(params or {}), contrast, finished,
                           compile_mechanism, start)
    finally:
        finished.progress.close()


def check_horizon(model: Model, horizon: float) -> None:
    """The long horizon is at least the scene's own interval: its energy drift is sampled at
    HORIZON_SAMPLES times after the scene's start (a horizon of 1e-300 s gave equal times and
    a LinAlgError)."""
    t0, t1 = model.scene["t_span"] or DEFAULT_T_SPAN
    if not horizon >= abs(t1 - t0):
        raise s.runtime.ModelError(f"--horizon: the long horizon must be at least the scene's "
                                   f"interval, {abs(t1 - t0):g} s, got {horizon:g} s")


SKIPPED = {  # with friction or contacts: what has no meaning across mode switches, and why
    "sensitivity": "a Lyapunov exponent linearizes the flow, which has no derivative at the "
                   "switches (and a stuck joint's started modes are not a tangent direction)",
    "stiffness": "the Jacobian's eigenvalues hold only within one mode, and RK45 and Radau, "
                 "the comparison's methods, cannot run friction or contacts",
}


def measure(path: str | Path, horizon: float, lyapunov_time: float, params: dict,
            contrast: dict | None, finished: Finished, compile_mechanism, start: float) -> Study:
    """study()'s measurements, in order, each reported to `finished`."""
    finished.start("compiling")
    model = compile_mechanism(path, True, energy=True, mass_matrix=True).model
    check_horizon(model, horizon)
    finished.start("the scene's own run")
    own = model.simulate(params=params)
    if not own.success:
        raise s.runtime.ModelError(f"the scene's own run failed: {own.message}")
    finished.done(f"the scene's run: {own.method}, {own.nfev} rhs calls, {own.message}")
    span = (float(own.t[0]), float(own.t[-1]))
    finished.start("the reference")
    ref = s.reference(model, span, np.linspace(*span, SCENE_SAMPLES), params)
    switching = model.friction.present  # modes switched at events: SKIPPED's sections
    power = math.nan if switching else s.energy_power_ratio(model, ref.result, params)
    conservative = power < s.CONSERVED
    accuracy = s.accuracy_table(model, ref, s.methods(model=model), params=params,
                                done=finished.run)
    finished.start("the long reference")
    long = (s.reference(model, (span[0], span[0] + horizon),
                        np.linspace(span[0], span[0] + horizon, HORIZON_SAMPLES), params)
            if conservative else ref)
    drifts = []
    for method in s.methods(explicit_only=True, model=model) if conservative else ():
        for tol in s.DRIFT_TOLERANCES:
            finished.start(f"energy drift, {method} at rtol {tol:g}")
            drifts.append(s.energy_drift(model, long, method, tol, params))
            finished.done(f"energy drift over {horizon:g} s: {method} at rtol {tol:g}: max "
                          f"|dE/E| {drifts[-1].max_relative:.2g}")
    constraints = []
    for method in s.methods(explicit_only=True, model=model) if model.has_loops else ():
        for tol in s.DRIFT_TOLERANCES:
            finished.start(f"constraint drift, {method} at rtol {tol:g}")
            constraints.append(s.constraint_drift(
                model, (long.result.t[0], long.result.t[-1]), method, tol, params))
            finished.done(f"constraint drift: {method} at rtol {tol:g}: max |Phi| "
                          f"{max(constraints[-1].position):.2g}, max |Phi'| "
                          f"{max(constraints[-1].rate):.2g}")
    duration = min(horizon, lyapunov_time) if conservative else span[1] - span[0]
    y0 = ref.result.y[:, 0]
    finished.start("sensitivity, stiffness, conditioning")
    result = Study(
        name=model.name, path=str(path), model=model, reference=ref, runs=accuracy, own=own,
        own_error=s.error_estimate(model, own, params),
        agreement=s.agreement(model, params), power_ratio=power, horizon=long, drifts=drifts,
        lyapunov=None if switching else s.lyapunov(model, y0, duration, params),
        divergence=None if switching else s.divergence(model, long, 1e-6, params),
        stiffness=None if switching else s.stiffness(model, ref, params),
        conditioning=s.conditioning(model, ref.result, params), params=params,
        constraints=constraints,
        switches=sw.count_switches(model, ref.result, params) if switching else None,
        balance=s.energy_balance(model, span, params) if switching else None,
    )
    if contrast:
        start_state = model.state_vector(contrast, params)
        result.contrast = (contrast, s.lyapunov(model, start_state, duration, params))
    result.seconds = time.perf_counter() - start
    return result


def partial_markdown(finished: Finished) -> str:
    """What a study interrupted by Ctrl-C had measured: its finished measurements, as lines."""
    return "\n".join([f"# {finished.name}: interrupted (partial stress report)", "",
                      "`nemc stress` was interrupted before it finished; the measurements done "
                      "by then, in order:", "", *(f"- {line}" for line in finished.lines),
                      ""])


# -- Markdown --------------------------------------------------------------------------------


def g(value: float, digits: int = 2) -> str:
    """A number for a table: 3.1e-07, 0.012, 1.5e+03, inf."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if math.isinf(value):
        return "∞" if value > 0 else "-∞"
    return f"{value:.{digits}g}"


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in rows]


def scene_section(st: Study) -> list[str]:
    scene = st.model.scene
    rtol, atol = st.own.rtol, st.own.atol
    errors, ref_rtol, ref_atol = st.own_error
    worst = max(errors, key=errors.get)
    method, other, difference = st.agreement
    return [
        f"# Stress report: {st.name} (`{Path(st.path).name}`)", "",
        f"Scene: t_span {scene['t_span']}, method {st.own.method}, rtol {g(rtol)}, "
        f"atol {g(atol)}; {st.own.nfev} RHS calls. Measured in {st.seconds:.0f} s.", "",
        "## The scene's own run", "",
        f"- Error estimate (against {s.reference_method(st.model)} at rtol {g(ref_rtol)}, atol "
        f"{g(ref_atol)}): largest "
        f"{g(errors[worst])} on {worst}; all states: "
        + ", ".join(f"{k} {g(v)}" for k, v in errors.items()) + ".",
        f"- Agreement of two methods at the scene's tolerances: {method} and {other} differ by "
        f"at most {g(difference)} (state units) at the scene's times.",
        f"- `nemc simulate {Path(st.path).name} --error-estimate` prints the estimate.", "",
    ]


def accuracy_section(st: Study) -> list[str]:
    ref = st.reference
    method_names = list(dict.fromkeys(r.method for r in st.runs))
    rows = []
    for tol in s.TOLERANCES:
        row = [f"{g(tol)} / {g(s.tolerance_pair(tol)[1])}"]
        for m in method_names:
            run = next(r for r in st.runs if r.method == m and r.rtol == tol)
            row.append(f"{g(run.max_error)} ({run.nfev})")
        rows.append(row)
    book = next((r for r in st.runs if r.method == "RK45" and r.rtol == s.BOOK_RTOL), None)
    names = st.model.state_names
    loosest = [f"{m} rtol {g(s.loosest_tolerance(st.runs, m))}" for m in method_names]
    return [
        "## Accuracy against the true solution", "",
        f"Truth: {ref.result.method} at rtol {g(ref.result.rtol)} (its own error ≤ "
        f"{g(ref.own_error)}), "
        f"{SCENE_SAMPLES} times over the "
        "scene's t_span. Cells: max over t and states of |y − y_true| (RHS calls).", "",
        *table(["rtol / atol", *method_names], rows), "",
        *(["- The book's ode45 defaults (RK45, rtol 1e-3, atol 1e-6) are off by "
           + ", ".join(f"{n} {g(e)}" for n, e in zip(names, book.errors)) + "."]
          if book else []),
        f"- Loosest tolerance (atol = rtol/1000) reproducing the curve to {g(s.TRUST_ERROR)}: "
        + "; ".join(loosest) + ".", "",
    ]


def energy_section(st: Study) -> list[str]:
    head = ["## Energy drift", ""]
    if st.balance is not None:
        b = st.balance
        return ["## Energy balance", "",
                f"Friction and impacts take energy, so there is no drift to measure; instead "
                f"(a {s.reference_method(st.model)} run at rtol {g(s.REFERENCE_RTOL)}, its "
                "work account: the outputs NAME.friction_work and NAME.impact_loss):", "",
                f"- Energy change E(end) − E(0): {g(b.change, 8)}.",
                f"- Work of the friction (joints', guides' and contacts', every "
                f"NAME.friction_work): "
                f"{g(b.friction_work, 8)}.",
                f"- Energy the impacts took (every NAME.impact_loss): {g(b.impact_loss, 8)}.",
                f"- The rest, {g(b.rest, 3)}: the other loads' work (driven, time-dependent or "
                "damping loads, not in the energy); 0 to the integration's error where none "
                "is present.", ""]
    if not st.conservative:
        return head + [
            f"Not conservative: the loads do work (max |dE/dt| / max |dT/dt| = "
            f"{g(st.power_ratio)} along the trajectory), so energy is not a check here.", ""]
    long = st.horizon.result
    rows = [[d.method, g(d.rtol), str(d.nfev), g(d.max_relative), g(d.rate),
             until(d).removeprefix("until t = ") + (f" (**blew up** at t = {g(d.t[-1], 4)})"
                                                      if d.stopped else "")]
            for d in st.drifts]
    exponents = [f"{m} p = {s.drift_exponent(st.drifts, m):.2f}"
                 for m in dict.fromkeys(d.method for d in st.drifts)]
    return head + [
        f"Conservative (max |dE/dt| / max |dT/dt| = {g(st.power_ratio)}). Over "
        f"{g(long.t[-1] - long.t[0], 4)} s; |ΔE/E| is |E(t) − E(0)| over max(|E(0)|, max T). "
        f"Rate: least-squares slope of |ΔE/E| against t. Trusted until: first time the state "
        f"is off the reference by more than {g(s.TRUST_ERROR)} (reference error ≤ "
        f"{g(st.horizon.own_error)})."
        + (f" The long run ends early: {st.horizon.ended}." if st.horizon.ended else ""), "",
        *table(["method", "rtol", "RHS calls", "max abs(ΔE/E)", "rate (1/s)",
                "trusted"], rows), "",
        "- Drift rate ∝ rtol^p: " + ", ".join(exponents) + ".", "",
    ]


def constraint_section(st: Study) -> list[str]:
    """Closed loops: how well each explicit method keeps the constraints over the horizon."""
    if not st.constraints:
        return []
    rows = [[c.method, g(c.rtol), str(c.nfev), g(c.position[0]), g(c.position[1]),
             g(c.rate[0]), g(c.rate[1]),
             "**grows**" if c.growing else "no" + (f" (stopped at t = {g(c.t_end, 4)})"
                                                    if c.stopped else "")]
            for c in st.constraints]
    span = st.horizon.result.t
    return ["## Constraint drift", "",
            f"The closed loops' constraints on the returned states over {g(span[-1] - span[0], 4)}"
            " s (the first half, then the second): |Φ| the positions' residual, |Φ'| = "
            "|Φ_q q' + Φ_t| the rates'. nemc projects every state onto the constraints "
            "(docs/decisions.md, \"Closed loops\"): both stay at rounding level unless a "
            "projection fails.", "",
            *table(["method", "rtol", "RHS calls", "max |Φ| first half", "second half",
                    "max |Φ'| first half", "second half", "growth"], rows), ""]


def switching_section(st: Study) -> list[str]:
    """Friction's and contacts' switches on the reference run by item and kind, the
    chattering rule's verdict, and the events each method located at each tolerance."""
    found = st.switches
    if found is None:
        return []
    rows = [[item, *(str(counts.get(kind, 0)) for kind in sw.KINDS)]
            for item, counts in found.counts.items()]
    methods = list(dict.fromkeys(r.method for r in st.runs))
    located = [[g(tol), *(str(next(r.events for r in st.runs if r.method == m
                                   and r.rtol == tol)) for m in methods)]
               for tol in s.TOLERANCES]
    reference = sum(len(times) for times, _ in st.reference.result.events.values())
    return ["## Switches", "",
            f"Counted on the reference run ({st.reference.result.method}, rtol "
            f"{g(st.reference.result.rtol)}) across each of its events, from the modes "
            "(`J.stuck`, `C.active`) at the state before it and before the next "
            "(docs/stress.md, \"Friction and contacts\").", "",
            *table(["item", *sw.KINDS], rows), "", *chattering_lines(found), "",
            f"Events located by each method at each tolerance (the reference: {reference}):",
            "", *table(["rtol", *methods], located), ""]


def chattering_lines(found: sw.Switching) -> list[str]:
    """The chattering rule, and which events it flags (or the tightest bursts it does not)."""
    rule = (f"Chattering rule: {sw.CHATTER_COUNT} consecutive occurrences of one event within "
            f"{g(sw.CHATTER_FRACTION)} of the run's length ({g(found.window, 3)} s).")
    if found.chattering:
        return [rule, *(f"- **{b.event} chatters**: {sw.CHATTER_COUNT} occurrences within "
                        f"{g(b.span, 3)} s from t = {g(b.start, 8)} s" for b in found.chattering),
                f"- Closings (a plastic impact or the accumulation rule's): "
                f"{found.total('closing')}."]
    tightest = ", ".join(f"{b.event} {g(b.span, 3)} s" for b in found.bursts) or "none"
    return [rule, f"- No chattering; the tightest {sw.CHATTER_COUNT} occurrences: {tightest}."]


def until(drift: s.Drift) -> str:
    if math.isinf(drift.trusted_until):
        return f"over the whole {g(drift.t[-1] - drift.t[0], 4)} s"
    return f"until t = {g(drift.trusted_until, 4)} s"


def sensitivity_section(st: Study) -> list[str]:
    lam = st.lyapunov
    if lam is None or st.divergence is None:
        return ["## Sensitivity to the initial state", "", f"Skipped: {SKIPPED['sensitivity']}.",
                ""]
    t = st.horizon.result.t
    if st.horizon.result.method == "kinematic":
        return ["## Sensitivity to the initial state", "",
                "No degree of freedom is left by the drives (a kinematic analysis): the motion "
                "is prescribed, no initial value can be moved.", ""]
    lines = [
        "## Sensitivity to the initial state", "",
        f"- Largest Lyapunov exponent (Benettin renormalization of the variational equations "
        f"with the analytic Jacobian, {g(lam.t[-1], 4)} s): λ ≈ {lam.value:.3g} /s (estimate "
        f"at half that time: {lam.estimate[len(lam.t) // 2 - 1]:.3g}).",
        f"- A start 1e-6 away in {st.model.state_names[0]} is {g(st.divergence[-1])} away at "
        f"t = {g(t[-1], 4)} s.",
        divergence_line(lam, s.growth_exponent(t, st.divergence)),
    ]
    if st.contrast:
        start, contrast = st.contrast
        lines.append(f"- Contrast, started from {start} (higher energy): λ ≈ "
                     f"{contrast.value:.3g} /s; "
                     + divergence_line(contrast, math.nan).removeprefix("- ").lower())
    return lines + [""]


def divergence_line(lam: s.Lyapunov, power: float) -> str:
    if lam.exponential:
        horizons = ", ".join(f"rtol {g(tol)}: {g(s.lyapunov_horizon(lam.value, tol), 3)} s"
                             for tol in (1e-6, 1e-9, 1e-12))
        return (f"- Exponential divergence (chaotic): an error of size tol grows to "
                f"{g(s.TRUST_ERROR)} by ln({g(s.TRUST_ERROR)}/tol)/λ: {horizons}.")
    if lam.value < 0:
        return "- Nearby starts converge (λ < 0): errors made early are damped out."
    growth = f" like t^{power:.2f}" if math.isfinite(power) else ""
    return (f"- No exponential divergence (the estimate falls like ln t / t: regular motion); "
            f"the separation grows{growth}. The trust horizon is then set by the tolerance "
            "alone: see 'trusted until' above.")


def stiffness_section(st: Study) -> list[str]:
    """The stiffness (skipped with friction or contacts: SKIPPED), then the conditioning."""
    k = st.stiffness
    if k is None:
        return ["## Stiffness", "", f"Skipped: {SKIPPED['stiffness']}.", "",
                *conditioning_section(st)]
    advice = ("stiff: use an implicit method (Radau or BDF)" if k.stiff else
              "not stiff: an explicit method (DOP853, RK45) is the right choice")
    return [
        "## Stiffness", "",
        f"- Jacobian eigenvalues along the trajectory: fastest decay max(−Re λ) = "
        f"{g(k.fastest_decay, 4)} /s, spread max|λ|/min|λ| = {g(k.ratio, 3)}.",
        f"- RK45 at the scene's tolerances: mean step h = {g(k.explicit_step, 3)} s, "
        f"h · max(−Re λ) = {g(k.step_times_decay, 3)} (its stability limit is about 3.3); "
        f"{k.explicit_nfev} RHS calls against Radau's {k.implicit_nfev}"
        + ("." if math.isnan(k.explicit_stopped_at) else
           f" (its stiffness test stopped it at t = {g(k.explicit_stopped_at, 6)}: its RHS "
           "calls are extrapolated from its pace until then)."),
        f"- Verdict: {advice}.", "", *conditioning_section(st)]


def conditioning_section(st: Study) -> list[str]:
    """cond(M) along the reference run, and the worst configuration."""
    c = st.conditioning
    return [
        "## Conditioning of the mass matrix", "",
        f"- cond₂(M(q)) along the trajectory: {g(float(np.min(c.condition)), 3)} to "
        f"{g(c.worst, 3)} ({c.verdict}; about {c.digits_lost:.1f} of 16 digits lost in the "
        f"accelerations); eigenvalues of M from {g(float(np.min(c.smallest)), 3)} to "
        f"{g(float(np.max(c.largest)), 3)}.",
        "- Worst configuration: " + ", ".join(
            f"{n}={v:.4g}" for n, v in zip(st.model.state_names, c.worst_state)) + ".", "",
    ]


def markdown(st: Study, figure_name: str) -> str:
    lines = [*scene_section(st), *accuracy_section(st), *switching_section(st),
             *energy_section(st),
             *constraint_section(st),
             *sensitivity_section(st), *stiffness_section(st), f"![{st.name}]({figure_name})", ""]
    return "\n".join(lines)


# -- figure ----------------------------------------------------------------------------------


def figure(st: Study, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(16, 8.4), layout="constrained")
    plot_accuracy(st, axes[0, 0])
    plot_drift(st, axes[0, 1])
    if st.switches is None:
        plot_divergence(st, axes[0, 2])
        plot_lyapunov(st, axes[1, 0])
        plot_eigenvalues(st, axes[1, 1])
    else:
        plot_switches(st, axes[0, 2])
        plot_skipped(axes[1, 0], "largest Lyapunov exponent")
        plot_skipped(axes[1, 1], "Jacobian eigenvalues")
    plot_conditioning(st, axes[1, 2])
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
        if ax.get_legend() is not None:  # beside its axes: never on the data
            handles, labels = ax.get_legend_handles_labels()
            ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                      fontsize="small", frameon=False)
    fig.suptitle(f"nemc stress: {st.name}")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_accuracy(st: Study, ax) -> None:
    for m in dict.fromkeys(r.method for r in st.runs):
        runs = [r for r in st.runs if r.method == m]
        ax.loglog([max(r.nfev, 1) for r in runs], [max(r.max_error, 1e-16) for r in runs], "o-",
                  label=m, ms=3)
    ax.axhline(s.TRUST_ERROR, color="k", lw=0.8, ls="--")
    ax.set(xlabel="RHS calls", ylabel="max |y − y_true|", title="work / precision")
    ax.legend(fontsize="small")


def plot_drift(st: Study, ax) -> None:
    if not st.drifts:
        ax.text(0.5, 0.5, "not conservative", ha="center", va="center", transform=ax.transAxes)
        ax.set(title="energy drift")
        return
    methods = list(dict.fromkeys(d.method for d in st.drifts))
    tolerances = sorted({d.rtol for d in st.drifts}, reverse=True)
    colours = plt_colours()
    for d in st.drifts:  # a colour per method, a line style per tolerance: no repeats
        ax.semilogy(d.t, np.maximum(d.relative, 1e-17), lw=0.9,
                    color=colours[methods.index(d.method) % len(colours)],
                    ls=("-", "--", ":", "-.")[tolerances.index(d.rtol) % 4],
                    label=f"{d.method} {g(d.rtol)}")
    ax.set(xlabel="t (s)", ylabel="|ΔE/E|", title="energy drift")
    ax.legend(fontsize="x-small", ncol=2)


def plt_colours() -> list[str]:
    return ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"]


def plot_switches(st: Study, ax) -> None:
    """The reference run's events, one row per event name, at their times."""
    events = st.reference.result.events
    for row, (name, (times, _)) in enumerate(events.items()):
        ax.plot(times, np.full(len(times), row), "|", ms=10, label=name)
    ax.set_yticks(range(len(events)), list(events))
    ax.set(xlabel="t (s)", title="switches (events) of the reference run")


def plot_skipped(ax, title: str) -> None:
    """An empty panel saying why it is empty: friction or contacts switch modes."""
    ax.text(0.5, 0.5, "skipped: modes switch\n(see the report)", ha="center", va="center",
            transform=ax.transAxes)
    ax.set(title=title)


def plot_divergence(st: Study, ax) -> None:
    t = st.horizon.result.t
    ax.semilogy(t, np.maximum(st.divergence, 1e-17), lw=0.8, label="|Δy|, Δ = 1e-6")
    ax.set(xlabel="t (s)", ylabel="|Δy|", title="divergence of nearby starts")
    ax.legend(fontsize="small")


def plot_lyapunov(st: Study, ax) -> None:
    ax.plot(st.lyapunov.t, st.lyapunov.estimate, label="scene")
    if st.contrast:
        ax.plot(st.contrast[1].t, st.contrast[1].estimate, label="high energy")
    ax.axhline(0, color="k", lw=0.6)
    ax.set(xlabel="t (s)", ylabel="λ estimate (1/s)", title="largest Lyapunov exponent")
    ax.legend(fontsize="small")


def plot_eigenvalues(st: Study, ax) -> None:
    k = st.stiffness
    ax.plot(k.t, k.eigenvalues.real, ".", ms=1.5)
    ax.set_yscale("symlog", linthresh=1.0)
    ax.set(xlabel="t (s)", ylabel="Re λ(J)", title="Jacobian eigenvalues")


def plot_conditioning(st: Study, ax) -> None:
    ax.semilogy(st.conditioning.t, st.conditioning.condition)
    ax.set(xlabel="t (s)", ylabel="cond₂ M(q)", title="mass matrix conditioning")


# -- writing ---------------------------------------------------------------------------------


def write(st: Study, out: Path) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    figure(st, out / f"{st.name}.png")
    target = out / f"{st.name}.md"
    target.write_text(markdown(st, f"{st.name}.png"))
    return target


def book_run(st: Study) -> s.Run:
    return next(r for r in st.runs if r.method == "RK45" and r.rtol == s.BOOK_RTOL)


def summary_row(st: Study, section: str) -> list[str]:
    loosest = {m: s.loosest_tolerance(st.runs, m) for m in ("RK45", "DOP853", "Radau")}
    drift = next((d for d in st.drifts if d.method == "DOP853" and d.rtol == 1e-9), None)
    return [
        f"[{section} {st.name}]({st.name}.md)",
        "yes" if st.conservative else "no",
        g(book_run(st).max_error),
        " / ".join(g(v) for v in loosest.values()),
        g(max(st.own_error[0].values())),
        g(drift.rate) if drift else "–",
        f"{st.lyapunov.value:.3g}" + (" (chaotic)" if st.lyapunov.exponential else ""),
        f"{'stiff' if st.stiffness.stiff else 'not stiff'} ({g(st.stiffness.ratio, 2)})",
        g(st.conditioning.worst, 2),
    ]


def findings(st: Study, section: str) -> list[str]:
    """The key findings on one system, in sentences (every number measured)."""
    book = book_run(st)
    worst = int(np.argmax(book.errors))
    names = st.model.state_names
    lines = [
        f"- **{section} {st.name}**: the book's ode45 defaults are off by "
        f"{g(book.errors[worst])} on {names[worst]} over t_span {st.model.scene['t_span']}; "
        f"reproducing the curve to {g(s.TRUST_ERROR)} needs rtol "
        + ", ".join(f"{g(s.loosest_tolerance(st.runs, m))} ({m})" for m in ("RK45", "DOP853"))
        + f" with atol = rtol/1000. The scene's own run ({st.own.method}, rtol "
        f"{g(st.own.rtol)}) is within {g(max(st.own_error[0].values()))} of the truth.",
    ]
    if st.drifts:
        best = min(st.drifts, key=lambda d: (d.method != "DOP853", d.rtol))  # the tightest
        lines.append(
            f"  Conservative: over {g(st.horizon.result.t[-1], 4)} s energy drifts at "
            f"{g(best.rate)} /s at best ({best.method}, rtol {g(best.rtol)}), growing as "
            f"rtol^{s.drift_exponent(st.drifts, best.method):.2f}; the state stays within "
            f"{g(s.TRUST_ERROR)} of the truth {until(best)}.")
    lam = st.lyapunov
    kind = ("chaotic" if lam.exponential else "converging" if lam.value < 0
            else "regular, not chaotic")
    lines.append(f"  λ ≈ {lam.value:.3g} /s ({kind})"
                 + (f"; from {st.contrast[0]} λ ≈ {st.contrast[1].value:.3g} /s"
                    + (" (chaotic)" if st.contrast[1].exponential else "")
                    if st.contrast else "") + ".")
    stiff = st.stiffness
    lines.append(
        f"  {'Stiff' if stiff.stiff else 'Not stiff'}: fastest decay {g(stiff.fastest_decay, 4)}"
        f" /s, eigenvalue spread {g(stiff.ratio, 3)}, RK45 {stiff.explicit_nfev} RHS calls vs "
        f"Radau {stiff.implicit_nfev}"
        + ("; use Radau or BDF." if stiff.stiff else ".")
        + f" Mass matrix {st.conditioning.verdict} (cond ≤ {g(st.conditioning.worst, 3)}).")
    return lines


def index(studies: Sequence[Study], sections: Sequence[str]) -> str:
    header = ["system", "conservative", "book ode45 error", "rtol for 1e-3 (RK45 / DOP853 / "
              "Radau)", "scene's own error", "energy drift rate, DOP853 1e-9 (1/s)",
              "λ (1/s)", "stiffness (spread)", "max cond M"]
    rows = [summary_row(st, sec) for st, sec in zip(studies, sections)]
    found = [line for st, sec in zip(studies, sections) for line in findings(st, sec)]
    return "\n".join([
        "# Stress report: the book's four systems", "",
        "Generated by `nemc stress --suite book --out docs/stress` (or `make stress`); every "
        "number is measured, none is typed in. Errors are max over t and states of "
        "|y − y_true|, y_true from DOP853 at rtol 1e-12 over the scene's t_span.", "",
        *table(header, rows), "", "## Findings", "", *found, "",
    ])


def run_suite(out: Path, horizon: float = 1000.0, lyapunov_time: float = 300.0,
              log=print) -> list[Study]:
    """The book's systems, each written as it is done; after Ctrl-C, the index of those done
    and the partial report of the one under way (then KeyboardInterrupt goes on up)."""
    studies = []
    sections = []
    try:
        for name, (section, contrast) in BOOK_SUITE.items():
            finished = Finished(name)
            try:
                st = study(EXAMPLES / f"{name}.yaml", horizon, lyapunov_time, contrast=contrast,
                           finished=finished)
            except KeyboardInterrupt:
                log(f"{name}: interrupted -> {write_partial(finished, out)}")
                raise
            log(f"{name}: measured in {st.seconds:.1f} s -> {write(st, out)}")
            studies.append(st)
            sections.append(section)
    finally:
        if studies:
            (out / "README.md").write_text(index(studies, sections))
            log(f"index -> {out / 'README.md'}")
    return studies


def write_partial(finished: Finished, out: Path) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    target = out / f"{finished.name}.partial.md"
    target.write_text(partial_markdown(finished))
    return target
