"""The integration methods nemc accepts: one list, read by the validator (a scene's `method`),
the compiler (which parts a build needs) and the runtime (what `simulate` runs).

Plain constants, no imports: the runtime of a standalone package imports this module too
(nemc/build.py copies it beside the package's `_runtime.py`).
"""

SCIPY_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
# Integrators in the model's own C (templates/integrators.c.tmpl), no Python in the loop.
NATIVE_METHODS = ("nemc.DOP853", "nemc.Radau", "nemc.Vern9", "nemc.Taylor")
METHODS = SCIPY_METHODS + NATIVE_METHODS
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA", "nemc.Radau")  # these get the analytic Jacobian
TAYLOR_METHODS = ("nemc.Taylor",)  # these need the build's Taylor coefficients
DEFAULT_METHOD = "nemc.DOP853"
