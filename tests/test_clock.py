"""The clock of 8.2.4 (PHYSICS.md section 4): hand angles, anticlockwise hands, and the clock in every frame."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vegym
from agents.analytic import controller_for
from vegym.physics import clock

HOUR = 3600.0


def test_the_chapters_angles_at_three_and_half_past_six() -> None:
    np.testing.assert_allclose(clock.hand_angles(3, 0, 0), [90.0, 90.0, 0.0])
    np.testing.assert_allclose(clock.hand_angles_at(3 * HOUR), [90.0, 90.0, 0.0])
    np.testing.assert_allclose(clock.hand_angles_at(6.5 * HOUR)[2], -105.0)
    np.testing.assert_allclose(clock.hand_angles(15, 0, 0), clock.hand_angles(3, 0, 0))  # hrs mod 12
    np.testing.assert_allclose(clock.hand_angles_at(15 * HOUR), clock.hand_angles_at(3 * HOUR))
    hrs, minutes, sec = clock.clock_reading(np.array([13 * HOUR + 25 * 60 + 7.25]))
    np.testing.assert_allclose([hrs[0], minutes[0], sec[0]], [1.0, 25.0, 7.25])


def test_the_hands_coincide_every_twelve_elevenths_of_an_hour_and_the_minute_hand_is_twelve_times_faster() -> None:
    t = np.arange(11) * 12.0 / 11.0 * HOUR
    angles = clock.hand_angles_at(t)
    gap = np.mod(angles[:, 1] - angles[:, 2] + 180.0, 360.0) - 180.0
    np.testing.assert_allclose(gap, 0.0, atol=1e-9)
    halfway = clock.hand_angles_at(t + 6.0 / 11.0 * HOUR)
    assert np.all(np.abs(np.mod(halfway[:, 1] - halfway[:, 2], 360.0) - 180.0) < 1e-9)  # opposite in between
    start, later = clock.hand_angles_at(np.array([1000.0, 1000.0 + 0.5 * HOUR]))
    assert (later[1] - start[1]) == pytest.approx(12.0 * (later[2] - start[2]))
    assert later[2] - start[2] == pytest.approx(-15.0)  # clockwise on the dial: the angle decreases


def test_the_second_hand_sweeps_continuously_across_minute_and_hour_boundaries() -> None:
    t = np.array([59.5, 60.0, 60.5, HOUR - 0.5, HOUR, HOUR + 0.5, 12 * HOUR - 0.5, 12 * HOUR])
    steps = np.diff(clock.hand_angles_at(t), axis=0)
    steps = np.mod(steps + 180.0, 360.0) - 180.0
    for k in (0, 1, 3, 4, 6):
        np.testing.assert_allclose(steps[k], [-3.0, -0.05, -0.5 / 120.0], atol=1e-9)


def test_hands_turn_anticlockwise_with_r_z_plus_theta_not_the_mirroring_rolling_matrix() -> None:
    times = np.array([3 * HOUR, 9 * HOUR, 6 * HOUR + 45 * 60 + 45])
    tips = clock.hand_tips(clock.hand_angles_at(times), np.array([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(tips[0], [[0.0, 1.0], [0.0, 2.0], [3.0, 0.0]], atol=1e-12)  # 3:00:00
    np.testing.assert_allclose(tips[1], [[0.0, 1.0], [0.0, 2.0], [-3.0, 0.0]], atol=1e-12)  # 9:00:00
    np.testing.assert_allclose(tips[2][0], [-1.0, 0.0], atol=1e-12)  # 6:45:45: the second hand at 9
    assert tips[2][1, 0] < -1.9 and tips[2][1, 1] > 0.1  # the minute hand just past 9, on the way to 10 (clockwise)
    assert tips[2][2, 0] < 0.0 and tips[2][2, 1] < 0.0  # the hour hand between 7 and 8


def clock_pixels(seconds: float) -> tuple[np.ndarray, int]:
    from vegym.render import canvas
    from vegym.render import clock as clock_render

    surface = canvas.new_surface(100, 100)
    clock_render.draw_clock(surface, seconds, (50, 50), 40)
    return canvas.to_array(surface), 40


def test_the_drawn_face_shows_the_hour_minute_and_second_hands_where_they_point() -> None:
    from vegym.render import canvas

    frame, r = clock_pixels(3 * HOUR)
    assert tuple(frame[50, 50 + r // 3]) == canvas.BLACK and tuple(frame[50, 50 - r // 3]) == canvas.WHITE
    frame, r = clock_pixels(15 * 60.0)  # 12:15:00
    assert tuple(frame[50, 50 + 2 * r // 3]) == canvas.BLACK and tuple(frame[50, 50 - 2 * r // 3]) == canvas.WHITE
    frame, r = clock_pixels(15.0)
    assert tuple(frame[50, 50 + 2 * r // 3]) == canvas.RED and tuple(frame[50, 50 - 2 * r // 3]) == canvas.WHITE


def elapsed_seconds(env_id: str, env: gym.Env, info: dict, total_flight: float) -> float:
    """The simulation time each env's frame should show after its steps so far (``info`` of the last step)."""
    if env_id == "vegym/BouncingBall-v0":
        return float(env.unwrapped.state["time"][0])
    if env_id == "vegym/Projectile-v0":
        return float(info.get("flight_time", 0.0))
    if env_id == "vegym/ProjectileAdjust-v0":
        return total_flight
    if env_id == "vegym/Billiards-v0":
        return float(info.get("duration", 0.0))
    return float(env.unwrapped.state["step"][0]) * env.unwrapped.params.dt


@pytest.mark.parametrize("env_id", list(vegym.ENVS))
def test_every_frame_draws_one_clock_at_the_simulation_time(env_id: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from vegym.render import clock as clock_render

    calls: list[float] = []
    draw = clock_render.draw_clock

    def recording_draw(surface, seconds, center, radius) -> None:  # noqa: ANN001
        calls.append(seconds)
        draw(surface, seconds, center, radius)

    monkeypatch.setattr(clock_render, "draw_clock", recording_draw)
    env = gym.make(env_id, render_mode="rgb_array")
    controller = controller_for(env)
    obs, _ = env.reset(seed=2)
    env.render()
    assert calls == [pytest.approx(elapsed_seconds(env_id, env, {}, 0.0), rel=1e-12)]
    total_flight = 0.0
    for _ in range(3):
        obs, _, terminated, truncated, info = env.step(controller.predict(obs)[0])
        total_flight += info.get("flight_time", 0.0)
        calls.clear()
        env.render()
        assert calls == [pytest.approx(elapsed_seconds(env_id, env, info, total_flight), rel=1e-12)]
        assert calls[0] > 0.0
        if terminated or truncated:
            break


def test_clock_reading_is_whole_hours_whole_minutes_and_the_seconds_left_over() -> None:
    seconds = np.array([3 * HOUR + 59 * 60 + 40.5, 13 * HOUR + 30 * 60 + 29.0, 11 * HOUR + 59 * 60 + 59.75])
    hrs, minutes, sec = clock.clock_reading(seconds)
    np.testing.assert_array_equal(hrs, [3.0, 1.0, 11.0])
    np.testing.assert_array_equal(minutes, [59.0, 30.0, 59.0])
    np.testing.assert_allclose(sec, [40.5, 29.0, 59.75], rtol=0, atol=1e-9)
    second_hand = clock.hand_angles_at(seconds)[:, 0]
    assert np.all((second_hand > -270.0) & (second_hand <= 90.0))  # 90 - 6 sec with sec in [0, 60)
