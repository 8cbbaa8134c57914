"""Sine, cosine and angle wrapping as branch-free numba code, so that a kernel's loop over a batch compiles to SIMD
instructions (libm's ``sin``/``cos``/``fmod`` are calls that keep a loop scalar: numba here has no vector math
library).

:func:`sincos` is fdlibm's method (the kernels of musl's ``__sin``/``__cos`` after a two-round Cody-Waite
reduction by pi/2): within 1 ulp of libm's ``sin``/``cos`` (they differ in about 3% of arguments) for
``|x| <= 1e6`` rad, and beyond that less accurate (the reduction keeps about ``2^-33 |x|`` ulp): the envs pass
angles of at most a few turns. Results are a pure function of the argument, the same in a batch and alone.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00  # the first 33 bits of pi/2
_PIO2_2 = 6.07710050630396597660e-11  # the next 33 bits
_PIO2_2T = 2.02226624879595063154e-21  # pi/2 - _PIO2_1 - _PIO2_2
_TO_INTEGER = 1.5 / np.finfo(np.float64).eps  # (x + _TO_INTEGER) - _TO_INTEGER rounds x to an integer
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_TWO_PI = 2.0 * np.pi


@njit(cache=True, inline="always", error_model="numpy")
def sincos(x: float) -> tuple[float, float]:
    """``(sin x, cos x)`` of an angle x (rad), within 1 ulp of libm for ``|x| <= 1e6``."""
    quadrants = (x * _INV_PIO2 + _TO_INTEGER) - _TO_INTEGER  # nearest multiple of pi/2
    n = np.int64(quadrants)
    t = x - quadrants * _PIO2_1
    w = quadrants * _PIO2_2
    r = t - w
    w = quadrants * _PIO2_2T - ((t - r) - w)
    y = r - w  # x - n pi/2 = y + tail, |y| <= pi/4
    tail = (r - y) - w
    z = y * y
    v = z * y
    s_poly = _S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))
    sine = y - ((z * (0.5 * tail - v * s_poly) - tail) - v * _S1)
    c_poly = z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    half_z = 0.5 * z
    one_minus = 1.0 - half_z
    cosine = one_minus + (((1.0 - one_minus) - half_z) + (z * c_poly - y * tail))
    odd = (n & 1) != 0
    s = cosine if odd else sine
    c = sine if odd else cosine
    s = -s if (n & 2) != 0 else s
    c = -c if ((n + 1) & 2) != 0 else c
    return s, c


@njit(cache=True, inline="always", error_model="numpy")
def wrap_angle(angle: float) -> float:
    """``angle`` (rad) wrapped into ``[-pi, pi]`` as ``(angle + pi) mod 2 pi - pi``, with a floor instead of
    ``fmod``: bit for bit Python's ``%`` (hence ``wheel.wrap_one``) for ``|angle| < 5 pi``; beyond, within an ulp
    of ``angle``."""
    shifted = angle + np.pi
    rest = shifted - _TWO_PI * np.floor(shifted / _TWO_PI)
    rest = rest + _TWO_PI if rest < 0.0 else rest  # the quotient rounded up to an integer
    return rest - np.pi
