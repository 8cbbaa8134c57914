"""Falling particle, exact ground contact and restitution against closed forms (PHYSICS.md section 1)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from vegym.physics import particle
from vegym.physics.particle import ParticleParams

G = 9.81


def test_velocity_law_is_v_minus_g_t_not_the_printed_height_law() -> None:
    h, v = particle.state_at(np.array([2.0]), np.array([-3.0]), np.array([0.1]), G)
    assert v[0] == pytest.approx(-3.981, abs=1e-12)
    assert h[0] == pytest.approx(2.0 - 0.3 - 0.5 * G * 0.01, abs=1e-12)


@pytest.mark.parametrize("radius", [0.0, 0.1])
def test_time_to_ground_is_the_exact_root_in_both_directions(radius: float) -> None:
    rng = np.random.default_rng(0)
    h = radius + rng.uniform(0.0, 10.0, 1000)
    v = rng.uniform(-20.0, 20.0, 1000)
    t = particle.time_to_ground(h, v, radius, G)
    h_at, v_at = particle.state_at(h, v, t, G)
    np.testing.assert_allclose(h_at, radius, atol=1e-9)
    np.testing.assert_allclose(v_at, particle.impact_velocity(h, v, radius, G), atol=1e-9)
    assert np.all(t >= 0)


def test_time_to_ground_keeps_precision_where_the_printed_formula_cancels() -> None:
    h, v = np.array([1e-6]), np.array([-30.0])
    t = particle.time_to_ground(h, v, 0.0, G)
    exact = 2e-6 / (np.sqrt(900.0 + 2 * G * 1e-6) + 30.0)
    assert abs(t[0] - exact) / exact < 1e-12


def test_time_to_ground_is_zero_on_the_ground_and_infinite_below_it_when_falling() -> None:
    t = particle.time_to_ground(np.array([0.1, 0.1, -5.0]), np.array([-1.0, 0.0, -1.0]), 0.1, G)
    assert t[0] == 0.0 and t[1] == 0.0 and np.isinf(t[2])


def test_time_to_ground_below_the_ground_is_zero_falling_and_the_later_root_rising() -> None:
    """The docstring's cases for h < r, which no env reaches: +inf without a real root, else 0 moving down and,
    moving up, the time it falls back through h = r."""
    t = particle.time_to_ground(np.array([0.05, 0.05, 0.05]), np.array([-3.0, 3.0, 0.5]), 0.1, G)
    s = np.sqrt(9.0 - 2 * G * 0.05)
    assert t[0] == 0.0 and t[1] == pytest.approx((3.0 + s) / G, rel=1e-12) and np.isinf(t[2])


def test_impact_velocity_is_negative_and_from_energy() -> None:
    v_g = particle.impact_velocity(np.array([3.0]), np.array([2.0]), 0.2, G)
    assert v_g[0] == pytest.approx(-np.sqrt(4.0 + 2 * G * 2.8), abs=1e-12)


@pytest.mark.parametrize("e", [0.0, 0.3, 0.7, 1.0])
def test_apex_after_an_impact_is_r_plus_e_v_squared_over_2g(e: float) -> None:
    radius, v = 0.15, 6.0
    rebound = particle.restitute(np.array([[0.0, -v, 0.0]]), np.array([0.0, 1.0, 0.0]), e)[:, 1]
    apex = particle.apex_height(radius, rebound, G)
    assert apex[0] == pytest.approx(radius + (e * v) ** 2 / (2 * G), abs=1e-12)
    next_impact = particle.impact_velocity(radius, rebound, radius, G)
    assert -next_impact[0] == pytest.approx(e * v, abs=1e-12)


def test_ten_thousand_elastic_bounces_keep_the_apex() -> None:
    radius, h0 = 0.1, 3.0
    speed = -particle.impact_velocity(h0, 0.0, radius, G)
    for _ in range(10_000):
        rebound = particle.restitute(np.array([[0.0, -speed, 0.0]]), np.array([0.0, 1.0, 0.0]), 1.0)[0, 1]
        speed = -particle.impact_velocity(radius, rebound, radius, G)
    assert particle.apex_height(radius, rebound, G) == pytest.approx(h0, abs=1e-9)


def test_the_apex_is_h_plus_v_squared_over_2g_rising_and_the_height_itself_falling() -> None:
    h, v = np.array([1.0, 1.0, 2.5, 2.5]), np.array([3.0, -3.0, 0.0, -0.5])
    expected = [1.0 + 9.0 / (2.0 * G), 1.0, 2.5, 2.5]
    np.testing.assert_allclose(particle.apex_height(h, v, G), expected, rtol=1e-15, atol=0.0)


@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_restitution_on_an_inclined_surface_keeps_the_tangential_component(e: float) -> None:
    rng = np.random.default_rng(1)
    normal = rng.normal(size=(500, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    v = rng.normal(size=(500, 3)) * 5
    after = particle.restitute(v, normal, e)
    v_n = np.sum(v * normal, axis=1)
    a_n = np.sum(after * normal, axis=1)
    tangential_before = v - v_n[:, None] * normal
    tangential_after = after - a_n[:, None] * normal
    np.testing.assert_allclose(tangential_after, tangential_before, atol=1e-12)
    incoming = v_n < 0
    np.testing.assert_allclose(a_n[incoming], -e * v_n[incoming], atol=1e-12)
    np.testing.assert_array_equal(after[~incoming], v[~incoming])
    # 8.17 and 8.15/8.18: |v'| = |v| sqrt(sin^2 a + e^2 cos^2 a) with a the angle from the normal
    cos_a = -v_n[incoming] / np.linalg.norm(v[incoming], axis=1)
    expected = np.linalg.norm(v[incoming], axis=1) * np.sqrt(1 - cos_a**2 + e**2 * cos_a**2)
    np.testing.assert_allclose(np.linalg.norm(after[incoming], axis=1), expected, rtol=1e-12)


@pytest.mark.parametrize(("e", "radius"), [(1.0, 0.0), (0.8, 0.0), (1.0, 0.1), (0.8, 0.1)])
def test_event_step_does_not_depend_on_the_time_step(e: float, radius: float) -> None:
    params = ParticleParams(gravity=G, radius=radius)
    h_coarse, v_coarse = np.array([3.0]), np.array([0.0])
    for _ in range(60):
        h_coarse, v_coarse = particle.event_step(h_coarse, v_coarse, 0.05, e, params)
    h_fine, v_fine = particle.event_step(np.array([3.0]), np.array([0.0]), 3.0, e, params)
    assert h_coarse[0] == pytest.approx(h_fine[0], abs=1e-9)
    assert v_coarse[0] == pytest.approx(v_fine[0], abs=1e-9)
    assert h_coarse[0] >= radius


def test_event_step_with_e_one_conserves_energy_and_apex() -> None:
    params = ParticleParams(gravity=G, radius=0.0)
    h, v = np.array([3.0]), np.array([0.0])
    energies, heights = [], []
    for _ in range(1000):
        h, v = particle.event_step(h, v, 0.01, 1.0, params)
        energies.append(0.5 * v[0] ** 2 + G * h[0])
        heights.append(h[0])
    np.testing.assert_allclose(energies, G * 3.0, rtol=1e-9)
    assert max(heights) == pytest.approx(3.0, abs=1e-3)


def test_event_step_comes_to_rest_in_the_closed_form_time() -> None:
    e, radius = 0.5, 0.0
    params = ParticleParams(gravity=G, radius=radius)
    speed = 2.0  # rebound speed just after an impact at speed / e: the flights sum to 2 speed / (g (1 - e))
    t_rest = 2 * speed / (G * (1 - e))
    h, v = particle.event_step(np.array([0.0]), np.array([speed]), t_rest + 1e-3, e, params, rest_speed=1e-9)
    assert h[0] == 0.0 and v[0] == 0.0
    h, v = particle.event_step(np.array([0.0]), np.array([speed]), t_rest - 1e-3, e, params, rest_speed=1e-9)
    assert h[0] > 0.0 or v[0] != 0.0


def test_event_step_rejects_a_start_below_the_ground_and_a_rest_speed_that_never_stops() -> None:
    with pytest.raises(ValueError, match="below the ground"):
        particle.event_step(np.array([0.05]), np.array([0.0]), 0.1, 1.0, ParticleParams(radius=0.1))
    with pytest.raises(ValueError, match=r"rest_speed=0.0 is outside the allowed range \(0, inf\)"):
        particle.event_step(np.array([0.1]), np.array([0.0]), 0.1, 0.8, ParticleParams(radius=0.1), rest_speed=0.0)


@pytest.mark.parametrize(
    ("h", "v", "dt", "e", "message"),
    [
        (1.0, np.nan, 0.1, 0.8, "v must be finite, got nan"),
        (np.inf, 0.0, 0.1, 0.8, "h must be finite, got inf"),
        (1.0, 0.0, 0.1, np.nan, "restitution must be finite, got nan"),
        (1.0, 0.0, 0.1, 1.5, r"restitution=1.5 is outside the allowed range \[0, 1\]"),
        (1.0, 0.0, np.inf, 0.8, r"dt=inf is outside the allowed range \[0, inf\) s"),
        (1.0, 0.0, -0.1, 0.8, r"dt=-0.1 is outside the allowed range \[0, inf\) s"),
    ],
)
def test_event_step_refuses_input_it_cannot_step(h: float, v: float, dt: float, e: float, message: str) -> None:
    """A NaN restitution re-landed the particle forever; the others had no meaning."""
    with pytest.raises(ValueError, match=message):
        particle.event_step(np.array([h]), np.array([v]), dt, e, ParticleParams())


def test_event_step_with_e_one_over_a_long_span_is_the_periodic_closed_form() -> None:
    params = ParticleParams(gravity=G, radius=0.0)
    period = 2.0 * np.sqrt(2.0 * 3.0 / G)  # dropped from 3 m: at the apex again every period
    for span in (1e4, 12345.678):
        h, v = particle.event_step(np.array([3.0]), np.array([0.0]), span, 1.0, params)
        phase = np.fmod(span, period)
        fall = phase if phase <= period / 2 else period - phase  # time from the nearest apex
        assert h[0] == pytest.approx(3.0 - 0.5 * G * fall**2, abs=1e-9)
        assert abs(v[0]) == pytest.approx(G * fall, abs=1e-9)


@pytest.mark.parametrize(
    ("h", "v", "dt", "e", "rest_speed"),
    [
        (0.0, -1e-19, 0.01, 1.0, 1e-20),  # bounces far shorter than an ulp of the time left
        (1e-30, 0.0, 0.01, 1.0, 1e-20),
        (0.0, -1.0001e-6, 1e9, 1.0, 1e-6),  # 2e15 bounces of 0.2 us
        (0.0, 1.0, 2.0 / (G * 1e-9) * 1.0000001, 1.0 - 1e-9, 1e-300),  # longer than its 2e11 bounces together
    ],
)
def test_event_step_returns_however_many_bounces_the_step_holds(
    h: float, v: float, dt: float, e: float, rest_speed: float
) -> None:
    """These looped forever (or for days): the bounces after a rebound now follow in closed form."""
    code = (
        "import numpy as np; from vegym.physics import particle; from vegym.physics.particle import ParticleParams;"
        f"print(particle.event_step(np.array([{h!r}]), np.array([{v!r}]), {dt!r}, {e!r},"
        f" ParticleParams(gravity={G!r}, radius=0.0), rest_speed={rest_speed!r}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_event_step_ending_ulps_short_of_a_contact_stays_on_the_ground_and_bounces_next_step() -> None:
    """h >= r after every step: a step a few ulps short of the contact time used to round the height below r
    (-3.6e-16 m), which the next step refused as a start below the ground. Held at r, the particle still moves
    down: the next step bounces it, as one step over both spans does (it used to stop it dead, as at rest)."""
    params = ParticleParams(radius=0.1)
    rng = np.random.default_rng(0)
    h0, v0 = rng.uniform(0.2, 3.0, 2000), rng.uniform(-8.0, 8.0, 2000)
    contact = particle.time_to_ground(h0, v0, params.radius, params.gravity)
    for ulps in (1, 2, 3):
        dt = contact
        for _ in range(ulps):
            dt = np.nextafter(dt, 0.0)
        for h, v, step in zip(h0, v0, dt, strict=True):
            h1, v1 = particle.event_step(np.array([h]), np.array([v]), float(step), 0.8, params)
            assert h1[0] >= params.radius
            h2, v2 = particle.event_step(h1, v1, 0.01, 0.8, params)
            h_one, v_one = particle.event_step(np.array([h]), np.array([v]), float(step) + 0.01, 0.8, params)
            assert h2[0] == pytest.approx(h_one[0], abs=1e-9) and v2[0] == pytest.approx(v_one[0], abs=1e-9)


def test_batched_functions_equal_looped_bit_for_bit() -> None:
    rng = np.random.default_rng(2)
    params = ParticleParams(gravity=G, radius=0.1)
    h = 0.1 + rng.uniform(0, 5, 64)
    v = rng.uniform(-5, 5, 64)
    e = rng.uniform(0, 1, 64)
    batched = particle.event_step(h, v, 0.37, e, params)
    looped = [particle.event_step(h[i : i + 1], v[i : i + 1], 0.37, e[i : i + 1], params) for i in range(64)]
    np.testing.assert_array_equal(batched[0], np.concatenate([lh for lh, _ in looped]))
    np.testing.assert_array_equal(batched[1], np.concatenate([lv for _, lv in looped]))
    t = particle.time_to_ground(h, v, 0.1, G)
    np.testing.assert_array_equal(t, [particle.time_to_ground(h[i], v[i], 0.1, G) for i in range(64)])


def test_particle_params_reject_invalid_values_naming_them() -> None:
    with pytest.raises(ValueError, match=r"gravity=0.0 is outside the allowed range \[1e-09, 1e\+09\]"):
        ParticleParams(gravity=0.0)
    with pytest.raises(ValueError, match="radius=-1"):
        ParticleParams(radius=-1)
    with pytest.raises(TypeError):
        ParticleParams(radious=1.0)  # type: ignore[call-arg]


def test_event_step_refuses_a_negative_restitution() -> None:
    with pytest.raises(ValueError, match=r"restitution=-0.5 is outside the allowed range \[0, 1\]"):
        particle.event_step(np.array([1.0]), np.array([0.0]), 0.1, -0.5, ParticleParams())


def test_event_step_of_zero_duration_keeps_a_flying_particle_and_bounces_one_on_the_ground() -> None:
    """dt = 0 is allowed (dt >= 0): nothing moves, but a particle at h = r moving down rebounds at once."""
    h, v = particle.event_step(np.array([1.0, 0.1]), np.array([-2.0, -3.0]), 0.0, 0.5, ParticleParams(radius=0.1))
    np.testing.assert_array_equal(h, [1.0, 0.1])
    np.testing.assert_array_equal(v, [-2.0, 1.5])


def test_a_contact_exactly_at_the_end_of_the_step_is_resolved_in_that_step() -> None:
    """g = 8, h = 4 from rest lands after exactly 1 s at -8 m/s (every number exact): a 1 s step ends rebounding."""
    assert particle.time_to_ground(4.0, 0.0, 0.0, 8.0) == 1.0
    h, v = particle.event_step(np.array([4.0]), np.array([0.0]), 1.0, 0.5, ParticleParams(gravity=8.0))
    np.testing.assert_array_equal(h, [0.0])
    np.testing.assert_array_equal(v, [4.0])
