"""Rolling wheel, gear trains and steerable wheel (PHYSICS.md sections 2 and 3) against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from vegym.physics import wheel
from vegym.physics.wheel import Pose, WheelParams

WHEEL = WheelParams(radius=0.3)


def poses(n: int, seed: int = 0) -> Pose:
    r = np.random.default_rng(seed)
    return Pose(r.uniform(-5, 5, n), r.uniform(-5, 5, n), r.uniform(-np.pi, np.pi, n), r.uniform(-10, 10, n))


def bottom_point(pose: Pose, params: WheelParams) -> np.ndarray:
    """Object-space point (n, 3) that ``wheel_matrix`` puts at the contact point: ``R_z(alpha) (0, -r, 0)``."""
    down = np.array([0.0, -params.radius, 0.0, 1.0])
    return (wheel.rotation_z(pose.roll) @ down)[:, :3]


@pytest.mark.parametrize("phi", [0.02, -0.02, 0.3, -1.0])
def test_constant_phi_traces_a_circle_of_radius_v_dt_over_phi_about_the_analytic_centre(phi: float) -> None:
    dt, speed = 0.1, np.array([1.5, 0.4, 3.0])
    yaw_rate = np.full(3, phi / dt)
    pose = poses(3)
    centre = wheel.turn_centre(pose, speed, yaw_rate)
    radius = speed * dt / abs(phi)
    np.testing.assert_allclose(np.abs(wheel.turn_radius(speed, yaw_rate)), radius, rtol=1e-15)
    for _ in range(1000):
        pose = wheel.steer_step(pose, speed, yaw_rate, dt, WHEEL)
        distance = np.hypot(pose.x - centre[:, 0], pose.z - centre[:, 1])
        np.testing.assert_allclose(distance, radius, rtol=0, atol=1e-9)
        np.testing.assert_allclose(wheel.turn_centre(pose, speed, yaw_rate), centre, rtol=0, atol=1e-9)


def test_a_full_circle_takes_two_pi_over_phi_steps_and_turns_left_for_positive_phi() -> None:
    steps, dt = 100, 0.05
    phi = 2.0 * np.pi / steps
    start = Pose(np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1))
    pose = start
    for k in range(steps):
        pose = wheel.steer_step(pose, np.ones(1), np.full(1, phi / dt), dt, WHEEL)
        if k == steps // 4 - 1:
            assert pose.x[0] > 0.5 and pose.z[0] > 0.5  # heading +z, turning toward the left, +x
    np.testing.assert_allclose([pose.x[0], pose.z[0], wheel.wrap_angle(pose.heading)[0]], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(wheel.left(start.heading), [[1.0, 0.0, 0.0]])
    np.testing.assert_allclose(wheel.turn_centre(start, np.ones(1), np.full(1, phi / dt)), [[dt / phi, 0]])


def test_phi_zero_is_exactly_the_straight_update_and_small_phi_converges_to_it() -> None:
    pose, speed, dt = poses(4, 1), np.array([0.5, 1.0, 2.0, 3.0]), 0.1
    straight = wheel.steer_step(pose, speed, np.zeros(4), dt, WHEEL)
    np.testing.assert_array_equal(straight.x, pose.x + speed * dt * np.sin(pose.heading))
    np.testing.assert_array_equal(straight.z, pose.z + speed * dt * np.cos(pose.heading))
    errors = []
    for phi in (1e-2, 1e-4, 1e-6, 1e-8):
        turned = wheel.steer_step(pose, speed, np.full(4, phi / dt), dt, WHEEL)
        error = np.hypot(turned.x - straight.x, turned.z - straight.z)
        assert np.all(error <= 0.5 * speed * dt * phi * (1 + 1e-6) + 1e-15)
        errors.append(error.max())
    assert errors[-1] < 2e-9 and errors == sorted(errors, reverse=True)


@pytest.mark.parametrize("phi", [0.5, -0.1, 1e-3])
def test_chord_update_equals_the_book_rotation_about_the_turn_centre(phi: float) -> None:
    pose, speed, dt = poses(5, 2), np.full(5, 1.2), 0.1
    theta = pose.heading + 0.5 * np.pi  # the book's steering angle
    radius = speed * dt / phi
    book_x = pose.x + radius * (np.sin(theta) - np.sin(theta + phi))  # 8.29-8.34 in book variables
    book_z = pose.z + radius * (np.cos(theta) - np.cos(theta + phi))
    new = wheel.steer_step(pose, speed, np.full(5, phi / dt), dt, WHEEL)
    np.testing.assert_allclose(new.x, book_x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(new.z, book_z, rtol=0, atol=1e-12)
    np.testing.assert_allclose(new.heading, wheel.wrap_angle(pose.heading + phi), atol=1e-15)


def test_roll_angle_times_radius_is_the_path_length() -> None:
    r = np.random.default_rng(3)
    pose = Pose(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    dt, path, chords = 0.05, np.zeros(3), np.zeros(3)
    for _ in range(500):
        speed, yaw_rate = r.uniform(0, 3, 3), r.uniform(-4, 4, 3)
        new = wheel.steer_step(pose, speed, yaw_rate, dt, WHEEL)
        path += speed * dt
        chords += np.hypot(new.x - pose.x, new.z - pose.z)
        pose = new
    np.testing.assert_allclose(pose.roll * WHEEL.radius, path, rtol=1e-12)
    assert np.all(chords <= path) and np.all(chords > 0.99 * path)
    np.testing.assert_allclose(wheel.roll_angle(2 * np.pi * 0.3, 0.3), 2 * np.pi)


def test_rolling_example_and_the_printed_matrix_8_27() -> None:
    np.testing.assert_allclose(
        wheel.transform(wheel.rolling_matrix(2 * np.pi, 1.0), [[0, -1, 0]]), [[[2 * np.pi, 0, 0]]]
    )
    d, r = np.array([0.7, -2.0]), 0.4
    theta = d / r
    c, s = np.cos(theta), np.sin(theta)
    printed = np.zeros((2, 4, 4))
    printed[:, 0] = np.stack([c, s, 0 * c, d], -1)
    printed[:, 1] = np.stack([-s, c, 0 * c, np.full(2, r)], -1)
    printed[:, 2, 2] = printed[:, 3, 3] = 1.0
    np.testing.assert_allclose(wheel.rolling_matrix(d, r), printed, atol=1e-15)
    wrong_order = wheel.rotation_z(-theta) @ wheel.translation(d, r, 0.0)  # the R.T pitfall of PHYSICS.md 2
    assert not np.allclose(wrong_order, printed)


def test_rolling_matrix_has_zero_contact_point_velocity() -> None:
    d, r, h = np.array([0.0, 1.3, -4.0]), 0.5, 1e-5
    material = (wheel.rotation_z(d / r) @ np.array([0.0, -r, 0.0, 1.0]))[:, None, :3]  # at the bottom now
    ahead, behind = (wheel.transform(wheel.rolling_matrix(d + sign * h, r), material)[:, 0] for sign in (1, -1))
    np.testing.assert_allclose((ahead - behind) / (2 * h), 0.0, atol=1e-8)
    top = material.copy()
    top[:, 0, :2] *= -1.0  # the diametrically opposite point moves at twice the centre's speed
    up_a, up_b = (wheel.transform(wheel.rolling_matrix(d + sign * h, r), top)[:, 0] for sign in (1, -1))
    np.testing.assert_allclose((up_a - up_b) / (2 * h), [[2, 0, 0]] * 3, atol=1e-8)


@pytest.mark.parametrize("yaw_rate", [0.0, 1.5, -3.0])
def test_steerable_model_matrix_has_zero_contact_point_velocity(yaw_rate: float) -> None:
    pose, speed, h = poses(4, 4), np.array([0.5, 1.0, 2.0, 4.0]), 1e-6
    omega = np.full(4, yaw_rate)
    material = bottom_point(pose, WHEEL)[:, None]
    contact = wheel.transform(wheel.wheel_matrix(pose, WHEEL), material)[:, 0]
    np.testing.assert_allclose(contact, np.stack([pose.x, 0 * pose.x, pose.z], -1), atol=1e-14)
    ahead, behind = (
        wheel.transform(wheel.wheel_matrix(wheel.steer_step(pose, speed, omega, dt, WHEEL), WHEEL), material)[:, 0]
        for dt in (h, -h)
    )
    np.testing.assert_allclose((ahead - behind) / (2 * h), 0.0, atol=1e-8)
    centre = np.array([[0.0, 0.0, 0.0]] * 4)[:, None]
    c_ahead, c_behind = (
        wheel.transform(wheel.wheel_matrix(wheel.steer_step(pose, speed, omega, dt, WHEEL), WHEEL), centre)[:, 0]
        for dt in (h, -h)
    )
    np.testing.assert_allclose((c_ahead - c_behind) / (2 * h), speed[:, None] * wheel.forward(pose.heading), atol=1e-8)


def test_rolling_the_wrong_way_skids_so_the_no_slip_check_can_fail() -> None:
    pose, speed, h = poses(3, 5), np.full(3, 2.0), 1e-5

    def skidding(p: Pose) -> np.ndarray:  # book roll R_z(+alpha) on a model rolling toward +x
        return (
            wheel.translation(p.x, WHEEL.radius, p.z)
            @ wheel.rotation_y(p.heading - np.pi / 2)
            @ wheel.rotation_z(p.roll)
        )

    material = (wheel.rotation_z(-pose.roll) @ np.array([0.0, -WHEEL.radius, 0.0, 1.0]))[:, None, :3]
    ahead, behind = (
        wheel.transform(skidding(wheel.steer_step(pose, speed, np.zeros(3), dt, WHEEL)), material)[:, 0]
        for dt in (h, -h)
    )
    np.testing.assert_allclose(np.linalg.norm((ahead - behind) / (2 * h), axis=-1), 2 * speed, rtol=1e-6)


def test_model_matrix_matches_the_book_form_and_the_rolling_matrix() -> None:
    pose = poses(6, 6)
    ours = wheel.wheel_matrix(pose, WHEEL)
    book = (
        wheel.translation(pose.x, WHEEL.radius, pose.z)
        @ wheel.rotation_y(pose.heading + np.pi / 2)
        @ wheel.rotation_z(pose.roll)
    )
    np.testing.assert_allclose(ours, book @ wheel.rotation_y(np.full(6, np.pi)), atol=1e-14)
    forward_axis = ours[:, :3, :3] @ wheel.rotation_z(pose.roll)[:, :3, :3] @ np.array([1.0, 0.0, 0.0])
    np.testing.assert_allclose(forward_axis, wheel.forward(pose.heading), atol=1e-14)
    d = np.array([0.3, 2.5])
    along_x = Pose(d, np.zeros(2), np.full(2, np.pi / 2), d / WHEEL.radius)
    np.testing.assert_allclose(wheel.wheel_matrix(along_x, WHEEL), wheel.rolling_matrix(d, WHEEL.radius), atol=1e-15)


def test_gear_ratios_alternate_in_sign_and_the_idlers_cancel() -> None:
    assert wheel.mesh_ratio(2.0, 5.0) == pytest.approx(-0.4)
    assert wheel.mesh_ratio(2.0, 5.0, internal=True) == pytest.approx(0.4)
    radii = np.array([[1.0, 3.0, 0.5, 2.0, 4.0], [2.0, 7.0, 1.5, 9.0, 1.0]])
    speeds = wheel.train_speeds(np.array([3.0, -1.0]), radii)
    np.testing.assert_allclose(speeds[:, 1:] * radii[:, 1:], -speeds[:, :-1] * radii[:, :-1], rtol=1e-15)
    np.testing.assert_array_equal(np.sign(speeds[0]), [1, -1, 1, -1, 1])
    np.testing.assert_allclose(speeds[:, -1] / speeds[:, 0], wheel.train_ratio(radii), rtol=1e-15)
    np.testing.assert_allclose(wheel.train_ratio(radii), radii[:, 0] / radii[:, -1])
    np.testing.assert_allclose(wheel.train_ratio(radii[:, :4]), -radii[:, 0] / radii[:, 3])
    idlers = radii.copy()
    idlers[:, 1:-1] *= 1.7
    np.testing.assert_allclose(wheel.train_speeds(1.0, idlers)[:, -1], wheel.train_speeds(1.0, radii)[:, -1])
    teeth = np.array([12.0, 36.0, 24.0])
    assert wheel.train_ratio(teeth) == pytest.approx(0.5)


def test_batched_functions_equal_the_looped_ones_bit_for_bit() -> None:
    pose, n = poses(64, 7), 64
    r = np.random.default_rng(8)
    speed, yaw_rate = r.uniform(0, 3, n), np.where(r.random(n) < 0.2, 0.0, r.uniform(-4, 4, n))
    batched = wheel.steer_step(pose, speed, yaw_rate, 0.1, WHEEL)
    matrices = wheel.wheel_matrix(batched, WHEEL)
    for i in range(n):
        one = wheel.steer_step(Pose(*(c[i : i + 1] for c in pose)), speed[i : i + 1], yaw_rate[i : i + 1], 0.1, WHEEL)
        for got, want in zip(one, batched, strict=True):
            assert got[0] == want[i]
        np.testing.assert_array_equal(wheel.wheel_matrix(one, WHEEL)[0], matrices[i])


@pytest.mark.parametrize("radius", [0.0, -0.5, float("nan")])
def test_bad_radius_raises_value_error_naming_it(radius: float) -> None:
    with pytest.raises(ValueError, match=r"radius=.* is outside the allowed range \[1e-09, 1e\+09\]"):
        WheelParams(radius=radius)


def test_steer_step_wraps_the_heading_into_minus_pi_to_pi() -> None:
    pose = Pose(np.array([0.0]), np.array([0.0]), np.array([3.0]), np.array([0.0]))
    new = wheel.steer_step(pose, np.array([1.0]), np.array([1.0]), 0.5, WheelParams())
    assert new.heading[0] == 3.5 - 2.0 * np.pi


def test_the_oriented_arc_step_gives_the_sine_and_cosine_of_the_new_heading() -> None:
    """The sine and cosine come from turning the mid-step heading's by the half turn: within 2e-15 of those of the
    wrapped heading (the roundings of the mid-step heading and of the two sines and cosines), for any heading and
    turn (up to 6 rad a step here)."""
    rng = np.random.default_rng(0)
    for heading, yaw_rate in zip(rng.uniform(-np.pi, np.pi, 2000), rng.uniform(-60.0, 60.0, 2000), strict=True):
        heading_after = wheel.oriented_arc_step(1.0, -2.0, heading, 0.5, 1.7, yaw_rate, 0.1, 0.3)[2]
        sine, cosine = wheel.oriented_arc_step(1.0, -2.0, heading, 0.5, 1.7, yaw_rate, 0.1, 0.3)[4:]
        assert abs(sine - np.sin(heading_after)) <= 2e-15 and abs(cosine - np.cos(heading_after)) <= 2e-15
