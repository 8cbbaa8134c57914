"""Spring-mass and quarter-car (PHYSICS.md section 8) against closed forms: period, rest, energy, transmissibility."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from vegym.physics import suspension
from vegym.physics.suspension import SpringParams

CHECK = SpringParams(mass=2.0, modulus=80.0, natural_length=1.0)
"""The section 8 check parameters: k = 80 N/m, omega_n = sqrt(40) rad/s; with c = 2 N s/m, zeta = 1 / sqrt(160)."""
DAMPING = 2.0


def free_motion(y0: np.ndarray, damping: float, dt: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Heights and velocities (steps + 1, n) on a level base at rest, released at rest from ``y0``."""
    y, v = np.asarray(y0, dtype=np.float64), np.zeros(len(y0))
    heights, velocities = [y], [v]
    for _ in range(steps):
        y, v, _ = suspension.step(y, v, 0.0, 0.0, damping, dt, CHECK)
        heights.append(y)
        velocities.append(v)
    return np.array(heights), np.array(velocities)


def upward_crossings(values: np.ndarray, dt: float) -> np.ndarray:
    """Times (s) at which ``values`` (steps + 1,) crosses zero upward, linearly interpolated between samples."""
    k = np.flatnonzero((values[:-1] < 0.0) & (values[1:] >= 0.0))
    return (k + values[k] / (values[k] - values[k + 1])) * dt


def test_derived_values_are_the_closed_forms() -> None:
    assert CHECK.stiffness == 80.0
    assert CHECK.period == pytest.approx(2.0 * math.pi * math.sqrt(2.0 * 1.0 / 80.0), rel=1e-15)
    assert CHECK.period == pytest.approx(0.99346, abs=5e-6)
    assert CHECK.static_length == pytest.approx(1.0 - 2.0 * 9.81 / 80.0, rel=1e-15)
    beta, w2 = DAMPING / CHECK.mass, CHECK.stiffness / CHECK.mass
    h = CHECK.max_stable_step(DAMPING)
    assert w2 * h * h + 2.0 * beta * h == pytest.approx(4.0, rel=1e-12)


def test_stiffness_is_the_modulus_over_the_natural_length() -> None:
    """``k = lambda / l`` (8.89): CHECK's l = 1 m cannot tell it from ``k = lambda``."""
    spring = SpringParams(mass=2.0, modulus=80.0, natural_length=0.4)
    assert spring.stiffness == pytest.approx(200.0, rel=1e-15)
    assert spring.period == pytest.approx(2.0 * math.pi * math.sqrt(2.0 * 0.4 / 80.0), rel=1e-15)
    assert spring.static_length == pytest.approx(0.4 - 2.0 * 9.81 / 200.0, rel=1e-15)


@pytest.mark.parametrize("amplitude", [0.01, 0.2])
def test_free_oscillation_has_period_2_pi_sqrt_m_l_over_lambda_about_the_static_length(amplitude: float) -> None:
    dt = 1e-3
    heights, _ = free_motion(np.array([CHECK.static_length + amplitude]), 0.0, dt, 6000)
    deflection = heights[:, 0] - CHECK.static_length
    periods = np.diff(upward_crossings(deflection, dt))
    assert len(periods) == 5
    np.testing.assert_allclose(periods, CHECK.period, rtol=1e-5)
    whole = int(round(5 * CHECK.period / dt))
    assert np.mean(heights[:whole, 0]) == pytest.approx(CHECK.static_length, abs=1e-4 * amplitude)


