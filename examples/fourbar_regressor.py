"""The driven four-bar's inertial parameters from its drive torque (issue 47's regressor example).

The crank of examples/fourbar_driven.yaml turns at constant speed w; the motor's torque A.drive
is "measured" with 1 % noise (seeded) at two speeds, 60 and 30 rpm, and the base parameters (the
combinations of the bodies' masses, first moments and inertias the torque identifies) are
estimated by linear least squares on tau = Y(q, qd, qdd) phi - Q, with standard errors. Each
estimate is printed with the model's own value and how many standard errors apart they are.

    python examples/fourbar_regressor.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

import nemc

EXAMPLE = Path(__file__).resolve().parent / "fourbar_driven.yaml"
NOISE = 0.01  # of the largest torque


def with_accelerations(folder: Path) -> Path:
    """fourbar_driven.yaml with the solved coordinates' accelerations among its outputs."""
    path = folder / "fourbar_driven.yaml"
    path.write_text(EXAMPLE.read_text().replace("  drives: [A]\n",
                                                "  drives: [A]\n  accelerations: true\n"))
    return path


def measured(model: nemc.runtime.Model, w: float) -> tuple[np.ndarray, ...]:
    """One revolution at crank speed w: t, q, qd, qdd (crank, coupler, rocker) and the drive."""
    res = model.simulate((0.0, 2 * np.pi / w), t_eval=np.linspace(0, 2 * np.pi / w, 101),
                         params={"w": w}, rtol=1e-12, atol=1e-13)
    out = res.outputs
    q = np.vstack([out["q1"], res.y[0], res.y[2]])
    qd = np.vstack([out["dot(q1)"], res.y[1], res.y[3]])
    qdd = np.vstack([np.zeros_like(res.t), out["ddot(q2)"], out["ddot(q3)"]])
    return res.t, q, qd, qdd, out["A.drive"]


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        model = nemc.compile(with_accelerations(Path(folder)))
    runs = [measured(model, w) for w in (2 * np.pi, np.pi)]
    t, q, qd, qdd, drive = (np.concatenate(parts, axis=-1) for parts in zip(*runs))
    rng = np.random.default_rng(47)
    sigma = NOISE * np.max(np.abs(drive))
    found = nemc.identify(model, t, q, qd, qdd, drive + rng.normal(0.0, sigma, drive.size))
    print(f"{found.rank} base parameters from {drive.size} torque samples (noise {sigma:.3g} N m)")
    for name, value, err, truth in zip(found.names, found.values, found.stderr, found.expected):
        print(f"  {name:45s} {value:10.5f} ± {err:.5f}  (model {truth:8.5f}, "
              f"{abs(value - truth) / err:.1f} sigma)")


if __name__ == "__main__":
    main()
