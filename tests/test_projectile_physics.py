"""Projectile flight with wind, ground impact and the firing solution against closed forms (section 6)."""

from __future__ import annotations

import numpy as np
import pytest

from vegym.physics import projectile
from vegym.physics.projectile import ProjectileParams

G = 9.81


def random_shots(n: int, seed: int, radius: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    p0 = np.stack([rng.uniform(-5, 5, n), radius + rng.uniform(0, 20, n), rng.uniform(-5, 5, n)], -1)
    v0 = projectile.launch_velocity(rng.uniform(-1.2, 1.5, n), rng.uniform(-np.pi, np.pi, n), rng.uniform(1, 40, n))
    wind = np.stack([rng.uniform(-5, 5, n), np.zeros(n), rng.uniform(-5, 5, n)], -1)
    return p0, v0, wind


def test_launch_direction_is_a_unit_vector_with_the_book_angles() -> None:
    d = projectile.launch_direction(np.array([np.pi / 6]), np.array([np.pi / 2]))
    np.testing.assert_allclose(d, [[0.0, 0.5, np.sqrt(3) / 2]], atol=1e-15)
    rng = np.random.default_rng(0)
    d = projectile.launch_direction(rng.uniform(-2, 2, 100), rng.uniform(-4, 4, 100))
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-15)


