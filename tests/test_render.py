"""Renderers: decorations stay few however large the scene; frames survive pygame.quit() and share one display;
views show what the state has (orientation, rest points, a state put back)."""

from __future__ import annotations

import gc
import math
import subprocess
import sys
import warnings
from collections import deque
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401
from vegym.envs.base import load_object
from vegym.render import canvas
from vegym.render import projectile_adjust as projectile_adjust_render
from vegym.render.bouncing_ball import SHOWN_FLIGHTS
from vegym.render.canvas import pygame
from vegym.render.gear_train import MOST_TEETH, TOOTH_PITCH, gear_outline
from vegym.render.pendulum_pump import TRAIL
from vegym.render.projectile import side_world
from vegym.render.projectile_adjust import beside_clear_of_ring


def record_calls(monkeypatch: pytest.MonkeyPatch, owner: Any, name: str) -> list[tuple]:
    """The positional arguments of every call of ``owner.name`` (a ``canvas`` function, or a ``Panel`` method with
    its panel first) from now on in the test; the calls still draw."""
    calls: list[tuple] = []
    draw = getattr(owner, name)

    def recording(*args: Any, **kwargs: Any) -> Any:
        calls.append(args)
        return draw(*args, **kwargs)

    monkeypatch.setattr(owner, name, recording)
    return calls


def test_tick_step_keeps_the_finest_spacing_when_few_and_steps_1_2_5_otherwise() -> None:
    assert canvas.tick_step(20.0, 5.0, 20) == 5.0
    assert canvas.tick_step(3.0, 0.5, 12) == 0.5
    assert [canvas.tick_step(extent, 1.0, 10) for extent in (15.0, 45.0, 95.0, 150.0)] == [2.0, 5.0, 10.0, 20.0]
    for extent in (1e3, 1e7, 1e12):
        step = canvas.tick_step(extent, 0.5, 12)
        assert extent / step <= 12 < extent / (step / 2.0)


