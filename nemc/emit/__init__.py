"""Emission: the Equations -> C source, header (which is also the cffi declarations) and the
runtime's metadata, from the templates (resources.py reads them). Rewrites before printing
(optimize.py), the C text of expressions (c_text.py), the right-hand side's sines and cosines
together (angles.py), the units of what a model reports (units.py)."""
