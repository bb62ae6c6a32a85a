"""PNG plots of the benchmark results (matplotlib, Agg): work-precision, costs against n."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)

STAGES = ("validate", "derive", "optimize", "emit", "build", "load")


def save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def wp_series(rows: Sequence[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    """Rows grouped by curve label (contender and method), loosest tolerance first."""
    series: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        label = r["contender"] if r["contender"].split()[0] not in ("nemc", "lambdify(cse)") \
            else f"{r['method']}, {r['contender']}"
        if r.get("seconds") and r.get("error") is not None:
            series.setdefault(label, []).append(r)
    return {k: sorted(v, key=lambda r: -r["rtol"]) for k, v in series.items()}


def plot_work_precision(result: dict[str, Any], folder: Path) -> list[Path]:
    paths = []
    peer_rows = result.get("peers", {}).get("work_precision", [])
    for name, w in result["work_precision"].items():
        rows = w["rows"] + (peer_rows if name == "double_pendulum" else [])
        fig, axes = plt.subplots(1, 2, figsize=(13, 5.5), sharey=True)
        for k, (label, series) in enumerate(wp_series(rows).items()):
            style = "--s" if "lambdify" in label else ":^" if not label.split(", ")[-1] \
                .startswith("nemc") else "-o"
            for ax, key in zip(axes, ("error", "trajectory_error")):
                ax.loglog([max(r[key], 1e-16) for r in series],
                          [r["seconds"]["median"] for r in series], style,
                          color=f"C{k % 10}", label=label, markersize=4)
        for ax, what in zip(axes, ("final state", "trajectory (t_eval points)")):
            ax.set_xlabel(f"error of the {what}, max abs vs reference")
            ax.grid(True, which="both", alpha=0.3)
        axes[0].set_ylabel("wall time of the solve, median (s)")
        axes[1].legend(fontsize=6, ncol=2)
        fig.suptitle(f"Work-precision: {name}, t in {w['t_span']} "
                     f"({result['environment']['mode']} run)")
        paths.append(save(fig, folder / f"work_precision_{name}.png"))
    return paths


def errorbar_series(ax, ns, stats: Sequence[dict[str, Any]], label: str, color: str,
                    scale: float = 1.0) -> None:
    ax.errorbar(ns, [s["median"] * scale for s in stats],
                yerr=[[(s["median"] - s["min"]) * scale for s in stats],
                      [(s["max"] - s["median"]) * scale for s in stats]],
                fmt="-o", color=color, label=label, capsize=3, markersize=4)


def log_axes(ax, xlabel: str, ylabel: str, title: str) -> None:
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)


def chains(table: dict[str, Any], prefix: str = "chain") -> dict[int, Any]:
    return {int(k[len(prefix):]): v for k, v in table.items() if k.startswith(prefix)
            and k[len(prefix):].isdigit()}


def plot_rhs(result: dict[str, Any], folder: Path) -> list[Path]:
    by_n = chains(result["rhs"])
    if not by_n:
        return []
    ns = sorted(by_n)
    contenders = dict.fromkeys(c for n in ns for c in by_n[n]["per_call_seconds"])
    fig, ax = plt.subplots(figsize=(7, 5))
    for k, contender in enumerate(contenders):
        points = [(n, by_n[n]["per_call_seconds"][contender]) for n in ns
                  if contender in by_n[n]["per_call_seconds"]]
        errorbar_series(ax, [n for n, _ in points], [t for _, t in points], contender, f"C{k}",
                        1e9)
    log_axes(ax, "links n (chain of uniform rods)", "ns per RHS evaluation (median, min-max)",
             f"RHS cost vs n ({result['environment']['mode']} run)")
    return [save(fig, folder / "rhs_cost.png")]


def plot_phases(phases: dict[str, Any], folder: Path, title: str, filename: str,
                prefix: str = "chain") -> list[Path]:
    by_n = chains(phases, prefix)
    if len(by_n) < 2:
        return []
    ns = sorted(by_n)
    fig, ax = plt.subplots(figsize=(7, 5))
    for k, stage in enumerate(STAGES):
        values = [by_n[n]["cold"]["timings"].get(stage) for n in ns]
        if any(values):
            ax.plot(ns, [max(v or 0, 1e-5) for v in values], "-o", color=f"C{k}", label=stage,
                    markersize=4)
    ax.plot(ns, [by_n[n]["cold_total"] for n in ns], "-k", linewidth=2, label="cold total")
    errorbar_series(ax, ns, [by_n[n]["cached_load"] for n in ns], "cached load (first call)",
                    "C8")
    log_axes(ax, "bodies n", "seconds", title)
    return [save(fig, folder / filename)]


def suite_plots(result: dict[str, Any], folder: Path) -> list[Path]:
    return (plot_work_precision(result, folder) + plot_rhs(result, folder)
            + plot_phases(result["phases"], folder, "Compile phases vs n (cold, fresh process)",
                          "compile_phases.png"))
