"""vegym.physics.vmath: SIMD-friendly sine/cosine and angle wrap against libm and Python's modulo."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from vegym.physics import vmath


@njit
def _sincos_each(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s, c = np.empty(x.size), np.empty(x.size)
    for i in range(x.size):
        s[i], c[i] = vmath.sincos(x[i])
    return s, c


@njit
def _libm_each(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s, c = np.empty(x.size), np.empty(x.size)
    for i in range(x.size):
        s[i], c[i] = math.sin(x[i]), math.cos(x[i])
    return s, c


@njit
def _wraps(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """vmath.wrap_angle and the formula it stands for, ``(a + pi) % 2 pi - pi`` with Python's modulo (fmod)."""
    a, b = np.empty(x.size), np.empty(x.size)
    for i in range(x.size):
        a[i], b[i] = vmath.wrap_angle(x[i]), (x[i] + np.pi) % (2.0 * np.pi) - np.pi
    return a, b


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance in units in the last place between same-signed doubles (or zeros)."""
    return np.abs(a.view(np.int64) - b.view(np.int64))


@pytest.mark.parametrize("bound", [1e-8, np.pi / 4, np.pi, 100.0, 1e6])
def test_sincos_is_within_one_ulp_of_libm(bound: float) -> None:
    x = np.random.default_rng(0).uniform(-bound, bound, 200_000)
    (s, c), (s_ref, c_ref) = _sincos_each(x), _libm_each(x)
    same_sign = (np.sign(s) == np.sign(s_ref)) & (np.sign(c) == np.sign(c_ref))
    assert same_sign.all()
    assert _ulps(s, s_ref).max() <= 1
    assert _ulps(c, c_ref).max() <= 1


def test_sincos_is_exact_at_quadrant_points_and_zero() -> None:
    s, c = _sincos_each(np.array([0.0, -0.0, np.pi / 2, np.pi, -np.pi / 2]))
    assert s[0] == 0.0 and c[0] == 1.0 and math.copysign(1.0, s[1]) == -1.0
    assert c[2] == pytest.approx(0.0, abs=1e-16) and s[2] == 1.0
    assert s[3] == pytest.approx(0.0, abs=2e-16) and c[3] == -1.0
    assert s[4] == -1.0


def test_wrap_angle_equals_python_modulo_within_five_half_turns() -> None:
    rng = np.random.default_rng(1)
    pieces = [rng.uniform(-5 * np.pi, 5 * np.pi, 1_000_000)]
    for m in range(-2, 3):  # around the odd multiples of pi, where the wrap jumps
        edge = (2 * m + 1) * np.pi
        pieces.append(edge + rng.integers(-2000, 2000, 50_000) * np.spacing(edge))
    x = np.concatenate([*pieces, [0.0, -0.0, np.pi, -np.pi, 3 * np.pi, -3 * np.pi]])
    wrapped, reference = _wraps(x)
    np.testing.assert_array_equal(wrapped, reference)
    assert wrapped.min() >= -np.pi and wrapped.max() <= np.pi


def test_wrap_angle_stays_within_an_ulp_of_the_argument_beyond() -> None:
    x = np.random.default_rng(2).uniform(-1e4, 1e4, 100_000)
    wrapped, reference = _wraps(x)
    assert np.all(np.abs(wrapped - reference) <= np.spacing(np.abs(x)))


@njit
def _acos_each(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.empty(x.size), np.empty(x.size)
    for i in range(x.size):
        a[i], b[i] = vmath.acos(x[i]), math.acos(x[i])
    return a, b


def test_acos_is_within_one_ulp_of_libm_and_exact_at_the_ends() -> None:
    rng = np.random.default_rng(3)
    ends = [1.0 - rng.uniform(0.0, 1e-6, 20_000), -1.0 + rng.uniform(0.0, 1e-6, 20_000)]
    edges = [0.5, -0.5, np.nextafter(0.5, 0.0), np.nextafter(-0.5, 0.0), 0.0, -0.0, 1e-300, np.nextafter(1.0, 0.0)]
    x = np.concatenate([rng.uniform(-1.0, 1.0, 500_000), rng.uniform(-1e-9, 1e-9, 10_000), *ends, edges])
    angle, reference = _acos_each(x)
    assert _ulps(angle, reference).max() <= 1
    ends_angle, _ = _acos_each(np.array([1.0, -1.0, 1.5]))
    assert ends_angle[0] == 0.0 and ends_angle[1] == np.pi and np.isnan(ends_angle[2])


@pytest.mark.parametrize(("damping_rate", "omega_squared"), [(0.0, 9.81), (0.05, 9.81), (3.0, 1.0), (1e6, 1e-3)])
def test_stable_step_is_the_root_of_the_semi_implicit_euler_bound(damping_rate: float, omega_squared: float) -> None:
    h = vmath.stable_step(damping_rate, omega_squared)
    assert omega_squared * h * h + 2.0 * damping_rate * h == pytest.approx(4.0, rel=1e-12)


def test_stable_step_neither_cancels_nor_fails_at_extreme_rates() -> None:
    """Strong damping: h -> 2 / damping_rate - omega^2 / damping_rate^3 (the old form's subtraction gave 0 at 1e9);
    overflowing rates give 0 (every step unstable), no restoring force and no damping any step (inf)."""
    assert vmath.stable_step(1e9, 9.81) == pytest.approx(2e-9 - 9.81e-27, rel=1e-15)
    assert vmath.stable_step(1e200, 9.81) == 0.0 and vmath.stable_step(0.0, math.inf) == 0.0
    assert vmath.stable_step(0.0, 0.0) == math.inf
    assert vmath.stable_step(0.0, 4.0) == pytest.approx(1.0, rel=1e-15)
