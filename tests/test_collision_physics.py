"""Direct and oblique impact of two spheres (PHYSICS.md section 5) against the chapter's example and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vegym.physics import collision


def random_impacts(n: int, dim: int, seed: int) -> tuple[np.ndarray, ...]:
    """Spheres in contact (unit contact distance) closing on each other, random masses and restitution."""
    r = np.random.default_rng(seed)
    normal = r.normal(size=(n, dim))
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    c_a = r.uniform(-3, 3, (n, dim))
    v_a, v_b = r.normal(size=(n, dim)), r.normal(size=(n, dim))
    closing = np.sum((v_a - v_b) * normal, axis=-1)
    v_a = v_a + (np.abs(closing) + 0.1 - closing)[:, None] * normal  # make every pair close
    return c_a, c_a + normal, v_a, v_b, r.uniform(0.1, 5, n), r.uniform(0.1, 5, n), r.uniform(0, 1, n)


@pytest.mark.parametrize(("e", "u_a", "u_b"), [(1.0, -2.5, 3.5), (0.5, -1.375, 1.625), (0.0, -0.25, -0.25)])
def test_the_worked_example_8_50_in_one_dimension_and_as_a_vector(e: float, u_a: float, u_b: float) -> None:
    assert collision.direct_impact(2.0, -4.0, 5.0, 3.0, e) == pytest.approx((u_a, u_b), abs=1e-15)
    after_a, after_b = collision.oblique_impact([0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [-4.0, 0.0], 5.0, 3.0, e)
    np.testing.assert_allclose([after_a, after_b], [[u_a, 0.0], [u_b, 0.0]], atol=1e-15)
    assert 5.0 * u_a + 3.0 * u_b == pytest.approx(-2.0)  # the momentum of 8.49, corrected
    lost = 0.5 * (5.0 * 2.0**2 + 3.0 * 4.0**2) - 0.5 * (5.0 * u_a**2 + 3.0 * u_b**2)
    assert lost == pytest.approx(collision.energy_loss(6.0, 5.0, 3.0, e))
    if e == 0.0:
        assert lost == pytest.approx(33.75)


@pytest.mark.parametrize("dim", [2, 3])
def test_momentum_is_conserved_the_normal_relative_velocity_reverses_by_e_and_the_tangential_parts_are_kept(
    dim: int,
) -> None:
    c_a, c_b, v_a, v_b, m_a, m_b, e = random_impacts(500, dim, seed=dim)
    u_a, u_b = collision.oblique_impact(c_a, c_b, v_a, v_b, m_a, m_b, e)
    np.testing.assert_allclose(m_a[:, None] * u_a + m_b[:, None] * u_b, m_a[:, None] * v_a + m_b[:, None] * v_b)
    n = c_b - c_a
    w = np.sum((v_a - v_b) * n, axis=-1)
    np.testing.assert_allclose(np.sum((u_a - u_b) * n, axis=-1), -e * w, atol=1e-12)
    for before, after in ((v_a, u_a), (v_b, u_b)):
        change = after - before
        np.testing.assert_allclose(change - np.sum(change * n, axis=-1, keepdims=True) * n, 0.0, atol=1e-12)
    kinetic_before = 0.5 * (m_a * np.sum(v_a * v_a, -1) + m_b * np.sum(v_b * v_b, -1))
    kinetic_after = 0.5 * (m_a * np.sum(u_a * u_a, -1) + m_b * np.sum(u_b * u_b, -1))
    np.testing.assert_allclose(kinetic_before - kinetic_after, collision.energy_loss(w, m_a, m_b, e), atol=1e-12)
    np.testing.assert_allclose(collision.direct_impact(w, 0.0, m_a, m_b, e)[1], np.sum((u_b - v_b) * n, -1))


def test_spheres_moving_apart_are_left_alone() -> None:
    u_a, u_b = collision.oblique_impact([[0.0, 0.0]], [[1.0, 0.0]], [[-1.0, 0.3]], [[0.5, 2.0]], 1.0, 2.0, 0.8)
    np.testing.assert_array_equal(u_a, [[-1.0, 0.3]])
    np.testing.assert_array_equal(u_b, [[0.5, 2.0]])


def test_equal_masses_at_e_1_separate_at_90_degrees_and_b_leaves_along_the_line_of_centres() -> None:
    c_a, c_b, v_a, _, _, _, _ = random_impacts(200, 2, seed=5)
    rest = np.zeros_like(v_a)
    u_a, u_b = collision.oblique_impact(c_a, c_b, v_a, rest, 0.17, 0.17, 1.0)
    np.testing.assert_allclose(np.sum(u_a * u_b, axis=-1), 0.0, atol=1e-12)
    n = c_b - c_a
    np.testing.assert_allclose(u_b[:, 0] * n[:, 1] - u_b[:, 1] * n[:, 0], 0.0, atol=1e-12)


@pytest.mark.parametrize(("m_a", "m_b", "e"), [(1.0, 1.0, 0.5), (2.0, 1.0, 0.9), (1.0, 3.0, 0.7), (0.6, 1.0, 0.6)])
def test_the_8_61_deflection_angle_matches_the_vector_impact(m_a: float, m_b: float, e: float) -> None:
    alpha = np.radians(np.array([5.0, 30.0, 60.0, 85.0, -40.0]))
    v_a = np.stack([np.cos(alpha), np.sin(alpha)], axis=-1) * 2.0
    u_a, _ = collision.oblique_impact(np.zeros((5, 2)), [1.0, 0.0], v_a, np.zeros((5, 2)), m_a, m_b, e)
    theta = collision.deflection_angle(alpha, m_a, m_b, e)
    np.testing.assert_allclose(theta, np.arctan2(u_a[:, 1], u_a[:, 0]), atol=1e-12)
    if m_a == e * m_b:  # the printed tan form is singular here: A leaves square to the line of centres
        np.testing.assert_allclose(np.abs(theta), np.pi / 2, atol=1e-12)
    else:
        np.testing.assert_allclose(np.tan(theta), (m_a + m_b) * np.tan(alpha) / (m_a - e * m_b), rtol=1e-9)
    if m_a == m_b:
        np.testing.assert_allclose(np.tan(theta), 2.0 * np.tan(alpha) / (1.0 - e), rtol=1e-9)  # 8.62


def test_striking_from_the_ghost_point_sends_b_along_the_chosen_direction() -> None:
    r = np.random.default_rng(3)
    c_b = r.uniform(-1, 1, (100, 2))
    angle = r.uniform(-np.pi, np.pi, 100)
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    ghost = collision.ghost_point(c_b, direction, 0.06)
    cut = r.uniform(-1.2, 1.2, 100)  # A approaches the ghost point at up to ~69 degrees off the direction
    approach = np.stack([np.cos(angle + cut), np.sin(angle + cut)], axis=-1)
    c_a = ghost - r.uniform(0.2, 2.0, 100)[:, None] * approach
    travel = collision.first_contact(c_a, approach, c_b, 0.06)
    np.testing.assert_allclose(c_a + travel[:, None] * approach, ghost, atol=1e-12)
    _, u_b = collision.oblique_impact(ghost, c_b, approach, np.zeros((100, 2)), 0.17, 0.2, 0.9)
    np.testing.assert_allclose(u_b / np.linalg.norm(u_b, axis=-1, keepdims=True), direction, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(u_b, axis=-1), 1.9 * 0.17 / 0.37 * np.cos(cut), rtol=1e-12)  # 8.60
    away = collision.first_contact(c_a, -approach, c_b, 0.06)
    assert np.all(np.isinf(away))


def test_a_sliding_ball_stops_after_v_squared_over_2a_and_launch_speed_inverts_speed_after() -> None:
    rest, distance, time = collision.slide(np.array([[1.0, 2.0]]), np.array([[3.0, 4.0]]), 0.5)
    np.testing.assert_allclose(rest, [[1.0 + 0.6 * 25.0, 2.0 + 0.8 * 25.0]])
    assert (distance[0], time[0]) == pytest.approx((25.0, 10.0))
    speed = collision.launch_speed(np.array([0.0, 1.5]), np.array([2.0, 0.7]), 0.3)
    np.testing.assert_allclose(collision.speed_after(speed, np.array([2.0, 0.7]), 0.3), [0.0, 1.5], atol=1e-12)
    assert collision.speed_after(1.0, 10.0, 0.3) == 0.0


def test_first_contact_is_inf_for_a_miss_or_a_sphere_behind_and_0_when_touching() -> None:
    c_a = np.zeros((4, 2))
    direction = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [1.0, 0.0]])
    c_b = np.array([[2.0, 0.0], [2.0, 0.5], [2.0, 0.0], [0.5, 0.0]])
    travel = collision.first_contact(c_a, direction, c_b, 0.5)
    np.testing.assert_array_equal(travel, [1.5, np.inf, np.inf, 0.0])  # ahead, passing by, behind, touching
    grazing = collision.first_contact(np.zeros(2), np.array([1.0, 0.0]), np.array([2.0, 0.5]), 0.5)
    assert grazing == pytest.approx(2.0)


def test_first_contact_keeps_its_precision_for_spheres_far_apart() -> None:
    """Written as ``b - sqrt(b^2 - (|c_b - c_a|^2 - R^2))`` the root cancelled: 3e-8 m off at 1 km, contacts missed
    from 1,000 km. A's line passes B's centre at R / 2: the travel is ``D - sqrt(3) R / 2`` to D's last bit."""
    for distance in (1.0, 1e3, 1e6, 1e9):
        travel = collision.first_contact(np.zeros(2), np.array([1.0, 0.0]), np.array([distance, 0.03]), 0.06)
        assert abs(travel - (distance - math.sqrt(0.06**2 - 0.03**2))) <= np.spacing(distance)


def test_reduced_mass_is_the_product_over_the_sum_for_any_shapes() -> None:
    assert collision.reduced_mass(5.0, 3.0) == 15.0 / 8.0
    np.testing.assert_array_equal(
        collision.reduced_mass(np.array([[1.0], [2.0]]), np.array([1.0, 3.0])),
        [[1.0 / 2.0, 3.0 / 4.0], [2.0 / 3.0, 6.0 / 5.0]],
    )


def test_first_contact_is_zero_not_negative_for_spheres_touching_to_rounding() -> None:
    """|c_b - c_a| = 0.3 against R = 0.1 + 0.2 (one ulp more): in contact, so no travel, never a negative one."""
    travel = collision.first_contact(np.zeros(2), np.array([1.0, 0.0]), np.array([0.3, 0.0]), 0.1 + 0.2)
    assert travel == 0.0