def test_landing_point_and_flight_time_equal_the_closed_form() -> None:
    params = ProjectileParams(gravity=G, radius=0.05)
    p0, v0, wind = random_shots(1000, seed=1)
    point, t = projectile.impact_point(p0, v0, wind, params)
    u = v0 + wind
    t_closed = (u[:, 1] + np.sqrt(u[:, 1] ** 2 + 2 * G * (p0[:, 1] - 0.05))) / G
    np.testing.assert_allclose(t, t_closed, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(point[:, [0, 2]], p0[:, [0, 2]] + u[:, [0, 2]] * t[:, None], atol=1e-9)
    np.testing.assert_allclose(point[:, 1], 0.05)
    at_impact = projectile.position_at(p0, v0, wind, t, params)  # the drift w t included (PHYSICS.md section 6)
    np.testing.assert_allclose(at_impact, point, atol=1e-9)


def test_landing_point_matches_a_fine_simulation() -> None:
    params = ProjectileParams(gravity=G, radius=0.0)
    p0 = np.array([[0.0, 10.0, 0.0]])
    v0 = projectile.launch_velocity(np.array([0.6]), np.array([0.3]), np.array([20.0]))
    wind = np.array([[3.0, 0.0, -2.0]])
    point, t = projectile.impact_point(p0, v0, wind, params)
    dt, p, v = 1e-5, p0[0].copy(), v0[0] + wind[0]
    steps = 0
    while True:
        v_next = v + params.gravity_vector * dt
        p_next = p + 0.5 * (v + v_next) * dt  # exact for constant acceleration
        if p_next[1] < 0:
            break
        p, v, steps = p_next, v_next, steps + 1
    assert steps * dt <= t[0] <= (steps + 1) * dt
    assert np.linalg.norm(p[[0, 2]] - point[0, [0, 2]]) < 25 * dt


def test_horizontal_ground_velocity_is_constant_and_apex_is_closed_form() -> None:
    params = ProjectileParams(gravity=G)
    p0, v0, wind = random_shots(50, seed=2, radius=0.0)
    for t in (0.0, 0.5, 2.0):
        v = projectile.velocity_at(v0, wind, np.full(50, t), params)
        np.testing.assert_allclose(v[:, [0, 2]], (v0 + wind)[:, [0, 2]], atol=1e-12)
    u_y = (v0 + wind)[:, 1]
    rising = u_y > 0
    t_apex = u_y[rising] / G
    apex = projectile.position_at(p0[rising], v0[rising], wind[rising], t_apex, params)[:, 1]
    np.testing.assert_allclose(apex, p0[rising, 1] + u_y[rising] ** 2 / (2 * G), rtol=1e-12)


def test_no_wind_range_is_maximal_at_45_degrees_on_flat_ground() -> None:
    params = ProjectileParams(gravity=G)
    elevations = np.radians(np.linspace(1, 89, 881))
    v0 = projectile.launch_velocity(elevations, np.zeros_like(elevations), np.full_like(elevations, 20.0))
    point, _ = projectile.impact_point(np.zeros((881, 3)), v0, np.zeros(3), params)
    best = np.argmax(point[:, 0])
    assert np.degrees(elevations[best]) == pytest.approx(45.0, abs=0.1)
    assert point[best, 0] == pytest.approx(400.0 / G, rel=1e-9)
    assert projectile.max_range(20.0, 0.0, params) == pytest.approx(400.0 / G, rel=1e-12)


@pytest.mark.parametrize("lob", [False, True])
def test_firing_solution_hits_with_wind_and_launch_height(lob: bool) -> None:
    params = ProjectileParams(gravity=G, radius=0.0)
    rng = np.random.default_rng(3)
    n = 500
    height = rng.uniform(0, 20, n)
    delta = np.stack([rng.uniform(-60, 60, n), -height, rng.uniform(-60, 60, n)], -1)
    wind = np.stack([rng.uniform(-5, 5, n), np.zeros(n), rng.uniform(-5, 5, n)], -1)
    elevation, azimuth, flight_time, reachable = projectile.firing_solution(delta, wind, 40.0, params, lob=lob)
    assert reachable.all()
    p0 = np.stack([np.zeros(n), height, np.zeros(n)], -1)
    v0 = projectile.launch_velocity(elevation, azimuth, np.full(n, 40.0))
    point, t = projectile.impact_point(p0, v0, wind, params)
    np.testing.assert_allclose(point[:, [0, 2]], delta[:, [0, 2]], atol=1e-9)
    np.testing.assert_allclose(t, flight_time, atol=1e-9)


def test_firing_solution_without_wind_equals_the_closed_form_angles() -> None:
    params = ProjectileParams(gravity=G)
    v, distance, rise = 25.0, 40.0, 3.0
    root = np.sqrt(v**4 - G * (G * distance**2 + 2 * rise * v**2))
    low, high = np.arctan((v**2 - root) / (G * distance)), np.arctan((v**2 + root) / (G * distance))
    delta = np.array([[0.0, rise, distance]])
    el_low, az, _, _ = projectile.firing_solution(delta, np.zeros(3), v, params)
    el_high, _, _, _ = projectile.firing_solution(delta, np.zeros(3), v, params, lob=True)
    assert el_low[0] == pytest.approx(low, abs=1e-12)
    assert el_high[0] == pytest.approx(high, abs=1e-12)
    assert az[0] == pytest.approx(np.pi / 2, abs=1e-12)


def test_firing_solution_reports_an_unreachable_target() -> None:
    params = ProjectileParams(gravity=G)
    _, _, flight_time, reachable = projectile.firing_solution(np.array([[500.0, 0.0, 0.0]]), np.zeros(3), 20.0, params)
    assert not reachable[0] and np.isnan(flight_time[0])


@pytest.mark.parametrize("height", [0.0, 5.0, 20.0, 200.0])
def test_unreachable_target_gets_the_max_range_shot_from_the_launch_height(height: float) -> None:
    params, v = ProjectileParams(gravity=G), 10.0
    delta = np.array([[0.0, -height, 500.0]])  # far out of range, along +z
    elevation, azimuth, _, reachable = projectile.firing_solution(delta, np.zeros(3), v, params)
    assert not reachable[0] and azimuth[0] == pytest.approx(np.pi / 2, abs=1e-12)
    p0 = np.array([[0.0, height, 0.0]])
    landed, _ = projectile.impact_point(
        p0, projectile.launch_velocity(elevation, azimuth, np.array([v])), np.zeros(3), params
    )
    assert landed[0, 2] == pytest.approx(projectile.max_range(v, height, params), rel=1e-9)
    others = np.radians(np.linspace(0.0, 90.0, 9001))
    v0 = projectile.launch_velocity(others, np.full_like(others, np.pi / 2), np.full_like(others, v))
    reach, _ = projectile.impact_point(np.broadcast_to(p0, v0.shape), v0, np.zeros(3), params)
    assert reach[:, 2].max() <= landed[0, 2] * (1.0 + 1e-12)


def test_max_range_elevation_is_45_degrees_from_the_landing_level_and_vertical_below_it() -> None:
    params = ProjectileParams(gravity=G)
    elevation = projectile.max_range_elevation(np.array([10.0, 10.0, 10.0]), np.array([0.0, -100.0, -5.0]), params)
    assert elevation[0] == pytest.approx(np.pi / 4, abs=1e-12)
    assert elevation[1] == np.pi / 2  # the landing level above the apex of a vertical shot
    assert elevation[2] == pytest.approx(np.arcsin(10.0 / np.sqrt(2.0 * (100.0 - 5.0 * G))), abs=1e-12)


def test_batched_impact_equals_looped_bit_for_bit() -> None:
    params = ProjectileParams(gravity=G, radius=0.05)
    p0, v0, wind = random_shots(32, seed=4)
    point, t = projectile.impact_point(p0, v0, wind, params)
    for i in range(32):
        point_i, t_i = projectile.impact_point(p0[i : i + 1], v0[i : i + 1], wind[i : i + 1], params)
        np.testing.assert_array_equal(point_i[0], point[i])
        assert t_i[0] == t[i]


def test_a_vertical_drift_enters_the_landing_time_as_it_enters_position_at() -> None:
    params = ProjectileParams(radius=0.1)
    p0, v0, wind = np.array([[0.0, 2.0, 0.0]]), np.array([[10.0, 5.0, 0.0]]), np.array([[1.0, -0.5, 2.0]])
    point, t = projectile.impact_point(p0, v0, wind, params)
    np.testing.assert_allclose(t, projectile.impact_time(p0, v0, wind, params), rtol=1e-12)
    np.testing.assert_allclose(projectile.position_at(p0, v0, wind, t, params), point, rtol=0, atol=1e-9)


def test_firing_solution_hits_with_a_vertical_drift_component() -> None:
    params = ProjectileParams()
    delta, wind = np.array([[60.0, 5.0, -20.0]]), np.array([[2.0, 0.8, -1.5]])
    for lob in (False, True):
        elevation, azimuth, t, ok = projectile.firing_solution(delta, wind, 40.0, params, lob=lob)
        assert ok.all()
        v0 = projectile.launch_velocity(elevation, azimuth, np.array([40.0]))
        hit = projectile.position_at(np.zeros((1, 3)), v0, wind, t, params)
        np.testing.assert_allclose(hit, delta, rtol=0, atol=1e-9)


def test_max_range_elevation_is_vertical_from_just_below_the_apex_of_a_vertical_shot() -> None:
    """Landing level between v^2/(2g) and v^2/g above the launch: 2 (v^2 + g h) > 0 but the sine would exceed 1."""
    params = ProjectileParams()
    v = 10.0
    h = -0.75 * v * v / params.gravity
    assert projectile.max_range_elevation(v, h, params) == np.pi / 2
