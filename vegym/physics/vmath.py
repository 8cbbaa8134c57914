"""Math shared by the models: sine, cosine, arccosine and angle wrapping as branch-free numba code, so that a
kernel's loop over a batch compiles to SIMD instructions (libm's ``sin``/``cos``/``acos``/``fmod`` are calls that
keep a loop scalar: numba here has no vector math library).

:func:`sincos` is fdlibm's method (the kernels of musl's ``__sin``/``__cos`` after a two-round Cody-Waite
reduction by pi/2): within 1 ulp of libm's ``sin``/``cos`` (they differ in about 3% of arguments) for
``|x| <= 1e6`` rad, and beyond that less accurate (the reduction keeps about ``2^-33 |x|`` ulp): the envs pass
angles of at most a few turns. :func:`acos` is fdlibm's rational approximation, also within 1 ulp of libm.
Results are a pure function of the argument, the same in a batch and alone. The kernels inline these functions
and numba's on-disk cache does not notice a change here: delete the ``__pycache__`` folders after editing.
:func:`stable_step` is the step bound of semi-implicit Euler on a damped oscillator.
"""

from __future__ import annotations

import math

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
_PIO2_HI, _PIO2_LO = 1.57079632679489655800e00, 6.12323399573676603587e-17  # pi/2 = _PIO2_HI + _PIO2_LO
_P0, _P1, _P2 = 1.66666666666666657415e-01, -3.25565818622400915405e-01, 2.01212532134862925881e-01
_P3, _P4, _P5 = -4.00555345006794114027e-02, 7.91534994289814532176e-04, 3.47933107596021167570e-05
_Q1, _Q2 = -2.40339491173441421878e00, 2.02094576023350569471e00
_Q3, _Q4 = -6.88283971605453293030e-01, 7.70381505559019352791e-02
_SPLIT = 134217729.0  # 2^27 + 1: Veltkamp's split of a double into two halves whose squares are exact


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


@njit(cache=True, inline="always", error_model="numpy")
def acos(x: float) -> float:
    """``arccos x`` (rad) of ``x`` in [-1, 1] (NaN outside), within 1 ulp of libm: fdlibm's ``pi/2 - asin``
    for ``|x| < 1/2`` and ``2 asin(sqrt((1 -+ x) / 2))`` beyond, all three computed and one selected."""
    small = abs(x) < 0.5
    z = (1.0 - abs(x)) * 0.5
    w = x * x if small else z
    ratio = (w * (_P0 + w * (_P1 + w * (_P2 + w * (_P3 + w * (_P4 + w * _P5)))))) / (
        1.0 + w * (_Q1 + w * (_Q2 + w * (_Q3 + w * _Q4)))
    )
    s = math.sqrt(z)
    central = _PIO2_HI - (x - (_PIO2_LO - x * ratio))
    negative = 2.0 * (_PIO2_HI - (s + (ratio * s - _PIO2_LO)))
    split = _SPLIT * s
    head = split - (split - s)  # s to 26 bits: head * head is exact
    tail = (z - head * head) / (s + head if s > 0.0 else 1.0)  # no 0/0 at x = 1, whatever the error model
    positive = 2.0 * (head + (ratio * s + tail))
    angle = central if small else (negative if x < 0.0 else positive)
    angle = 0.0 if x == 1.0 else angle
    return 2.0 * _PIO2_HI if x == -1.0 else angle


def stable_step(damping_rate: float, omega_squared: float) -> float:
    """Largest step h (s) at which semi-implicit Euler keeps ``x'' = -omega^2 x - damping_rate x'`` from growing:
    the positive root of ``omega^2 h^2 + 2 damping_rate h = 4``, written ``4 / (damping_rate + sqrt(damping_rate^2 +
    4 omega^2))`` (no cancellation for strong damping; 0 if either rate overflows, inf without either)."""
    root = math.sqrt(damping_rate * damping_rate + 4.0 * omega_squared) + damping_rate
    return 4.0 / root if root > 0.0 else math.inf
