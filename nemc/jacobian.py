"""The Jacobian of the right-hand side, derived without inverting M symbolically.

With qdd = M(q)^-1 f(t, q, dq), differentiating M qdd = f gives
    M d qdd/d q = d f/d q - d(M qdd)/d q  (qdd held fixed)  =: R
    M d qdd/d dq = d f/d dq                                  =: S
This stage returns R (in terms of the acceleration symbols) and S; the generated C evaluates
them at the accelerations it has just solved for and reuses the LDL^T factors of M.
"""

from __future__ import annotations

import dataclasses

import sympy

from .derive import Equations


def with_jacobian(eqs: Equations) -> Equations:
    qdd = sympy.Matrix(eqs.accelerations)
    q, u = sympy.Matrix(eqs.coordinates), sympy.Matrix(eqs.speeds)
    r = eqs.forcing.jacobian(q) - (eqs.mass_matrix * qdd).jacobian(q)
    s = eqs.forcing.jacobian(u)
    return dataclasses.replace(eqs, jacobian=(r, s))
