"""The branch-free math the generated C carries, over one GCC vector type each: sin and cos
(templates/sincos.c.tmpl: the right-hand side's angles, two at a time, and nemc.Taylor's), and
nemc.Taylor's sin, cos, log2 and exp2 (templates/taylor_math.c.tmpl), whose scalar code and
SIMD lanes compute the same bits.
"""

from __future__ import annotations

from .printing import template

KERNEL_INLINE = "static inline __attribute__((always_inline))"


def sincos_kernel(prefix: str, vector: str, bits: str, what: str) -> str:
    """The branch-free sin and cos (templates/sincos.c.tmpl) over one GCC vector type."""
    return template("sincos.c.tmpl").substitute(prefix=prefix, vec=vector, bits=bits, what=what,
                                                inline=KERNEL_INLINE)


def taylor_math(prefix: str, vector: str, bits: str, what: str) -> str:
    """nemc.Taylor's sin, cos, log2 and exp2 (templates/taylor_math.c.tmpl) over one GCC vector
    type: the scalar code's one-element vectors and the SIMD lanes' compute the same bits."""
    return template("taylor_math.c.tmpl").substitute(
        prefix=prefix, vec=vector, bits=bits, what=what, inline=KERNEL_INLINE,
        sincos=sincos_kernel(prefix, vector, bits, what))