def test_multiples_are_those_of_the_step_within_the_closed_range() -> None:
    np.testing.assert_allclose(canvas.multiples(-0.3, 1.0, 0.25), [-0.25, 0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(canvas.multiples(3.0, 68.9, 10.0), [10.0, 20.0, 30.0, 40.0, 50.0, 60.0])
    assert len(canvas.multiples(0.1, 0.2, 1.0)) == 0


def test_gear_teeth_keep_their_pitch_up_to_a_cap() -> None:
    radius = 0.08
    assert len(gear_outline(radius, 0.0, 0.004)) == 4 * round(2.0 * np.pi * radius / TOOTH_PITCH)
    assert len(gear_outline(1000.0, 0.0, 1.0)) == 4 * MOST_TEETH


@pytest.mark.parametrize(
    ("env_id", "params"),
    [
        ("vegym/GearTrain-v0", {"radius_min": 1000.0, "radius_max": 1000.0}),
        ("vegym/SteerableWheel-v0", {"arena_size": 1e7}),
        ("vegym/BouncingBall-v0", {"drop_height": 1e7}),
        ("vegym/Billiards-v0", {"target_radius": 1e5}),
        ("vegym/Suspension-v0", {"damping_min": 1000.0, "damping_max": 1000.0}),  # a fixed damper: no range
        ("vegym/Aircraft-v0", {"wind_x": 1e-300}),  # a wind whose np.linalg.norm underflows to 0
        ("vegym/Suspension-v0", {"slope_max": 1e9}),  # a road of cliffs: filled, it took pygame minutes a frame
    ],
)
def test_huge_and_degenerate_scenes_draw_their_frames(env_id: str, params: dict) -> None:
    env = gym.make(env_id, render_mode="rgb_array", **params)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 2  # a drawn scene, not a blank or filled frame


@pytest.mark.parametrize(("radius", "width"), [(27, 0), (27, 3), (40, 3), (40, 0), (80, 60), (1e7, 2)])
@pytest.mark.parametrize("center", [(20, 15), (3, 28)])
def test_circles_around_the_whole_surface_draw_the_pixels_pygame_draws(
    center: tuple[int, int], radius: float, width: int
) -> None:
    """One pixel per metre, y up: the shortcut for a circle around the whole surface (fill it, or nothing inside a
    ring's hole) draws what pygame's circle draws, which takes it seconds for a huge circle."""
    import pygame

    def panel() -> canvas.Panel:
        return canvas.Panel(canvas.new_surface(40, 30), (0, 0, 40, 30), (0.0, 40.0, 0.0, 30.0))

    shortcut = panel()
    shortcut.circle(center, radius, canvas.RED, width)
    if radius < 1e3:
        direct = panel()
        pygame.draw.circle(direct.surface, canvas.RED, direct.to_px(*center), round(radius), width)
        np.testing.assert_array_equal(canvas.to_array(shortcut.surface), canvas.to_array(direct.surface))
    else:
        assert not (canvas.to_array(shortcut.surface) == canvas.RED).all(axis=2).any()


def test_frames_still_draw_after_pygame_quit_elsewhere() -> None:
    """Gymnasium's HumanRendering.close() and classic-control envs call pygame.quit(), which stops the fonts; a
    stale font crashes the process when pygame was started again (so the check runs in a child process)."""
    check = (
        "import gymnasium as gym, numpy as np, pygame, vegym\n"
        "env = gym.make('vegym/GearTrain-v0', render_mode='rgb_array')\n"
        "env.reset(seed=0)\n"
        "before = env.render()\n"
        "pygame.quit()\n"
        "np.testing.assert_array_equal(env.render(), before)\n"
        "pygame.quit()\n"
        "pygame.init()\n"
        "np.testing.assert_array_equal(env.render(), before)\n"
    )
    child = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=120)
    assert child.returncode == 0, child.stderr[-2000:]


def test_human_windows_of_two_envs_take_turns_and_the_last_one_closed_closes_the_display() -> None:
    import pygame

    gears, pendulum = (
        gym.make(env_id, render_mode="human") for env_id in ("vegym/GearTrain-v0", "vegym/PendulumPump-v0")
    )
    sizes = []
    for env in (gears, pendulum):
        env.reset(seed=0)
        sizes.append(env.unwrapped._get_renderer().draw().shape[1::-1])
    assert sizes[0] != sizes[1]
    gears.step(gears.action_space.sample())
    assert pygame.display.get_surface().get_size() == sizes[0]  # not cropped to the other env's window
    gears.close()
    pendulum.step(pendulum.action_space.sample())
    assert pygame.display.get_init() and pygame.display.get_surface().get_size() == sizes[1]
    pendulum.close()
    assert not pygame.display.get_init()


def test_a_window_dropped_without_close_does_not_keep_the_display_open() -> None:
    import pygame

    dropped = gym.make("vegym/GearTrain-v0", render_mode="human")
    dropped.reset(seed=0)
    del dropped
    gc.collect()
    kept = gym.make("vegym/PendulumPump-v0", render_mode="human")
    kept.reset(seed=0)
    kept.close()
    assert not pygame.display.get_init()


def projectile_frame(wind: tuple[float, float, float], **params: float) -> np.ndarray:
    """A Projectile-v0 frame of a target 40 m along +x, level with the launcher, in the given wind (m/s)."""
    from vegym.render.projectile import ProjectileRenderer

    env = gym.make("vegym/Projectile-v0", **params)
    env.reset(seed=0)
    state = {name: value.copy() for name, value in env.unwrapped.state.items()}
    state["launch_position"][0] = (0.0, 1.0, 0.0)
    state["target"][0] = (40.0, 1.0, 0.0)
    state["wind"][0] = wind
    renderer = ProjectileRenderer(env.unwrapped.params)
    renderer.reset(state)
    return renderer.draw()


def test_projectile_top_view_is_seen_from_above_and_keeps_the_wind_arrow_inside() -> None:
    """+z (increasing azimuth, "across" for a target along +x) points down, as in the other top views; the arrow
    spans at most the view's half height (70 px) at wind_speed_max, any wind_speed_max."""
    from vegym.render import canvas

    top_rows = slice(320, 461)  # the top view's rectangle; its line of fire is row 390
    for wind_speed_max in (5.0, 20.0):
        frame = projectile_frame((0.0, 0.0, wind_speed_max), wind_speed_max=wind_speed_max, speed_max=60.0)
        rows, _ = np.nonzero(np.all(frame == canvas.GREEN, axis=-1))
        assert len(rows) > 0 and rows.min() >= top_rows.start - 1 and rows.max() < top_rows.stop
        assert rows.mean() > 390 + 20  # the arrow points down


@pytest.mark.parametrize("env_id", ["vegym/Projectile-v0", "vegym/ProjectileAdjust-v0"])
def test_projectile_views_take_in_every_shot_s_whole_flight_and_landing(
    env_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Random shots climb up to 66 m and land up to 110 m away: every drawn path point and landing lies inside its
    panel (half of such shots left a fixed view; ProjectileAdjust's landings beyond its panel are rings at its
    edge)."""
    drawn = [record_calls(monkeypatch, canvas.Panel, name) for name in ("polyline", "dot", "circle")]
    env = gym.make(env_id, render_mode="rgb_array")
    env.action_space.seed(2)
    for seed in range(20):
        env.reset(seed=seed)
        for _ in range(2 if env_id.endswith("Adjust-v0") else 1):
            env.step(env.action_space.sample())
        for calls in drawn:
            calls.clear()
        env.render()
        shapes = [(panel, np.reshape(points, (-1, 2))) for calls in drawn for panel, points, *_ in calls]
        assert len(shapes) >= 3
        for panel, points in shapes:
            rect = panel.rect.inflate(2, 2)
            assert all(rect.collidepoint(x, y) for x, y in panel.pixels(points)), (seed, rect)


@pytest.mark.parametrize("env_id", ["vegym/Projectile-v0", "vegym/ProjectileAdjust-v0"])
def test_projectile_side_views_number_the_distance_along_the_ground(
    env_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The side views had no numbers: marks every 1, 2, 5, 10, ... m from the launcher (0) past the target."""
    texts = record_calls(monkeypatch, canvas, "text")  # (surface, lines, xy, size, colour)
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    info = env.step(np.zeros(3, np.float32))[-1]
    env.render()
    env.close()
    marks = [float(lines[0]) for _, lines, _, size, *_ in texts if size == canvas.TICK_LABEL_SIZE]
    step = marks[1] - marks[0]
    assert step in (5.0, 10.0, 20.0) and 0.0 in marks and "-0" not in [lines[0] for _, lines, *_ in texts]
    np.testing.assert_allclose(np.diff(marks), step)
    assert marks[-1] > np.hypot(*(info["target"] - info["launch_position"])[[0, 2]])


def test_projectile_side_view_height_is_in_proportion_to_the_scene() -> None:
    """At least 1.6 times the highest launch or a seventh of the reach: a 3 m scene had a 16 m tall view."""
    along = np.array([1.0, 0.0, 0.0])
    assert side_world(3.45, 0.4, 0.5, [], along)[3] == pytest.approx(0.8)  # 1.6 * max(0.5, 3.45 / 7)
    assert side_world(69.0, 15.0, 20.0, [], along)[3] == pytest.approx(32.0)  # the defaults: 1.6 * 20 m
    assert side_world(69.0, 1.0, 2.0, [], along)[3] == pytest.approx(1.6 * 69.0 / 7.0)
    path = np.array([[0.0, 0.0, 0.0], [10.0, 30.0, 0.0]])  # a lob above it widens it
    assert side_world(69.0, 15.0, 20.0, [path], along)[3] == pytest.approx(1.05 * 45.0)


def test_projectile_adjust_shot_numbers_stay_off_the_hit_ring() -> None:
    """A landing beside the ring (inside or outside) had its number written across the ring's line."""
    centre, radius, size = (120, 120), 40.0, canvas.text_size(["3"], 18)  # a shot's number as drawn
    on_ring = np.linspace(0.0, 2.0 * np.pi, 2000)
    ring = np.stack([np.cos(on_ring), np.sin(on_ring)], -1) * radius + centre
    for distance in (radius - 6.0, radius - 2.0, radius + 2.0, radius + 6.0, 5.0):
        for angle in np.linspace(0.0, 2.0 * np.pi, 48, endpoint=False):
            dot = (round(centre[0] + distance * np.cos(angle)), round(centre[1] + distance * np.sin(angle)))
            left, top = beside_clear_of_ring(dot, size, centre, radius)
            inside = (
                (ring[:, 0] > left) & (ring[:, 0] < left + size[0]) & (ring[:, 1] > top) & (ring[:, 1] < top + size[1])
            )
            assert not inside.any(), (distance, angle)


@pytest.mark.parametrize(
    ("env_id", "seconds", "marked"),
    [
        ("vegym/Aircraft-v0", 0.0, (0.0, 300.0)),
        ("vegym/GearTrain-v0", 0.0, (0.0, 10.0)),
        ("vegym/PendulumPump-v0", 0.0, (0.0, 40.0)),
        ("vegym/Thread-v0", 0.0, (0.0, 2.0)),
        ("vegym/Suspension-v0", 6.5, (2.0, 6.0)),
    ],
)
def test_strip_charts_number_their_time_axis_under_the_lowest_chart(
    env_id: str, seconds: float, marked: tuple[float, float], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The time axes gave their range in words alone: marks every 1, 2, 5, 10, ... s over the shown window (the
    episode's planned length, Thread's first 2 s, Suspension's last 5 s), under the lowest chart."""
    frames = record_calls(monkeypatch, canvas.Panel, "frame")  # (panel, colour)
    texts = record_calls(monkeypatch, canvas, "text")  # (surface, lines, xy, size, colour)
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(round(seconds / env.unwrapped.params.dt)):
        env.step(np.zeros(env.action_space.shape, np.float32))
    frames.clear()
    texts.clear()
    env.render()
    env.close()
    marks = [(float(lines[0]), xy) for _, lines, xy, size, *_ in texts if size == canvas.TICK_LABEL_SIZE]
    times = np.array([t for t, _ in marks])
    assert (times[0], times[-1]) == marked
    np.testing.assert_allclose(np.diff(times), times[1] - times[0])
    charts = [panel for panel, *_ in frames if panel.rect.left <= marks[0][1][0] + 10 <= panel.rect.right]
    lowest = max(charts, key=lambda panel: panel.rect.bottom)
    assert all(lowest.rect.bottom <= y <= lowest.rect.bottom + 5 for _, (_, y) in marks)


def test_a_long_time_axis_numbers_its_marks_in_full(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 1e6 s episode ended its axis on "1e+06" beside "900000"."""
    texts = record_calls(monkeypatch, canvas, "text")  # (surface, lines, xy, size, colour)
    env = gym.make("vegym/Aircraft-v0", render_mode="rgb_array", dt=10.0, episode_steps=100_000)
    env.reset(seed=0)
    env.render()
    env.close()
    marks = [lines[0] for _, lines, _, size, *_ in texts if size == canvas.TICK_LABEL_SIZE]
    assert marks[-2:] == ["900000", "1000000"]


def test_aircraft_strip_labels_sit_above_their_charts(monkeypatch: pytest.MonkeyPatch) -> None:
    """Written inside the charts' top-left corners, the labels were crossed by a heading near +180 deg (the chart's
    top, unpadded) or by an altitude or airspeed near its largest value."""
    frames = record_calls(monkeypatch, canvas.Panel, "frame")  # (panel, colour): the top view, then the charts
    texts = record_calls(monkeypatch, canvas, "text")  # (surface, lines, xy, size, colour)
    env = gym.make("vegym/Aircraft-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    env.close()
    written = {lines[0]: (xy, size) for _, lines, xy, size, *_ in texts}
    charts = [panel for panel, *_ in frames[1:]]
    assert len(charts) == 3
    for label, chart in zip(["altitude (m)", "airspeed (m/s)", "heading (deg)"], charts, strict=True):
        (x, y), size = written[label]
        assert y + size <= chart.rect.top and chart.rect.left <= x < chart.rect.right


def test_aircraft_is_drawn_nose_first_along_its_heading_and_a_horizontal_wind_as_an_arrow(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The marker is an aircraft whose nose (its outline's point farthest from the position) lies along the
    heading, seen from above (screen right -x, up +z); a horizontal wind gets an arrow along it (the
    near-equilateral triangle drawn before read as pointing elsewhere, and no view showed the wind)."""
    polygons, arrows = (record_calls(monkeypatch, canvas.Panel, name) for name in ("polygon", "arrow"))
    for wind in ((0.0, 0.0), (30.0, -20.0)):
        env = gym.make("vegym/Aircraft-v0", render_mode="rgb_array", wind_x=wind[0], wind_z=wind[1])
        for seed in range(3):
            env.reset(seed=seed)
            env.step(np.zeros(3, np.float32))
            polygons.clear()
            arrows.clear()
            env.render()
            state = env.unwrapped.state
            heading, (x, _, z) = float(state["heading"][0]), state["position"][0]
            ((_, outline, *_),) = polygons
            nose = outline[np.argmax(np.linalg.norm(outline - (-x, z), axis=1))] - (-x, z)
            assert math.atan2(nose[1], nose[0]) == pytest.approx(math.atan2(math.cos(heading), -math.sin(heading)))
            winds = [vector for _, _, vector, *_ in arrows if not np.allclose(vector[0], 0.0)]  # +z's is vertical
            if wind == (0.0, 0.0):
                assert winds == []
            else:
                (shown,) = winds
                assert math.atan2(shown[1], shown[0]) == pytest.approx(math.atan2(wind[1], -wind[0]))


def test_billiards_frame_after_the_strike_takes_in_both_rest_points(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every ball circle drawn (starts, contact and rest points) has its centre inside the table's rectangle,
    for random strikes, which send the balls far."""
    circles = record_calls(monkeypatch, canvas.Panel, "circle")
    env = gym.make("vegym/Billiards-v0", render_mode="rgb_array")
    env.action_space.seed(1)
    for seed in range(30):
        env.reset(seed=seed)
        env.step(env.action_space.sample())
        circles.clear()
        env.render()
        assert len(circles) >= 4
        for panel, center, *_ in circles:
            (x, y), rect = panel.to_px(*center), panel.rect
            assert rect.collidepoint(x, y), (seed, (x, y), rect)


def test_billiards_draws_balls_visible_a_grid_over_the_whole_table_and_says_how_a_missing_a_went(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A hard strike zooms the table out to A's rest point 15 m away: the balls and the target ring keep a radius
    of at least 4 px (B was 4 px across), the grid spans the table (it stopped at 5 m) and the text tells a strike
    that passes beside B from one that stops short of it (every miss without contact was "stops short")."""
    from vegym.render.billiards import CLOTH_LINE

    circles, lines, texts = (
        record_calls(monkeypatch, canvas.Panel, "circle"),
        record_calls(monkeypatch, canvas.Panel, "line"),
        record_calls(monkeypatch, canvas, "text"),
    )
    env = gym.make("vegym/Billiards-v0", render_mode="rgb_array")
    for seed, action, how in ((13, (1.0, 1.0), "passes beside B"), (13, (0.0, -0.95), "stops short of B")):
        env.reset(seed=seed)
        info = env.step(np.array(action, np.float32))[-1]
        assert not info["contact"]
        circles.clear(), lines.clear(), texts.clear()
        env.render()
        assert min(panel.length_px(radius) for panel, _, radius, *_ in circles) >= 4
        assert any(how in line for _, shown, *_ in texts for line in shown)
        grid = [(panel.to_px(*a), panel.to_px(*b), panel) for panel, a, b, color, *_ in lines if color == CLOTH_LINE]
        rect = grid[0][2].rect
        vertical = [(a, b) for a, b, _ in grid if a[0] == b[0]]
        horizontal = [(a, b) for a, b, _ in grid if a[1] == b[1]]
        for drawn, axis, low, high in ((vertical, 0, rect.left, rect.right), (horizontal, 1, rect.top, rect.bottom)):
            at = sorted(a[axis] for a, _ in drawn)
            spacing = max(np.diff(at))
            assert at[0] - low <= spacing and high - at[-1] <= spacing + 1  # from edge to edge
        assert all(abs(b[1] - a[1]) >= rect.height - 2 for a, b in vertical)  # across the whole table


def test_a_steerable_wheel_that_leaves_a_small_arena_is_drawn_inside_the_view(monkeypatch: pytest.MonkeyPatch) -> None:
    """The view's margin takes in a wheel a step past the border (4% of a 4 m arena was less than the wheel); its
    footprint is the polyline 6 px wide."""
    polylines = record_calls(monkeypatch, canvas.Panel, "polyline")
    env = gym.make("vegym/SteerableWheel-v0", render_mode="rgb_array", arena_size=4.0, waypoint_margin=0.5)
    env.reset(seed=0)
    terminated = False
    while not terminated:
        _, _, terminated, _, info = env.step(np.array([1.0, 0.0], np.float32))
    assert info["reward_terms"]["exit"] < 0.0
    polylines.clear()
    env.render()
    ((panel, footprint),) = [(panel, points) for panel, points, _, *width in polylines if width == [6]]
    assert all(panel.rect.collidepoint(x, y) for x, y in panel.pixels(footprint))


def test_a_state_put_back_restarts_the_renderers_record_from_it() -> None:
    """The frame after a snapshot is put back shows that state alone, not the trail of the steps it undid."""
    env = gym.make("vegym/SteerableWheel-v0", render_mode="rgb_array")
    env.reset(seed=0)
    action = np.array([1.0, 0.3], np.float32)
    for _ in range(10):
        env.step(action)
    snapshot = {name: value.copy() for name, value in env.unwrapped.state.items()}
    for _ in range(40):
        env.step(action)
    env.unwrapped.state = snapshot
    renderer = load_object(env.unwrapped.task.renderer)(env.unwrapped.params)
    renderer.reset({name: value.copy() for name, value in snapshot.items()})
    np.testing.assert_array_equal(env.render(), renderer.draw())
    # at a step: envs with other histories, the same snapshot put back, draw the same frame after it
    twins = [gym.make("vegym/SteerableWheel-v0", render_mode="rgb_array") for _ in range(2)]
    for steps, twin in zip((0, 30), twins, strict=True):
        twin.reset(seed=1)
        for _ in range(steps):
            twin.step(action)
        twin.unwrapped.state = {name: value.copy() for name, value in snapshot.items()}
        twin.step(action)
    np.testing.assert_array_equal(twins[0].render(), twins[1].render())


def test_panels_draw_nothing_outside_their_rectangle() -> None:
    """Scenes that parameters push past their panel (a trail, a terrain, a thread) stay off the text around it."""
    surface = canvas.new_surface(60, 40)
    panel = canvas.Panel(surface, (10, 10, 30, 20), (0.0, 1.0, 0.0, 1.0))
    far = [(-50.0, -50.0), (50.0, 40.0), (-30.0, 60.0)]
    panel.polyline(np.array(far), canvas.RED, 5)
    panel.line(far[0], far[1], canvas.RED, 5)
    panel.polygon(np.array(far), canvas.RED)
    panel.circle((0.5, 0.5), 3.0, canvas.RED)
    panel.dot((0.5, 0.5), 100, canvas.RED)
    panel.arrow((-10.0, 0.5), (30.0, 0.0), canvas.RED, 5)
    frame = canvas.to_array(surface)
    inside = np.zeros(frame.shape[:2], bool)
    inside[10:30, 10:40] = True
    assert (frame[inside] == canvas.RED).all() and (frame[~inside] == canvas.WHITE).all()
    assert surface.get_clip() == surface.get_rect()  # the surface's clip is left as it was


def test_the_bouncing_ball_is_drawn_to_the_scale_of_the_height_axis(monkeypatch: pytest.MonkeyPatch) -> None:
    """Its radius in pixels is the radius in metres times the height axis' pixels per metre (the time axis' scale,
    used before, drew a 0.5 m ball 1.85 times too tall and shrank it as the episode went on)."""
    dots = []
    monkeypatch.setattr(canvas.Panel, "dot", lambda panel, center, pixels, color: dots.append((panel, pixels)))
    env = gym.make("vegym/BouncingBall-v0", render_mode="rgb_array", radius=0.5, target_min=0.6)
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.ones(1, np.float32))  # full restitution: never at rest (an unseeded sample could end the episode)
        dots.clear()
        env.render()
        panel, pixels = dots[-1]  # the ball, drawn last
        assert pixels == round(0.5 * panel.rect.height / (1.08 * env.unwrapped.params.drop_height))


def test_bouncing_ball_marks_its_shown_targets_legibly_and_none_once_at_rest(monkeypatch: pytest.MonkeyPatch) -> None:
    """The shown targets' marks take a share of the time axis, so they stay wide in long flights (fixed 0.2 s marks
    were 2-5 px at gravity 1.6), each at its height and inside the panel; a ball at rest shows none and says so."""
    lines, texts = record_calls(monkeypatch, canvas.Panel, "line"), record_calls(monkeypatch, canvas, "text")

    def marks() -> list[tuple[canvas.Panel, Any, Any]]:
        return [(panel, a, b) for panel, a, b, color, *_ in lines if color in (canvas.RED, canvas.ORANGE)]

    env = gym.make("vegym/BouncingBall-v0", render_mode="rgb_array", gravity=1.6)
    env.reset(seed=3)
    for _ in range(10):
        env.step(np.array([0.5], np.float32))
        lines.clear()
        env.render()
        state = env.unwrapped.state
        ahead = [(panel, a, b) for panel, a, b in marks() if a[0] >= state["time"][0]]  # not the past targets' dashes
        assert [a[1] for _, a, _ in ahead] == list(state["targets"][0])
        for panel, a, b in ahead:
            (x0, _), (x1, y1) = panel.to_px(*a), panel.to_px(*b)
            assert x1 - x0 >= 30 and panel.rect.collidepoint(x1, y1)
    env.reset(seed=1)
    env.step(np.array([-1.0], np.float32))  # e = 0: at rest
    texts.clear()
    lines.clear()
    env.render()
    assert not [a for _, a, _ in marks() if a[1] in env.unwrapped.state["targets"][0]]
    assert any("at rest" in line for _, shown, *_ in texts for line in shown)


def test_a_human_window_shows_a_frame_at_least_every_second(monkeypatch: pytest.MonkeyPatch) -> None:
    """BouncingBall with little gravity steps 0.03 times a second: real time would hold the window 33 s a frame."""
    import pygame

    ticks = []

    class Clock:
        def tick(self, fps: float = 0.0) -> None:
            ticks.append(fps)

    monkeypatch.setattr(pygame.time, "Clock", Clock)
    env = gym.make("vegym/BouncingBall-v0", render_mode="human", gravity=0.01)
    assert env.metadata["render_fps"] < 0.1
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
    assert ticks and min(ticks) >= 1.0


def test_small_gears_are_drawn_with_teeth_in_proportion(monkeypatch: pytest.MonkeyPatch) -> None:
    """Teeth 3 mm deep on 2-3 mm gears crossed their centres: star-shaped blades instead of gears."""
    polygons = record_calls(monkeypatch, canvas.Panel, "polygon")
    env = gym.make("vegym/GearTrain-v0", render_mode="rgb_array", radius_min=0.002, radius_max=0.003)
    env.reset(seed=0)
    env.render()
    assert polygons
    for _, points, *_ in polygons:
        distance = np.linalg.norm(points - points.mean(axis=0), axis=1)
        assert distance.min() > 0.8 * distance.max()


def test_gear_labels_never_overlap_even_under_small_neighbouring_gears(monkeypatch: pytest.MonkeyPatch) -> None:
    """Seed 22 of an 8-gear train has gears of 2.04 and 2.02 cm side by side: their labels were written over each
    other."""
    texts = record_calls(monkeypatch, canvas, "text")  # (surface, lines, xy, size, colour)
    env = gym.make("vegym/GearTrain-v0", render_mode="rgb_array", gears_min=8, gears_max=8)
    env.reset(seed=22)
    env.render()
    boxes = []
    for _, lines, (x, y), size, *_ in texts:
        if lines[-1].startswith("r = "):
            boxes.append(pygame.Rect((x, y), canvas.text_size(lines, size)))
    env.close()
    assert len(boxes) == 8
    assert all(box.collidelist(boxes[:k]) < 0 for k, box in enumerate(boxes))


def test_gear_train_draws_the_target_of_the_error_it_reports_and_a_next_one_apart(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The green target is the one of the step drawn (info's ``target_angle``, whose error the text reports); after
    a step at which the target changes, the new one is drawn too, in black (it drew only the new one, in green)."""
    dots = record_calls(monkeypatch, canvas.Panel, "dot")  # (panel, centre, pixels, colour)
    env = gym.make("vegym/GearTrain-v0", render_mode="rgb_array")
    env.reset(seed=3)
    task, interval = env.unwrapped.task, env.unwrapped.params.interval_steps
    for step in range(1, interval + 2):
        info = env.step(np.array([0.4], np.float32))[-1]
        dots.clear()
        env.render()
        output_x = [centre[0] for _, centre, pixels, _ in dots if pixels == 3][-1]  # gears' centres, output last
        targets = {colour: math.atan2(y, x - output_x) for _, (x, y), pixels, colour in dots if pixels == 5}
        assert math.sin(targets[canvas.GREEN] - info["target_angle"]) == pytest.approx(0.0, abs=1e-9)
        assert math.cos(targets[canvas.GREEN] - info["target_angle"]) > 0.0
        upcoming = float(task.target(env.unwrapped.state["key"], env.unwrapped.state["step"])[0])
        assert (canvas.BLACK in targets) == (step % interval == 0) == (upcoming != info["target_angle"])
        if canvas.BLACK in targets:
            assert math.sin(targets[canvas.BLACK] - upcoming) == pytest.approx(0.0, abs=1e-9)


def test_long_episodes_draw_a_bounded_history(monkeypatch: pytest.MonkeyPatch) -> None:
    """BouncingBall shows its latest flights, and a long line is thinned: frames of long episodes stay legible and
    quick (a frame drew every flight: 0.9 s and a solid blue block at 5,000 bounces)."""
    import pygame

    from vegym.render.bouncing_ball import SHOWN_FLIGHTS

    drawn = []
    lines = pygame.draw.lines
    monkeypatch.setattr(
        pygame.draw,
        "lines",
        lambda surface, color, closed, points, width: (
            drawn.append(len(points)) or lines(surface, color, closed, points, width)
        ),
    )
    env = gym.make(
        "vegym/BouncingBall-v0", render_mode="rgb_array", episode_bounces=100, max_episode_steps=100, rest_speed=0.0
    )
    env.reset(seed=0)
    for _ in range(2 * SHOWN_FLIGHTS):
        env.step(np.ones(1, np.float32))
    drawn.clear()
    env.render()
    assert len(drawn) == SHOWN_FLIGHTS  # the flights shown; the drop, long before them, is out of view

    panel = canvas.Panel(canvas.new_surface(40, 30), (0, 0, 40, 30), (0.0, 1.0, 0.0, 1.0))
    drawn.clear()
    t = np.linspace(0.0, 1.0, 100_000)
    panel.polyline(np.stack([t, t * t], axis=-1), canvas.BLUE)
    assert drawn == [4 * (40 + 30)]


def test_a_polygon_far_beyond_its_panel_is_cut_to_a_margin_and_fills_the_pixels_of_the_whole(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """pygame fills every pixel row between a polygon's lowest and highest vertex, clipped or not: Suspension's
    road of slope 1e6 took minutes a frame. The cut polygon that pygame gets, filled or outlined, lies within
    CLIP_MARGIN of the panel, and a filled one draws the pixels that the whole one draws (one reaching 4,000 px out,
    which pygame still fills quickly), but on its edges, where the cut's new vertices, rounded to pixels, may move
    a pixel over."""
    rng = np.random.default_rng(1)
    polygons = [rng.uniform(-100.0, 150.0, (12, 2)) for _ in range(20)]
    polygons += [np.array([[-5.0, -5.0], [5.0, 4000.0], [60.0, 20.0], [30.0, -900.0]])]
    drawn: list[list[list[int]]] = []
    draw = pygame.draw.polygon

    def recording(surface: Any, color: Any, points: list[list[int]], width: int = 0) -> Any:
        drawn.append(points)
        return draw(surface, color, points, width)

    def panel() -> canvas.Panel:
        return canvas.Panel(canvas.new_surface(70, 50), (10, 10, 50, 30), (0.0, 40.0, 0.0, 20.0))

    filled = 0
    for points in polygons:
        whole = panel()
        draw(whole.surface, canvas.RED, whole.pixels(points))  # unclipped, then the panel's rectangle alone
        expected = canvas.to_array(whole.surface)
        outside = np.ones(expected.shape[:2], bool)
        outside[10:40, 10:60] = False  # the rectangle (10, 10, 50, 30): 50 px wide, 30 tall
        expected[outside] = canvas.WHITE
        cut, outline = panel(), panel()
        with monkeypatch.context() as patch:
            patch.setattr(pygame.draw, "polygon", recording)
            cut.polygon(points, canvas.RED)
            outline.polygon(points, canvas.RED, 3)
        red = (expected == canvas.RED).all(axis=2)
        windows = np.lib.stride_tricks.sliding_window_view(np.pad(red, 1, mode="edge"), (3, 3))
        on_edge = windows.any(axis=(2, 3)) & ~windows.all(axis=(2, 3))
        differs = (canvas.to_array(cut.surface) != expected).any(axis=2)
        assert not (differs & ~on_edge).any()
        filled += red.sum() > 100
    margin = canvas.CLIP_MARGIN
    assert filled > 15 and len(drawn) > 30
    assert all(-margin <= x - 10 <= 50 + margin and -margin <= y - 10 <= 30 + margin for p in drawn for x, y in p)


def test_a_polygon_cut_to_a_box_keeps_the_part_inside_it() -> None:
    box = (0.0, 0.0, 10.0, 10.0)

    def area(points: np.ndarray) -> float:
        x, y = points.T
        return 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))

    inside = np.array([[1.0, 1.0], [9.0, 2.0], [5.0, 8.0]])
    np.testing.assert_array_equal(canvas.clip_polygon(inside, box), inside)
    assert canvas.clip_polygon(np.array([[20.0, 0.0], [30.0, 0.0], [25.0, 5.0]]), box).shape == (0, 2)
    around = canvas.clip_polygon(np.array([[-1e9, -1e9], [1e9, -1e9], [1e9, 1e9], [-1e9, 1e9]]), box)
    assert area(around) == 100.0 and np.abs(around).max() <= 10.0
    half = canvas.clip_polygon(np.array([[5.0, -5.0], [15.0, -5.0], [15.0, 15.0], [5.0, 15.0]]), box)
    assert area(half) == 50.0 and half[:, 0].min() == 5.0 and half[:, 0].max() == 10.0


def test_a_panel_maps_many_points_to_the_pixels_it_maps_each_to() -> None:
    panel = canvas.Panel(canvas.new_surface(100, 80), (5, 5, 90, 70), (-3.3, 7.1, -2.2, 5.5))
    points = np.random.default_rng(0).uniform(-5.0, 9.0, (1000, 2))
    assert panel.pixels(points) == [list(panel.to_px(x, y)) for x, y in points]


def ink(frame: np.ndarray, color: canvas.Color) -> np.ndarray:
    """(row, col) of the pixels of ``color``."""
    return np.argwhere(np.all(frame == color, axis=-1))


def test_an_equal_aspect_panel_shows_its_whole_world_box_at_one_scale() -> None:
    """The smaller of the two scales: a 10 m x 10 m box in a 200 x 100 px rectangle is 100 px tall, not 200."""
    panel = canvas.Panel(canvas.new_surface(200, 100), (0, 0, 200, 100), (0.0, 10.0, 0.0, 10.0), equal_aspect=True)
    assert panel.scale == (10.0, 10.0)
    rect = panel.rect.inflate(2, 2)
    assert all(rect.collidepoint(*panel.to_px(x, y)) for x in (0.0, 10.0) for y in (0.0, 10.0))


def test_a_circle_s_radius_is_measured_along_x() -> None:
    panel = canvas.Panel(canvas.new_surface(100, 100), (0, 0, 100, 100), (0.0, 10.0, 0.0, 50.0))  # 10 px/m, 2 px/m
    assert panel.length_px(3.0) == 30
    panel.circle((5.0, 25.0), 3.0, canvas.RED)
    cols = ink(canvas.to_array(panel.surface), canvas.RED)[:, 1]
    assert cols.max() - cols.min() + 1 == pytest.approx(60, abs=2)


def test_a_dashed_line_is_drawn_as_its_dashes() -> None:
    panel = canvas.Panel(canvas.new_surface(100, 20), (0, 0, 100, 20), (0.0, 100.0, 0.0, 20.0))
    panel.dashed((0.0, 10.0), (100.0, 10.0), canvas.RED, dashes=5)
    row = np.all(canvas.to_array(panel.surface)[10] == canvas.RED, axis=-1)
    runs = np.flatnonzero(np.diff(row.astype(int)) == 1).size + int(row[0])
    assert runs == 5 and 40 <= row.sum() <= 60  # 5 dashes, about half of the length


def test_an_arrow_has_its_head_at_the_end() -> None:
    panel = canvas.Panel(canvas.new_surface(100, 40), (0, 0, 100, 40), (0.0, 100.0, 0.0, 40.0))
    panel.arrow((10.0, 20.0), (80.0, 0.0), canvas.RED, 1)  # from x = 10 to x = 90 px
    cols = ink(canvas.to_array(panel.surface), canvas.RED)[:, 1]
    height = np.bincount(cols, minlength=100)
    assert height[80:91].max() >= 5 and height[10:21].max() <= 2  # the head's width near the end alone


def test_text_writes_each_line_below_the_last_at_the_font_s_line_spacing() -> None:
    surface = canvas.new_surface(60, 80)
    canvas.text(surface, ["H", "H"], (5, 5), 18)
    rows = np.unique(np.argwhere(np.any(canvas.to_array(surface) != canvas.WHITE, axis=-1))[:, 0])
    bands = np.split(rows, np.flatnonzero(np.diff(rows) > 1) + 1)
    assert len(bands) == 2
    assert bands[1][0] - bands[0][0] == canvas.line_height(18) >= canvas.font(18).get_linesize()


def test_a_window_shows_the_frame_s_colours_and_takes_its_own_title() -> None:
    from vegym.render.window import Window

    frame = np.zeros((30, 40, 3), np.uint8)
    frame[...] = canvas.RED
    first, second = Window("first", 1000.0), Window("second", 1000.0)
    try:
        first.show(frame)
        assert tuple(pygame.display.get_surface().get_at((5, 5)))[:3] == canvas.RED
        second.show(frame)  # the same size: the display must still take the second's title
        assert pygame.display.get_caption()[0] == "second"
    finally:
        first.close()
        second.close()


@pytest.mark.skipif(sys.platform != "linux", reason="SDL finds the native display without DISPLAY elsewhere")
def test_human_rendering_without_a_display_warns_once_that_nothing_is_shown(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    pygame.display.quit()  # started again by the window, where SDL falls back to a driver that shows nothing
    env = gym.make("vegym/Projectile-v0", render_mode="human")
    try:
        with pytest.warns(UserWarning, match="ProjectileEnv: no display to show render_mode='human' on"):
            env.reset(seed=0)
        pygame.display.quit()  # stopped elsewhere: the window starts it again, and SDL falls back again
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            env.step(np.zeros(3, np.float32))
    finally:
        env.close()


def test_the_clock_s_second_hand_points_down_at_half_a_minute() -> None:
    from vegym.render import clock

    surface = canvas.new_surface(100, 100)
    clock.draw_clock(surface, 30.0, (50, 50), 40)
    frame = canvas.to_array(surface)
    assert tuple(frame[50 + 26, 50]) == canvas.RED and tuple(frame[50 - 26, 50]) != canvas.RED


def test_bouncing_ball_flights_are_parabolas_from_the_floor_to_their_apex(monkeypatch: pytest.MonkeyPatch) -> None:
    polylines = record_calls(monkeypatch, canvas.Panel, "polyline")
    env = gym.make("vegym/BouncingBall-v0", render_mode="rgb_array")
    env.reset(seed=0)
    info = env.step(np.zeros(1, np.float32))[-1]
    polylines.clear()
    env.render()
    flight = np.asarray(polylines[-1][1])  # the flight just flown, drawn last
    radius = env.unwrapped.params.radius
    assert flight[0, 1] == pytest.approx(radius) and flight[-1, 1] == pytest.approx(radius, abs=1e-9)
    assert flight[:, 1].max() == pytest.approx(info["apex_height"], rel=0.01)


def billiards_strike(monkeypatch: pytest.MonkeyPatch, seed: int, action: tuple[float, float]) -> tuple:
    circles, lines = (record_calls(monkeypatch, canvas.Panel, name) for name in ("circle", "line"))
    env = gym.make("vegym/Billiards-v0", render_mode="rgb_array")
    env.reset(seed=seed)
    state = {k: v.copy() for k, v in env.unwrapped.state.items()}
    info = env.step(np.array(action, np.float32))[-1]
    circles.clear(), lines.clear()
    env.render()
    return env, state, info, circles, lines


def test_billiards_draws_bearings_clockwise_the_balls_to_scale_and_b_s_path_from_b(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from vegym.envs.billiards import BilliardsTask
    from vegym.render.billiards import BALL_B, SMALLEST_BALL

    for seed in range(10):
        env, state, info, circles, lines = billiards_strike(monkeypatch, seed, (0.3, 0.0))
        p = env.unwrapped.params
        _, along, across = BilliardsTask.line_frame(state)
        a, b, target = state["ball_a"][0], state["ball_b"][0], state["target"][0]
        # the target ring comes first: screen y (world, up) is minus the target's offset across the line
        panel, drawn, *_ = circles[0]
        assert drawn[1] == pytest.approx(-float((target - a) @ across[0]))
        for panel, _, radius, *_ in circles:  # balls as large as they are, or 4 px
            largest = max(p.radius_a, p.radius_b, p.target_radius)
            assert panel.length_px(radius) <= max(panel.scale[0] * largest, SMALLEST_BALL) + 1
        if info["contact"]:
            ((_, start, *_),) = [call for call in lines if call[3] == BALL_B]
            np.testing.assert_allclose(start, [float((b - a) @ along[0]), -float((b - a) @ across[0])], atol=1e-12)


def test_gear_outlines_turn_with_their_angle() -> None:
    angle = 0.3
    turned = gear_outline(0.05, angle, 0.002)
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    np.testing.assert_allclose(turned, gear_outline(0.05, 0.0, 0.002) @ rotation.T, atol=1e-12)


def test_gear_hubs_lie_inside_their_gears(monkeypatch: pytest.MonkeyPatch) -> None:
    polygons, circles = (record_calls(monkeypatch, canvas.Panel, name) for name in ("polygon", "circle"))
    env = gym.make("vegym/GearTrain-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.render()
    assert len(polygons) == len(circles) >= 2
    for (_, outline, *_), (_, centre, radius, *_) in zip(polygons, circles, strict=True):
        assert radius < np.linalg.norm(outline - centre, axis=1).min()


def test_pendulum_is_drawn_anticlockwise_with_its_torque_and_a_bounded_trail(monkeypatch: pytest.MonkeyPatch) -> None:
    from vegym.render.pendulum_pump import TRAIL

    circles, arrows = (record_calls(monkeypatch, canvas.Panel, name) for name in ("circle", "arrow"))
    env = gym.make("vegym/PendulumPump-v0", render_mode="rgb_array")
    env.reset(seed=0)
    length = env.unwrapped.params.length
    for torque in (1.0, -1.0) * 30:
        env.step(np.array([torque], np.float32))
    circles.clear(), arrows.clear()
    env.render()
    theta = float(env.unwrapped.state["theta"][0])
    bob = [centre for _, centre, _, color, *_ in circles if color == canvas.RED][-1]
    np.testing.assert_allclose(bob, length * np.array([np.sin(theta), -np.cos(theta)]), atol=1e-9)
    ((_, start, vector, *_),) = arrows  # the last torque, -1: clockwise about the pivot
    assert start[0] * vector[1] - start[1] * vector[0] < 0.0
    assert len(env.unwrapped._get_renderer().bobs) <= TRAIL + 1


def adjust_renderer(wind: tuple[float, float, float], shots: list[tuple[float, float]]):  # noqa: ANN201
    """A ProjectileAdjust renderer of a target 40 m along +x with the given wind and shots (miss along, across)."""
    from vegym.render.projectile_adjust import ProjectileAdjustRenderer

    env = gym.make("vegym/ProjectileAdjust-v0")
    env.reset(seed=0)
    state = {name: value.copy() for name, value in env.unwrapped.state.items()}
    state["launch_position"][0], state["target"][0], state["wind"][0] = (0.0, 1.0, 0.0), (40.0, 1.0, 0.0), wind
    renderer = ProjectileAdjustRenderer(env.unwrapped.params)
    renderer.reset(state)
    for along, across in shots:
        renderer.shots.append(
            {"launch_velocity": np.array([20.0, 10.0, 0.0]), "wind": np.array(wind), "flight_time": 2.0,
             "miss_along": along, "miss_across": across, "miss_distance": math.hypot(along, across),
             "is_success": False}
        )  # fmt: skip
    return renderer


def test_projectile_adjust_top_view_fires_upward_with_bearing_to_the_right(monkeypatch: pytest.MonkeyPatch) -> None:
    """A landing 3 m long and 1 m to the right is a dot 3 m up and 1 m right; a tail wind is an arrow upward."""
    dots, arrows = record_calls(monkeypatch, canvas.Panel, "dot"), record_calls(monkeypatch, canvas.Panel, "arrow")
    adjust_renderer((3.0, 0.0, 0.0), [(3.0, 1.0)]).draw()
    ((_, landing, *_),) = dots
    np.testing.assert_allclose(landing, (1.0, 3.0))
    ((_, _, vector, *_),) = arrows
    assert vector[0] == pytest.approx(0.0) and vector[1] > 0.0


def test_steerable_wheel_trail_and_arrow_follow_the_wheel(monkeypatch: pytest.MonkeyPatch) -> None:
    polylines, arrows = (record_calls(monkeypatch, canvas.Panel, name) for name in ("polyline", "arrow"))
    env = gym.make("vegym/SteerableWheel-v0", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(15):
        env.step(np.array([1.0, 0.4], np.float32))
    polylines.clear(), arrows.clear()
    env.render()
    x, z = env.unwrapped.state["position"][0]
    ((_, trail, *_),) = [call for call in polylines if call[2] == canvas.BLUE]
    np.testing.assert_allclose(trail[-1], (x, -z))  # the trail ends at the wheel (z down)
    ((_, centre, ahead, *_),) = arrows
    assert np.dot(ahead, trail[-1] - trail[-2]) > 0.0  # the arrow points the way the wheel rolls


def test_suspension_wheel_sits_on_the_road_between_its_bump_stops(monkeypatch: pytest.MonkeyPatch) -> None:
    from vegym.render.suspension import WHEEL_PIXELS

    polylines, lines = (record_calls(monkeypatch, canvas.Panel, name) for name in ("polyline", "line"))
    env = gym.make("vegym/Suspension-v0", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(30):
        info = env.step(np.zeros(1, np.float32))[-1]
    polylines.clear(), lines.clear()
    env.render()
    s, p = env.unwrapped.state, env.unwrapped.params
    x, base, height = float(s["distance"][0]), float(s["base"][0]), float(s["height"][0])
    panel, ground, *_ = polylines[0]  # the road, drawn first
    nearest = ground[np.argmin(np.abs(ground[:, 0] - x))]
    assert panel.to_px(*nearest)[1] - panel.to_px(x, base)[1] == pytest.approx(WHEEL_PIXELS, abs=2)
    stops = sorted(a[1] for _, a, _, color, *width in lines if color == canvas.RED and width == [3])
    bottom = height - info["travel"]  # where the body's bottom rests
    np.testing.assert_allclose(stops, [bottom - p.travel_limit, bottom + p.travel_limit])


def test_thread_colours_stretched_springs_and_draws_forces_along_them(monkeypatch: pytest.MonkeyPatch) -> None:
    lines, arrows = (record_calls(monkeypatch, canvas.Panel, name) for name in ("line", "arrow"))
    env = gym.make("vegym/Thread-v0", render_mode="rgb_array")
    env.reset(seed=0)
    info = env.step(np.full(env.action_space.shape, 0.5, np.float32))[-1]
    lines.clear(), arrows.clear()
    env.render()
    p = env.unwrapped.params
    springs = [(a, b, color) for _, a, b, color, *width in lines if width == [3]]
    assert len(springs) == p.n_nodes + 1
    for a, b, color in springs:
        stretched = np.linalg.norm(np.subtract(b, a)) > p.natural_length
        assert color == (canvas.BLACK if stretched else canvas.ORANGE)
    assert len(arrows) == len(info["forces"])
    for (_, _, vector, *_), force in zip(arrows, info["forces"], strict=True):
        assert np.dot(vector, force) > 0.0


def test_aircraft_heading_chart_breaks_its_line_where_the_heading_wraps() -> None:
    from vegym.render.aircraft import AircraftRenderer

    t = np.arange(4.0)
    segments = AircraftRenderer._unwrapped_segments(t, np.array([170.0, 179.0, -179.0, -170.0]), True)
    assert [len(segment) for segment in segments] == [2, 2]


@pytest.mark.parametrize(
    "env_id", ["vegym/Aircraft-v0", "vegym/Suspension-v0", "vegym/PendulumPump-v0", "vegym/GearTrain-v0"]
)
def test_a_renderer_keeps_the_latest_steps_of_an_episode_without_a_time_limit(
    env_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The renderers kept every step of an episode and drew them all: without a time limit, memory and frame time
    grew with it (Aircraft-v0: 23.6 MB more and 54 ms a frame after 50,000 steps; a helper's review). They keep the
    latest ``canvas.HISTORY`` now, and GearTrain's strip still puts its errors at their steps' times."""
    monkeypatch.setattr(canvas, "HISTORY", 8)
    env = gym.make(env_id, render_mode="rgb_array", max_episode_steps=-1)
    env.reset(seed=0)
    for _ in range(40):  # within the first episode of each of these envs
        env.step(np.zeros(env.action_space.shape, np.float32))
    renderer = env.unwrapped._renderer
    kept = {name: len(value) for name, value in vars(renderer).items() if isinstance(value, list | deque)}
    assert kept and all(length <= max(8, TRAIL + 1) for length in kept.values()), kept
    polylines = record_calls(monkeypatch, canvas.Panel, "polyline")
    assert env.render().shape[2] == 3
    if env_id == "vegym/GearTrain-v0":
        (errors,) = [points for _, points, *_ in polylines if np.shape(points) == (8, 2)]
        np.testing.assert_allclose(errors[:, 0], 0.05 * np.arange(33, 41))  # steps 33 to 40 of 0.05 s
        dashes = record_calls(monkeypatch, canvas.Panel, "dashed")
        renderer.state["step"][0] = 10**6  # far on: the strip spans the kept steps, not a million of them
        env.render()
        changes = [start for _, start, end, *_ in dashes if start[1] == -180.0 and end[1] == 180.0]
        assert 1 <= len(changes) <= 2 and all(49_999.6 <= x <= 50_010.0 for x, _ in changes), changes


@pytest.mark.filterwarnings("ignore:.*step\\(\\) after the episode terminated")  # stepped past it on purpose
def test_projectile_adjust_keeps_the_latest_shots_of_steps_past_the_end_and_counts_them_all(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Steps past the end without a reset fire more shots: the renderer kept one more each, without bound. It keeps
    the latest ``KEPT_SHOTS`` now, and numbers them and times the flights over all of them."""
    monkeypatch.setattr(projectile_adjust_render, "KEPT_SHOTS", 4)
    env = gym.make("vegym/ProjectileAdjust-v0", render_mode="rgb_array", max_episode_steps=-1)
    env.reset(seed=0)
    flight_times = []
    for _ in range(10):
        flight_times.append(env.step(np.zeros(3, np.float32))[4]["flight_time"])
    renderer = env.unwrapped._renderer
    assert len(renderer.shots) == 4 and renderer.fired == 10 and renderer.elapsed == sum(flight_times)
    texts = record_calls(monkeypatch, canvas, "text")
    env.render()
    shown = [line for _, lines, *_ in texts for line in lines]
    assert any("shot 10 of 3" in line for line in shown)
    assert [line.split(":")[0] for line in shown if line.startswith("shot ") and ":" in line][-1] == "shot 10"


def test_the_bouncing_ball_keeps_the_flights_it_shows_and_counts_every_bounce() -> None:
    env = gym.make("vegym/BouncingBall-v0", render_mode="rgb_array", episode_bounces=60, max_episode_steps=60)
    env.reset(seed=0)
    for _ in range(45):
        env.step(np.ones(1, np.float32))  # restitution 1: no ball comes to rest
    renderer = env.unwrapped._renderer
    assert renderer.bounces == 45 and len(renderer.flights) == SHOWN_FLIGHTS + 1
    env.render()
