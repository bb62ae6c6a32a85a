"""The driven four-bar's inertial parameters from its drive torque (issue 47's regressor example).

The crank of examples/fourbar_driven.yaml is driven here at an uneven speed, q1 = pi/2 + w t +
0.4 sin(w t), so that it accelerates; the motor's torque A.drive over one revolution is
"measured" at 401 times with 1 % noise (seeded), and the base parameters (the combinations of
the bodies' masses, first moments and inertias the torque identifies) are estimated by linear
least squares on tau = Y(q, qd, qdd) phi - Q, with standard errors. Each estimate is printed
with the model's own value and how many standard errors apart they are.

    python examples/fourbar_regressor.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

import nemc

EXAMPLE = Path(__file__).resolve().parent / "fourbar_driven.yaml"
NOISE = 0.01  # of the largest torque
WOBBLE = 0.4  # the crank's angle, beyond w t: WOBBLE sin(w t)
SAMPLES = 401  # over the revolution


def uneven_fourbar(folder: Path) -> Path:
    """fourbar_driven.yaml with the uneven crank motion and the solved coordinates'
    accelerations among its outputs."""
    text = EXAMPLE.read_text().replace("motion: pi/2 + w*t}",
                                       f"motion: pi/2 + w*t + {WOBBLE}*sin(w*t)}}")
    path = folder / "fourbar_uneven.yaml"
    path.write_text(text.replace("  drives: [A]\n", "  drives: [A]\n  accelerations: true\n"))
    return path


def measured(model: nemc.runtime.Model) -> tuple[np.ndarray, ...]:
    """One revolution: t, q, qd, qdd (crank, coupler, rocker) and the drive, exact."""
    res = model.simulate(t_eval=np.linspace(0.0, 1.0, SAMPLES), rtol=1e-12, atol=1e-13)
    out, w = res.outputs, model.parameters["w"]
    q = np.vstack([out["q1"], res.y[0], res.y[2]])
    qd = np.vstack([out["dot(q1)"], res.y[1], res.y[3]])
    crank = -WOBBLE * w**2 * np.sin(w * res.t)  # the motion's second derivative
    qdd = np.vstack([crank, out["ddot(q2)"], out["ddot(q3)"]])
    return res.t, q, qd, qdd, out["A.drive"]


def estimate(seed: int = 47) -> tuple[nemc.runtime.regressor.Identification, float, int]:
    """(the estimate from noisy torque, the noise's sigma, the samples)."""
    with tempfile.TemporaryDirectory() as folder:
        model = nemc.compile(uneven_fourbar(Path(folder)))
    t, q, qd, qdd, drive = measured(model)
    sigma = NOISE * np.max(np.abs(drive))
    noisy = drive + np.random.default_rng(seed).normal(0.0, sigma, drive.size)
    return nemc.identify(model, t, q, qd, qdd, noisy), sigma, drive.size


def main() -> None:
    found, sigma, count = estimate()
    print(f"{found.rank} base parameters from {count} torque samples (noise {sigma:.3g} N m)")
    for name, value, err, truth in zip(found.names, found.values, found.stderr, found.expected):
        print(f"  {name:50s} {value:9.5f} ± {err:.5f}  (model {truth:8.5f}, "
              f"{abs(value - truth) / err:.1f} sigma)")


if __name__ == "__main__":
    main()
