"""Simple pendulum (PHYSICS.md section 7): elliptic-integral period, bounded energy, energy pumping."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

from vegym.physics import pendulum
from vegym.physics.pendulum import PendulumParams

FREE = PendulumParams(damping=0.0)
ENERGY_CHECK = PendulumParams(length=2.0, mass=1.0, damping=0.0)
"""The section 7 energy check: 60 deg release, E0 = m g L (1 - cos 60 deg) = 9.81 J."""


def test_the_pendulum_falls_back_toward_the_vertical_both_printed_sign_errors_fixed() -> None:
    theta = np.array([0.3, -0.3, 0.0])
    a = pendulum.angular_acceleration(theta, np.zeros(3), 0.0, FREE)
    np.testing.assert_allclose(a, -9.81 * np.sin(theta), rtol=1e-15)
    new_theta, new_omega = pendulum.step(theta, np.zeros(3), 0.0, 0.01, FREE)
    np.testing.assert_allclose(new_omega, 0.01 * a, rtol=1e-15)
    np.testing.assert_allclose(new_theta, theta + 0.01 * new_omega, rtol=1e-15)  # d' = d + v' dt
    torqued = pendulum.angular_acceleration(np.zeros(1), np.full(1, 2.0), 1.5, PendulumParams(mass=2.0, damping=0.1))
    assert torqued[0] == pytest.approx((1.5 - 0.1 * 2.0) / 2.0, rel=1e-15)


def test_period_matches_the_elliptic_integral_to_4_digits_from_5_to_150_degrees() -> None:
    """``T = 4 sqrt(L/g) K(m)`` with scipy's parameter ``m = sin^2(theta0 / 2)``; the period is the mean spacing of the
    upward zero crossings (interpolated) over three swings from rest at theta0, dt = 1e-3."""
    amplitudes = np.radians([5.0, 14.0, 60.0, 150.0])
    exact = 4.0 * math.sqrt(FREE.length / FREE.gravity) * ellipk(np.sin(amplitudes / 2.0) ** 2)
    dt = 1e-3
    theta, omega = amplitudes.copy(), np.zeros(4)
    crossings: list[list[float]] = [[] for _ in amplitudes]
    for i in range(int(3.3 * exact.max() / dt)):
        new_theta, omega = pendulum.step(theta, omega, 0.0, dt, FREE)
        for k in np.flatnonzero((theta < 0.0) & (new_theta >= 0.0)):
            crossings[k].append((i + theta[k] / (theta[k] - new_theta[k])) * dt)
        theta = new_theta
    periods = np.array([np.mean(np.diff(times)) for times in crossings])
    assert all(len(times) >= 3 for times in crossings)
    np.testing.assert_allclose(periods, exact, rtol=1e-5)
    small_angle_error = exact / FREE.small_angle_period - 1.0
    np.testing.assert_allclose(small_angle_error, [0.0005, 0.0037, 0.073, 0.76], rtol=0.05)
    np.testing.assert_array_equal(pendulum.period(amplitudes, FREE), exact)


def test_the_exact_period_starts_at_the_small_angle_period_and_grows_without_bound() -> None:
    """T(0) = T0 exactly; ``T = T0 (1 + theta0^2 / 16 + 11 theta0^4 / 3072 + ...)`` for small swings; infinite at pi
    (the inverted balance); amplitudes outside [0, pi] raise."""
    assert pendulum.period(0.0, FREE) == FREE.small_angle_period
    small = np.array([1e-3, 1e-2, 0.1])
    series = FREE.small_angle_period * (1.0 + small**2 / 16.0 + 11.0 * small**4 / 3072.0)
    np.testing.assert_allclose(pendulum.period(small, FREE), series, rtol=1e-7)
    assert pendulum.period(math.pi, FREE) == math.inf
    assert np.all(np.diff(pendulum.period(np.linspace(0.0, 3.0, 50), FREE)) > 0.0)
    for bad in (-0.1, 3.2, math.nan):
        with pytest.raises(ValueError, match=r"amplitude=.*\[0, 3.14159\]"):
            pendulum.period(bad, FREE)


def run(params: PendulumParams, explicit: bool, dt: float = 0.01, steps: int = 6000) -> np.ndarray:
    """Energies (steps + 1,) from rest at 60 deg without torque; semi-implicit or explicit Euler."""
    theta, omega = np.radians([60.0]), np.zeros(1)
    energies = [pendulum.energy(theta, omega, params)[0]]
    for _ in range(steps):
        if explicit:
            a = pendulum.angular_acceleration(theta, omega, 0.0, params)
            theta, omega = theta + dt * omega, omega + dt * a
        else:
            theta, omega = pendulum.step(theta, omega, 0.0, dt, params)
        energies.append(pendulum.energy(theta, omega, params)[0])
    return np.array(energies)


def test_semi_implicit_energy_stays_bounded_without_drift_while_explicit_euler_grows() -> None:
    energy = run(ENERGY_CHECK, explicit=False)
    assert energy[0] == pytest.approx(9.81, rel=1e-14)
    assert (energy.min(), energy.max()) == (pytest.approx(9.709, abs=1e-3), pytest.approx(9.913, abs=1e-3))
    assert abs(energy[-1000:].mean() - energy[:1000].mean()) < 1e-3 * energy[0]
    assert run(ENERGY_CHECK, explicit=True).max() == pytest.approx(43.1, abs=0.1)


def test_amplitude_and_energy_convert_both_ways() -> None:
    amplitudes = np.linspace(0.0, np.pi, 13)
    energies = pendulum.amplitude_energy(amplitudes, FREE)
    np.testing.assert_allclose(pendulum.energy_amplitude(energies, FREE), amplitudes, atol=1e-7)
    np.testing.assert_allclose(energies[-1], 2.0 * FREE.weight_moment)
    np.testing.assert_array_equal(pendulum.energy_amplitude(np.array([-1.0, 30.0]), FREE), [0.0, np.pi])


def test_pump_torque_power_has_the_sign_of_the_energy_error_and_is_saturated() -> None:
    rng = np.random.default_rng(0)
    theta, omega = rng.uniform(-np.pi, np.pi, 500), rng.uniform(-6.0, 6.0, 500)
    target = rng.uniform(0.0, np.pi, 500)
    torque = pendulum.pump_torque(theta, omega, target, 2.0, 1.0, FREE)
    error = pendulum.amplitude_energy(target, FREE) - pendulum.energy(theta, omega, FREE)
    assert np.all(torque * omega * error >= 0.0) and np.all(np.abs(torque) <= 1.0)
    assert np.any(np.abs(torque) == 1.0) and np.any((np.abs(torque) < 1.0) & (torque != 0.0))


@pytest.mark.parametrize("target_degrees", [45.0, 120.0, 10.0])
def test_energy_pumping_reaches_the_target_amplitude_with_a_weak_damped_torque(target_degrees: float) -> None:
    """Section 7: with b = 0.05 N m s and tau_max = 1 N m against m g L = 9.81 J, pumping reaches the target swing
    (the printed check reached 44.5 deg of 45 with a smaller gain) from a 30 deg swing, up or down, to 2 deg."""
    params = PendulumParams(damping=0.05)
    target = np.radians([target_degrees])
    theta, omega, dt = np.radians([30.0]), np.zeros(1), 0.01
    amplitudes = []
    for _ in range(3000):
        torque = pendulum.pump_torque(theta, omega, target, 2.0, 1.0, params)
        theta, omega = pendulum.step(theta, omega, torque, dt, params)
        amplitudes.append(pendulum.energy_amplitude(pendulum.energy(theta, omega, params), params)[0])
    assert np.degrees(np.abs(np.array(amplitudes[-500:]) - target[0])).max() < 2.0


def test_max_stable_step_is_the_linear_stability_limit_about_the_hanging_position() -> None:
    params = PendulumParams(damping=0.5)
    h = params.max_stable_step()
    assert (params.gravity / params.length) * h * h + 2.0 * (0.5 / params.inertia) * h == pytest.approx(4.0)
    final, largest = [], []
    for dt in (0.95 * h, 1.05 * h):
        theta, omega = np.array([1e-3]), np.zeros(1)
        swing = [theta[0]]
        for _ in range(2000):
            theta, omega = pendulum.step(theta, omega, 0.0, dt, params)
            swing.append(theta[0])
        final.append(abs(swing[-1]))
        largest.append(np.max(np.abs(swing)))
    assert final[0] < 1e-9 and largest[1] > 0.1  # decays just below the bound, grows 100-fold just above it
