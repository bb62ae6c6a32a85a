"""A 4-link chain's 12 parameters from 1 %-noise angles of several swings (issue 47's fitting
example): nemc.fit with the exact Jacobian from the runs' sensitivities.

The chain (examples/chain4.yaml) hangs from a torsion-spring pivot; each link has a mass, a
length, a centre of mass c_i along it, an inertia J_i about that centre and a viscous damper
b_i at its joint. Masses are weighed and lengths measured; what a drawing does not give, and
is fitted, is the 4 c_i, the 4 J_i and the 4 b_i. The four joint angles are "measured" at
50 Hz over 2 s in each of four swings from different initial states, with seeded Gaussian
noise of 1 % of each angle's peak-to-peak range in that swing, the weights its 1 / sigma.
The fit starts from the drawing's uniform rods (c = L/2, J = m L^2/12, b = 0.03), within
bounds (a centre on its link, inertias and dampers positive). It prints each estimate with
its standard error, the true value and whether it is within 2 sigma, and the fit's wall time.

Why these 12, and the spring. The angles of a chain on a fixed pivot depend on its inertial
parameters only through 3 base combinations per link, the first moment m_i c_i + L_i (m_i+1
+ ... + m_4), the inertia J_i + m_i c_i^2 + L_i^2 (m_i+1 + ... + m_4) about the joint and
the damper b_i, and scaling all 12 of them by one factor leaves every motion unchanged (a
chain twice as heavy, twice as damped, swings the same). Knowing the masses does not fix
that scale: each c_i, J_i can take up the scaled combinations. Masses, c_i and J_i together
are therefore never identifiable from angles (nemc.fit refuses them, naming them), and
without a known force or torque even (c, J, b) would have rank 11 of 12. The pivot's spring
of known stiffness k is that known torque: with it the 12 base combinations are fixed, and
(c_i, J_i) <-> (first moment, inertia about the joint) is one-to-one for known masses and
lengths, so the 12 parameters are identifiable; the fit reports rank 12.

The design. The swings are large: near hanging, gravity's torque on the first link is almost
linear in its angle, like the spring's, and its first moment is then barely separable from
the spring (swings of 0.6 rad, over 4 s, left c1 and J1 standard errors of 36 % and 50 % of
their values; these give 5 % and 7.5 %). They
are short: one run per swing must follow the data from the start values (no multiple
shooting), and longer swings of the chaotic chain lost their way from the drawing's values.

    python examples/chain4_fit.py
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import nemc

EXAMPLE = Path(__file__).resolve().parent / "chain4.yaml"
NOISE = 0.01  # of each angle's peak-to-peak range in its swing
DURATION, SAMPLES = 2.0, 101  # each swing: 50 Hz over 2 s
ANGLES = ("q1", "q2", "q3", "q4")
FITTED = tuple(f"{kind}{link}" for kind in "cJb" for link in range(1, 5))
SWINGS = (  # each swing's initial angles (released at rest): large, so that gravity's torque
    (-np.pi / 2 + 1.6, -0.5, 0.4, -0.3),  # is far from the spring's linear one
    (-np.pi / 2 - 1.4, 0.7, -0.2, 0.5),
    (-np.pi / 2 + 0.9, 1.0, 0.9, 0.8),
    (-np.pi / 2 - 1.7, -0.6, -0.8, 0.4),
)


def drawing(model: nemc.runtime.Model) -> dict[str, float]:
    """The fit's start: uniform rods (c = L/2, J = m L^2/12) and one guessed damping."""
    p, start = model.parameters, {}
    for link in range(1, 5):
        length, mass = p[f"L{link}"], p[f"m{link}"]
        start |= {f"c{link}": length / 2, f"J{link}": mass * length**2 / 12, f"b{link}": 0.03}
    return start


def bounds(model: nemc.runtime.Model) -> dict[str, tuple[float, float]]:
    """Where each parameter can be: a centre of mass on its link, inertias and dampers > 0."""
    p = model.parameters
    return {f"{kind}{link}": (0.0, p[f"L{link}"] if kind == "c" else 1.0)
            for kind in "cJb" for link in range(1, 5)}


def experiments(model: nemc.runtime.Model, seed: int, swings: int = len(SWINGS)
                ) -> list[nemc.Experiment]:
    """The first SWINGS swings, their angles measured with seeded noise (the weights 1/sigma)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, DURATION, SAMPLES)
    made = []
    for angles in SWINGS[:swings]:
        y0 = np.ravel([(angle, 0.0) for angle in angles])  # q1, dot(q1), q2, ...
        clean = model.simulate((0.0, DURATION), y0, t_eval=t, rtol=1e-12, atol=1e-12).y[::2]
        sigma = NOISE * np.ptp(clean, axis=1)
        data = clean.T + rng.normal(0.0, sigma, clean.T.shape)
        made.append(nemc.Experiment(t, data, y0=y0, weights=1 / sigma))
    return made


def estimate(model: nemc.runtime.Model, seed: int = 47, swings: int = len(SWINGS)
             ) -> nemc.runtime.fitting.FitResult:
    """The 12 parameters fitted to the noisy swings of seed SEED."""
    return nemc.fit(model, fit=FITTED, observed=ANGLES, experiments=experiments(
        model, seed, swings), start=drawing(model), bounds=bounds(model), absolute_sigma=True)


def main() -> None:
    model = nemc.compile(EXAMPLE)
    data = experiments(model, 47)
    began = time.perf_counter()
    found = nemc.fit(model, fit=FITTED, observed=ANGLES, experiments=data,
                     start=drawing(model), bounds=bounds(model), absolute_sigma=True)
    seconds = time.perf_counter() - began
    print(f"{len(FITTED)} parameters from {len(data)} swings x {SAMPLES} times x "
          f"{len(ANGLES)} angles: rank {found.rank}, {found.nfev} runs, rms {found.rms:.3f}")
    print(f"{'name':>4}  {'estimate':>10}  {'stderr':>9}  {'true':>7}  within 2 sigma")
    for name in FITTED:
        value, err, truth = found.values[name], found.stderr[name], model.parameters[name]
        print(f"{name:>4}  {value:10.6f}  {err:9.2e}  {truth:7.4f}  "
              f"{'yes' if abs(value - truth) <= 2 * err else 'NO'} "
              f"({abs(value - truth) / err:.1f} sigma)")
    print(f"fit time {seconds:.2f} s")


if __name__ == "__main__":
    main()
