"""The derivation: a validated Mechanism -> its Equations (equations.py), symbolically, in the
runtime's symbols: the accelerations by the articulated-body algorithm (articulated.py) or the
book's mass-matrix form (mass_form.py, from the kinematics' Newton-Euler balances:
kinematics.py), the outputs (outputs.py), closed loops (loops.py, assembly.py), the exact
Jacobian (tangent.py), nemc.Taylor's program (taylor.py, products.py, angle_sums.py), the
drawing's points (geometry.py); straight-line programs (program.py) and what their C will cost
(c_cost.py)."""