def test_damped_mass_comes_to_rest_at_l_minus_m_g_over_k() -> None:
    heights, velocities = free_motion(np.array([1.0, 0.3, 1.6]), DAMPING, 0.01, 6000)
    np.testing.assert_allclose(heights[-1], 1.0 - 2.0 * 9.81 / 80.0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(velocities[-1], 0.0, atol=1e-10)


def test_energy_is_bounded_without_damping_and_explicit_euler_would_grow() -> None:
    dt, steps = 0.01, 6000
    heights, velocities = free_motion(np.array([CHECK.static_length + 0.2]), 0.0, dt, steps)
    energy = suspension.energy(heights[:, 0], velocities[:, 0], 0.0, CHECK)
    swing = 0.5 * CHECK.stiffness * 0.2**2
    assert np.max(np.abs(energy - energy[0])) < 0.05 * swing
    first, last = energy[: steps // 10], energy[-steps // 10 :]
    assert abs(np.mean(last) - np.mean(first)) < 1e-3 * swing
    y, v = np.array([CHECK.static_length + 0.2]), np.zeros(1)
    for _ in range(steps):
        a = suspension.acceleration(y, v, 0.0, 0.0, 0.0, CHECK)
        y, v = y + dt * v, v + dt * a
    assert suspension.energy(y, v, 0.0, CHECK)[0] - energy[0] > 10.0 * swing


def transfer_matrices(dt: float, params: SpringParams, damping: float) -> tuple[np.ndarray, np.ndarray]:
    """The step's linear part: ``x' - x_eq = M (x - x_eq) + N (y_b, v_b)`` for x = (y, v), column by column.

    The step is affine in (y, v, y_b, v_b), so unit perturbations from the rest state give M and N exactly up to
    rounding; checked against a second perturbation size.
    """
    rest = np.array([params.static_length, 0.0, 0.0, 0.0])

    def advance(z: np.ndarray) -> np.ndarray:
        y, v, _ = suspension.step(z[:, 0], z[:, 1], z[:, 2], z[:, 3], damping, dt, params)
        return np.stack([y, v], axis=-1)

    columns = []
    for scale in (1e-3, 1.0):
        z = rest + scale * np.eye(4)
        columns.append((advance(z) - advance(rest[None])) / scale)
    np.testing.assert_allclose(columns[0], columns[1], rtol=1e-7, atol=1e-12)
    return columns[1][:2].T, columns[1][2:].T


def discrete_transmissibility(omega: float, dt: float, params: SpringParams, damping: float) -> float:
    """Steady-state amplitude ratio of the simulation itself under ``y_b = sin(omega t)``: with ``z = e^{i omega dt}``
    and the body following ``X z^k``, ``X = (z I - M)^-1 N (1, i omega)``."""
    m, n = transfer_matrices(dt, params, damping)
    z = np.exp(1j * omega * dt)
    response = np.linalg.solve(z * np.eye(2) - m, n @ np.array([1.0, 1j * omega]))
    return float(abs(response[0]))


def test_closed_form_transmissibility_gives_the_quoted_values() -> None:
    ratios = np.array([0.5, 1.0, 2.0]) * CHECK.natural_frequency
    np.testing.assert_allclose(
        suspension.transmissibility(ratios, DAMPING, CHECK), [1.3301, 6.4031, 0.3477], rtol=0, atol=5e-5
    )
    assert suspension.transmissibility(0.0, DAMPING, CHECK) == 1.0
    zeta = DAMPING / (2.0 * math.sqrt(CHECK.stiffness * CHECK.mass))
    resonance = suspension.transmissibility(CHECK.natural_frequency, DAMPING, CHECK)
    assert resonance == pytest.approx(math.sqrt(1.0 + (2.0 * zeta) ** 2) / (2.0 * zeta), rel=1e-14)


@pytest.mark.parametrize(("ratio", "quoted"), [(0.5, 1.3301), (1.0, 6.4031), (2.0, 0.3477)])
def test_steady_state_amplitude_of_the_simulation_is_the_transmissibility_to_4_digits(
    ratio: float, quoted: float
) -> None:
    omega = ratio * CHECK.natural_frequency
    simulated = discrete_transmissibility(omega, 1e-5, CHECK, DAMPING)
    assert round(simulated, 4) == quoted
    coarse = discrete_transmissibility(omega, 1e-3, CHECK, DAMPING)
    assert abs(coarse - quoted) < 1e-3 * quoted  # first order in dt: 2.5e-4 at worst


def test_long_sinusoidal_drive_settles_to_the_computed_steady_state_amplitude() -> None:
    """Brute force at dt = 1e-3: 30 s from rest (the transient decays as e^{-t/2}), then a least-squares fit of
    sin, cos and a constant at the drive frequency over the last 8 s."""
    dt, amplitude = 1e-3, 0.01
    omega = np.array([0.5, 1.0, 2.0]) * CHECK.natural_frequency
    y, v = np.full(3, CHECK.static_length), np.zeros(3)
    steps, window = 30_000, 8_000
    record = np.empty((window, 3))
    for i in range(steps):
        t = i * dt
        y, v, _ = suspension.step(
            y, v, amplitude * np.sin(omega * t), amplitude * omega * np.cos(omega * t), DAMPING, dt, CHECK
        )
        if i >= steps - window:
            record[i - (steps - window)] = y
    times = (np.arange(steps - window, steps) + 1) * dt
    for k, w in enumerate(omega):
        basis = np.stack([np.sin(w * times), np.cos(w * times), np.ones(window)], axis=-1)
        coefficients = np.linalg.lstsq(basis, record[:, k], rcond=None)[0]
        measured = math.hypot(coefficients[0], coefficients[1]) / amplitude
        assert measured == pytest.approx(discrete_transmissibility(w, dt, CHECK, DAMPING), rel=1e-5)
        assert measured == pytest.approx(float(suspension.transmissibility(w, DAMPING, CHECK)), rel=1e-3)


def test_terrain_slope_is_the_derivative_of_its_height() -> None:
    rng = np.random.default_rng(0)
    amplitude, wavenumber, phase = rng.uniform(0, 0.1, (5, 3)), rng.uniform(0.2, 4.0, (5, 3)), rng.uniform(0, 6, (5, 3))
    x, h = rng.uniform(0, 50, 5), 1e-6
    _, slope = suspension.terrain(x, amplitude, wavenumber, phase)
    above, _ = suspension.terrain(x + h, amplitude, wavenumber, phase)
    below, _ = suspension.terrain(x - h, amplitude, wavenumber, phase)
    np.testing.assert_allclose(slope, (above - below) / (2 * h), rtol=1e-7, atol=1e-9)


def test_skyhook_is_stiff_exactly_when_the_damper_force_opposes_the_body_velocity() -> None:
    body = np.array([1.0, 1.0, -1.0, -1.0, 0.0, 0.5])
    relative = np.array([0.5, -0.5, -2.0, 2.0, 1.0, 0.0])
    c = suspension.skyhook_damping(body, relative, 0.5, 20.0)
    np.testing.assert_array_equal(c, [20.0, 0.5, 20.0, 0.5, 0.5, 0.5])
    force = -c * relative
    assert np.all((force * body < 0) == (c == 20.0))


ROAD_AMPLITUDE = 0.05
"""Amplitude of the section 8 check's sinusoidal road (m)."""


def rms_on_sinusoidal_road(omega: np.ndarray, damping: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
    """RMS body acceleration (m/s^2) of CHECK over a road ``ROAD_AMPLITUDE sin(omega t)`` (one row per omega,
    rad/s), in the last 5 s of 20 s at dt = 1e-3 s, with the damper coefficient ``damping(v, v - v_b)`` (N s/m)."""
    dt, steps, window = 1e-3, 20_000, 5_000
    y, v = np.full(len(omega), CHECK.static_length), np.zeros(len(omega))
    squares = np.zeros(len(omega))
    for i in range(steps):
        t = i * dt
        base, base_velocity = ROAD_AMPLITUDE * np.sin(omega * t), ROAD_AMPLITUDE * omega * np.cos(omega * t)
        y, v, a = suspension.step(y, v, base, base_velocity, damping(v, v - base_velocity), dt, CHECK)
        if i >= steps - window:
            squares += a * a
    return np.sqrt(squares / window)


def test_skyhook_rides_better_than_both_passive_dampers_of_its_range_as_in_the_section_8_table() -> None:
    """RMS body acceleration under a 5 cm sinusoidal road at resonance and at 2.5 omega_n: passive c = 4 and
    c = 20 (N s/m) against the closed form, and on-off skyhook in [0.5, 20]. At 2.5 omega_n the skyhook's switching
    makes it depend on the step (2.12 at 1e-3 s, 2.21 at 2e-3 s): it is about the soft damper there."""
    omega = np.repeat(np.array([1.0, 2.5]) * CHECK.natural_frequency, 3)
    passive = np.array([4.0, 20.0, 0.0] * 2)
    skyhook = passive == 0.0
    rms = rms_on_sinusoidal_road(
        omega, lambda v, relative: np.where(skyhook, suspension.skyhook_damping(v, relative, 0.5, 20.0), passive)
    )
    closed = omega**2 * suspension.transmissibility(omega, passive, CHECK) * ROAD_AMPLITUDE / math.sqrt(2.0)
    np.testing.assert_allclose(rms[~skyhook], closed[~skyhook], rtol=0.01)
    rms = rms.reshape(2, 3)
    np.testing.assert_allclose(rms, [[4.70, 1.68, 1.52], [2.12, 5.50, 2.10]], atol=0.03)
    assert rms[0, 2] < 0.92 * rms[0, 1] < rms[0, 0]
    assert rms[1, 2] < 1.01 * rms[1, 0] < 0.5 * rms[1, 1]


def test_continuous_skyhook_gives_the_sky_force_where_the_damper_range_reaches_it() -> None:
    body = np.array([1.0, 1.0, 1.0, -1.0, 1.0, -1.0, 0.0, 0.5])
    relative = np.array([0.5, 2.0, 100.0, -4.0, -0.5, 2.0, 1.0, 0.0])
    c = suspension.continuous_skyhook_damping(body, relative, 20.0, 0.5, 20.0)
    np.testing.assert_array_equal(c, [20.0, 10.0, 0.5, 5.0, 0.5, 0.5, 0.5, 0.5])
    reached = (c > 0.5) & (c < 20.0)
    np.testing.assert_allclose(-c[reached] * relative[reached], -20.0 * body[reached], rtol=1e-15)
    on_off = suspension.skyhook_damping(body, relative, 0.5, 20.0)
    np.testing.assert_array_equal(c == 20.0, (on_off == 20.0) & (np.abs(relative) <= np.abs(body)))


def test_continuous_skyhook_rides_as_the_on_off_one_at_resonance_and_better_above_it() -> None:
    """Section 8's road at resonance and 2.5 omega_n, range [0.5, 20] N s/m and c_sky = c_max: the continuous law
    follows the sky force instead of switching, which the on-off law's 2.12 m/s^2 above resonance pays for."""
    omega = np.repeat(np.array([1.0, 2.5]) * CHECK.natural_frequency, 2)
    continuous = np.array([False, True] * 2)

    def damping(v: np.ndarray, relative: np.ndarray) -> np.ndarray:
        on_off = suspension.skyhook_damping(v, relative, 0.5, 20.0)
        return np.where(continuous, suspension.continuous_skyhook_damping(v, relative, 20.0, 0.5, 20.0), on_off)

    rms = rms_on_sinusoidal_road(omega, damping).reshape(2, 2)
    print(f"\nRMS body acceleration (m/s^2), on-off vs continuous skyhook: resonance {rms[0]}, 2.5 omega_n {rms[1]}")
    assert rms[0, 1] == pytest.approx(rms[0, 0], rel=0.02)
    assert rms[1, 1] < 0.75 * rms[1, 0]


def test_terrain_is_the_sum_of_its_sinusoids_row_by_row() -> None:
    """The terrain is evaluated in passes over the rows (one per sinusoid): within an ulp or two of libm's sine and
    cosine, and each row as if alone."""
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 300.0, 64)
    wavenumber = 2.0 * np.pi / rng.uniform(1.5, 30.0, (64, 3))
    amplitude, phase = 0.01 / wavenumber, rng.uniform(0.0, 2.0 * np.pi, (64, 3))
    height, slope = suspension.terrain(x, amplitude, wavenumber, phase)
    angle = wavenumber * x[:, None] + phase
    np.testing.assert_allclose(height, np.sum(amplitude * np.sin(angle), axis=1), rtol=0, atol=1e-16)
    np.testing.assert_allclose(slope, np.sum(amplitude * wavenumber * np.cos(angle), axis=1), rtol=0, atol=1e-16)
    for i in (0, 31, 63):
        alone = suspension.terrain(x[i : i + 1], amplitude[i : i + 1], wavenumber[i : i + 1], phase[i : i + 1])
        assert (alone[0][0], alone[1][0]) == (height[i], slope[i])
