"""The base parameters' names in the model's own parameters: "link1.I + L1**2*link2.m".

A base parameter regroups dependent columns of Y into a kept one with coefficients beta that
depend on the geometry (regressor.base_parameters finds them as numbers at the parameters'
values). Where a coefficient is a monomial c * prod p_k^e_k of the parameters (the usual case:
a link's length, its square), it is found by scaling each parameter in turn and finding beta
again from the same samples: the ratio is FACTOR^e_k, e_k an integer, and c a small fraction.
A coefficient that is not (a sum, a ratio of sums) keeps its number; so does a column whose
dependence scaling a parameter breaks, and every coefficient where the regressor fails there.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from fractions import Fraction

import numpy as np

FACTOR = 1.25  # each parameter scaled by this in turn
EXPONENT_TOLERANCE = 1e-6  # from an integer
CONSTANT_TOLERANCE = 1e-9  # relative, from a fraction of denominator at most MAX_DENOMINATOR
MAX_DENOMINATOR = 100
DEPENDENCE_TOLERANCE = 1e-8  # relative residual of the dependent columns in the kept ones

Restack = Callable[[np.ndarray], np.ndarray]  # p -> Y stacked over the same samples


def coefficient_texts(combination: np.ndarray, independent: Sequence[int], restack: Restack,
                      p: np.ndarray, parameter_names: Sequence[str]) -> dict[tuple[int, int], str]:
    """(base row, phi column) -> the coefficient's magnitude as a monomial of the parameters,
    for the coefficients that are one (module docstring); empty where scaling a parameter
    makes the regressor fail."""
    dependent = [k for k in range(combination.shape[1])
                 if k not in independent and np.any(combination[:, k] != 0.0)]
    if not dependent:
        return {}
    reference = combination[:, dependent]
    exponents = np.zeros((len(parameter_names), *reference.shape))
    for k in range(len(parameter_names)):
        if p[k] == 0.0:
            continue
        scaled = np.array(p, dtype=float)
        scaled[k] *= FACTOR
        beta = dependence(restack, scaled, list(independent), dependent)
        if beta is None:
            return {}
        with np.errstate(divide="ignore", invalid="ignore"):
            exponents[k] = np.log(beta / reference) / math.log(FACTOR)  # nan: broken
    texts = {}
    for i, j in zip(*np.nonzero(reference)):
        text = monomial_text(reference[i, j], exponents[:, i, j], p, parameter_names)
        if text is not None:
            texts[int(i), dependent[j]] = text
    return texts


def dependence(restack: Restack, p: np.ndarray, kept: list[int], dependent: list[int]
               ) -> np.ndarray | None:
    """beta with Y[:, dependent] = Y[:, kept] beta at P, a column of nan where that does not
    hold (a closed loop's samples, off its constraints at other lengths, lose dependences the
    motion made); None where the regressor fails at P."""
    try:
        stacked = restack(p)
    except ValueError:
        return None
    beta = np.linalg.lstsq(stacked[:, kept], stacked[:, dependent], rcond=None)[0]
    misfit = np.linalg.norm(stacked[:, kept] @ beta - stacked[:, dependent], axis=0)
    scale = np.linalg.norm(stacked[:, dependent], axis=0) + 1e-300
    beta[:, misfit > DEPENDENCE_TOLERANCE * scale] = np.nan
    return beta


def monomial_text(value: float, exponents: np.ndarray, p: np.ndarray,
                  parameter_names: Sequence[str]) -> str | None:
    """|VALUE| as "L1**2", "1/3*L1*L2", "L1/L0", or None when it is no monomial."""
    if not np.all(np.isfinite(exponents)):
        return None
    powers = np.round(exponents)
    if np.any(np.abs(exponents - powers) > EXPONENT_TOLERANCE):
        return None
    constant = abs(value) / math.prod(abs(p[k]) ** powers[k] for k in range(len(powers)))
    fraction = Fraction(constant).limit_denominator(MAX_DENOMINATOR)
    if fraction == 0 or abs(float(fraction) - constant) > CONSTANT_TOLERANCE * constant:
        return None
    above = [power_text(name, int(e)) for name, e in zip(parameter_names, powers) if e > 0]
    below = [power_text(name, -int(e)) for name, e in zip(parameter_names, powers) if e < 0]
    if fraction.numerator != 1 or not above:
        above.insert(0, str(fraction.numerator))
    if fraction.denominator != 1:
        below.insert(0, str(fraction.denominator))
    text = "*".join(above)
    if below:
        text += "/" + (below[0] if len(below) == 1 else "(" + "*".join(below) + ")")
    return text


def power_text(name: str, power: int) -> str:
    return name if power == 1 else f"{name}**{power}"
