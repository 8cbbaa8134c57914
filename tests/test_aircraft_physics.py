"""First-order aircraft: closed forms of PHYSICS.md section 10, the autopilot's step responses, the book variant."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vegym.physics import aircraft
from vegym.physics.aircraft import AircraftParams, AutopilotGains

PARAMS = AircraftParams()
GAINS = AutopilotGains()


def fly(state: aircraft.AircraftState, command: np.ndarray, dt: float, steps: int, params: AircraftParams = PARAMS):
    """Positions (steps + 1, n, 3), headings and the final state under a constant command."""
    positions, headings = [state.position], [state.heading]
    for _ in range(steps):
        state, _ = aircraft.step(state, command, dt, params)
        positions.append(state.position)
        headings.append(state.heading)
    return np.array(positions), np.array(headings), state


@pytest.mark.parametrize("turn", [1.0, -1.0])
def test_standard_rate_turn_closes_its_circle_of_radius_v_over_m(turn: float) -> None:
    v, m, dt = 100.0, aircraft.STANDARD_RATE, 0.5
    radius = v / m
    assert radius == pytest.approx(1909.86, abs=0.01)
    start = aircraft.initial_state([[10.0, 1000.0, -20.0]], v, 0.3)
    steps = round(2 * math.pi / m / dt)
    assert steps * dt == pytest.approx(120.0)
    positions, _, end = fly(start, np.array([[0.0, 0.0, turn * m]]), dt, steps)
    left = np.array([math.cos(0.3), 0.0, -math.sin(0.3)])
    centre = start.position[0] + turn * radius * left
    distance = np.linalg.norm((positions[:, 0] - centre)[:, [0, 2]], axis=-1)
    np.testing.assert_allclose(distance, radius, rtol=0, atol=1e-9)
    np.testing.assert_allclose(end.position, start.position, rtol=0, atol=1e-9)
    assert end.heading[0] == pytest.approx(0.3, abs=1e-12)


def test_straight_flight_covers_v_t_along_the_heading() -> None:
    headings = np.array([0.0, 1.0, -2.5, math.pi / 2])
    start = aircraft.initial_state(np.tile([0.0, 500.0, 0.0], (4, 1)), 120.0, headings)
    positions, _, end = fly(start, np.zeros((4, 3)), 0.5, 200)
    forward = np.stack([np.sin(headings), np.zeros(4), np.cos(headings)], axis=-1)
    np.testing.assert_allclose(end.position, start.position + 120.0 * 100.0 * forward, rtol=0, atol=1e-9)


def test_constant_wind_drifts_the_track_by_w_t() -> None:
    windy = AircraftParams(wind_x=3.0, wind_z=-4.0)
    start = aircraft.initial_state([[0.0, 500.0, 0.0]], 100.0, 0.0)
    _, _, calm = fly(start, np.zeros((1, 3)), 1.0, 50)
    _, _, drifted = fly(start, np.zeros((1, 3)), 1.0, 50, windy)
    np.testing.assert_allclose(drifted.position - calm.position, [[150.0, 0.0, -200.0]], atol=1e-9)


@pytest.mark.parametrize(("climb", "rate"), [(1e3, 15.0), (-1e3, -10.0)])
def test_saturated_climb_takes_dy_over_the_climb_limit(climb: float, rate: float) -> None:
    dy, dt = 1500.0 if rate > 0 else -1000.0, 0.5
    start = aircraft.initial_state([[0.0, 2000.0, 0.0]], 100.0, 0.0)
    steps = round(dy / rate / dt)
    assert steps * dt == pytest.approx(100.0)
    positions, _, _ = fly(start, np.array([[0.0, climb, 0.0]]), dt, steps)
    np.testing.assert_allclose(positions[:, 0, 1], 2000.0 + rate * dt * np.arange(steps + 1), atol=1e-9)


def test_climb_rate_includes_the_vertical_wind_and_the_floor_cuts_it() -> None:
    start = aircraft.initial_state([[0.0, 20.0, 0.0], [0.0, 1000.0, 0.0]], 100.0, 0.0)
    command = np.array([[0.0, -10.0, 0.0], [0.0, 5.0, 0.0]])
    state, climb = aircraft.step(start, command, 2.0, PARAMS, vertical_wind=np.array([-3.0, 2.5]))
    np.testing.assert_allclose(climb, [-10.0, 7.5])  # -13 m/s for 2 s would go 6 m below the floor
    np.testing.assert_allclose(state.position[:, 1], [0.0, 1015.0])


def test_speed_is_clipped_with_the_mean_acceleration() -> None:
    start = aircraft.initial_state([[0.0, 1000.0, 0.0]], 199.0, 0.0)
    state, _ = aircraft.step(start, np.array([[1.5, 0.0, 0.0]]), 2.0, PARAMS)
    assert state.speed[0] == 200.0
    assert state.position[0, 2] == pytest.approx(0.5 * (199.0 + 200.0) * 2.0, abs=1e-12)


def step_response(dt: float, gains: AutopilotGains, demand: np.ndarray, start: aircraft.AircraftState, steps: int):
    """Errors (steps + 1, n, 3) of the autopilot flying toward ``demand``."""
    state = start
    errors = [aircraft.tracking_errors(state, demand)]
    for _ in range(steps):
        state, _ = aircraft.step(state, aircraft.autopilot(errors[-1], PARAMS, gains), dt, PARAMS)
        errors.append(aircraft.tracking_errors(state, demand))
    return np.array(errors)


@pytest.mark.parametrize(
    ("dt", "gains"),
    [(0.5, GAINS), (2.0, GAINS), (1.0, AutopilotGains(speed_gain=1.0, climb_gain=1.0, heading_gain=1.0))],
)
def test_autopilot_reaches_step_demands_without_overshoot_when_k_dt_at_most_one(dt: float, gains) -> None:
    start = aircraft.initial_state(np.array([[0.0, 1000.0, 0.0], [0.0, 1500.0, 0.0]]), [100.0, 150.0], [0.0, 3.0])
    demand = np.array([[1500.0, 150.0, math.radians(120.0)], [1000.0, 100.0, -3.0]])
    errors = step_response(dt, gains, demand, start, round(400.0 / dt))
    signs = np.sign(errors[0])
    assert np.all(errors * signs >= 0.0), "an error changed sign: overshoot"
    assert np.all(np.diff(np.abs(errors), axis=0) <= 1e-12), "an error grew"
    np.testing.assert_allclose(errors[-1], 0.0, atol=1e-6)
    assert errors[0, 1, 2] == pytest.approx(2 * math.pi - 6.0)  # 3 rad to -3 rad: the short way, through pi


def test_autopilot_is_three_saturated_p_loops_on_the_wrapped_heading_error() -> None:
    """``(clip(k_a v_err, -A_dec, A_acc), clip(k_v y_err, -V_des, V_cli), clip(k_psi wrap(psi_err), -M, M))`` on
    errors (altitude, speed, heading) that saturate and heading errors past +-pi (section 10)."""
    rng = np.random.default_rng(3)
    errors = np.column_stack([rng.uniform(-500, 500, 200), rng.uniform(-80, 80, 200), rng.uniform(-9.0, 9.0, 200)])
    errors[:4, 2] = [3.5, -3.5, 2 * math.pi + 0.01, -0.01]  # 3.5 rad to the left is 2 pi - 3.5 to the right
    command = aircraft.autopilot(errors, PARAMS, GAINS)
    p = PARAMS
    np.testing.assert_array_equal(
        command[:, 0], np.clip(GAINS.speed_gain * errors[:, 1], -p.max_deceleration, p.max_acceleration)
    )
    np.testing.assert_array_equal(
        command[:, 1], np.clip(GAINS.climb_gain * errors[:, 0], -p.max_descent_rate, p.max_climb_rate)
    )
    heading_error = (errors[:, 2] + math.pi) % (2 * math.pi) - math.pi
    np.testing.assert_allclose(
        command[:, 2], np.clip(GAINS.heading_gain * heading_error, -p.max_turn_rate, p.max_turn_rate), atol=1e-15
    )
    turn = p.max_turn_rate  # gain 0.5: 0.1 rad of error saturates it
    np.testing.assert_allclose(command[:4, 2], [-turn, turn, 0.005, -0.005], atol=1e-15)
    for column, low, high in zip(command.T, p.command_low, p.command_high, strict=True):
        assert low in column and high in column  # every limit binds somewhere


def test_autopilot_overshoots_when_k_dt_exceeds_one() -> None:
    start = aircraft.initial_state([[0.0, 1000.0, 0.0]], 100.0, 0.0)
    errors = step_response(1.0, AutopilotGains(climb_gain=1.5), np.array([[1010.0, 100.0, 0.0]]), start, 5)
    assert errors[:, 0, 0].min() < 0.0


def test_heading_is_always_wrapped() -> None:
    rng = np.random.default_rng(0)
    state = aircraft.initial_state(np.zeros((64, 3)), rng.uniform(60, 200, 64), rng.uniform(-10, 10, 64))
    for k in range(400):
        assert np.all((state.heading >= -math.pi) & (state.heading < math.pi))
        command = aircraft.command_from_action(rng.choice([-1.0, 1.0], (64, 3)) * (k % 7 != 0), PARAMS)
        state, _ = aircraft.step(state, command, 2.0, PARAMS)
    edges = np.array([math.pi, -math.pi, 3 * math.pi, -1e-300 - math.pi, math.nextafter(math.pi, 0.0)])
    wrapped = aircraft.wrap(edges)
    assert np.all((wrapped >= -math.pi) & (wrapped < math.pi))
    assert wrapped[0] == -math.pi


def test_wrap_is_the_floor_formula_bit_for_bit() -> None:
    """The branch-free wrap equals ``a - 2 pi floor((a + pi) / 2 pi)`` with -pi for round-off onto pi, evaluated
    by Python (exact integer floor), on random angles, huge ones and the neighbourhoods of the jumps."""
    rng = np.random.default_rng(5)
    pieces = [rng.uniform(-10 * np.pi, 10 * np.pi, 100_000), rng.uniform(-1e15, 1e15, 20_000)]
    pieces.append(np.ldexp(rng.uniform(-1.0, 1.0, 20_000), rng.integers(-1074, 1023, 20_000)))
    for m in range(-4, 4):  # around the odd multiples of pi, where the wrap jumps
        edge = (2 * m + 1) * np.pi
        pieces.append(edge + rng.integers(-2000, 2000, 10_000) * np.spacing(edge))
    edges = [0.0, -0.0, math.pi, -math.pi, 2 * math.pi, math.nextafter(math.pi, 0.0), math.nextafter(-math.pi, -4.0)]
    x = np.concatenate([*pieces, edges, [5e-324, -5e-324, 1e300, -1e300]])

    def reference(a: float) -> float:
        wrapped = a - 2.0 * math.pi * math.floor((a + math.pi) / (2.0 * math.pi))
        return max(-math.pi if wrapped >= math.pi else wrapped, -math.pi)

    expected = np.array([reference(a) for a in x])
    np.testing.assert_array_equal(aircraft.wrap(x).view(np.int64), expected.view(np.int64))


def test_actions_map_asymmetrically_onto_the_saturation_box() -> None:
    commands = aircraft.command_from_action(np.array([[1.0, 1.0, 1.0], [-1.0, -1.0, -1.0], [0.5, -0.5, 0.0]]), PARAMS)
    np.testing.assert_allclose(commands[0], [1.5, 15.0, aircraft.STANDARD_RATE])
    np.testing.assert_allclose(commands[1], [-2.0, -10.0, -aircraft.STANDARD_RATE])
    np.testing.assert_allclose(commands[2], [0.75, -5.0, 0.0])
    actions = np.random.default_rng(1).uniform(-1, 1, (100, 3))
    np.testing.assert_allclose(
        aircraft.action_from_command(aircraft.command_from_action(actions, PARAMS), PARAMS), actions
    )


def book_heading_after(dt: float, book: bool) -> float:
    """Heading (deg) after 2 s of flying toward a 1 degree heading demand at 100 m/s."""
    params = AircraftParams(book_faithful=book)
    state = aircraft.initial_state([[0.0, 1000.0, 0.0]], 100.0, 0.0)
    demand = np.array([[1000.0, 100.0, math.radians(1.0)]])
    for _ in range(round(2.0 / dt)):
        if book:
            command = aircraft.book_autopilot(state, demand, dt, params, GAINS)
        else:
            command = aircraft.autopilot(aircraft.tracking_errors(state, demand), params, GAINS)
        state, _ = aircraft.step(state, command, dt, params)
    return math.degrees(state.heading[0])


def test_book_heading_law_turn_rate_scales_as_one_over_dt() -> None:
    book = [book_heading_after(dt, True) for dt in (0.1, 0.05, 0.01)]
    assert [round(h, 2) for h in book] == [0.18, 0.33, 0.87]  # PHYSICS.md section 10, k_phi = 1 m/s/rad
    clean = [book_heading_after(dt, False) for dt in (0.1, 0.05, 0.01)]
    assert max(clean) - min(clean) < 0.02 * max(clean)


def test_book_variant_lags_the_commands_by_one_step_and_flies_the_old_heading() -> None:
    params = AircraftParams(book_faithful=True)
    start = aircraft.initial_state([[0.0, 1000.0, 0.0]], 100.0, 0.5)
    command = np.array([[1.0, 10.0, 2.0]])
    first, climb = aircraft.step(start, command, 1.0, params)
    assert climb[0] == 0.0 and first.speed[0] == 100.0 and first.heading[0] == 0.5
    second, climb = aircraft.step(first, np.zeros((1, 3)), 1.0, params)
    assert climb[0] == 10.0 and second.speed[0] == 101.0
    assert second.heading[0] == pytest.approx(0.5 + math.atan(2.0 / 100.0))
    np.testing.assert_allclose(second.position - first.position, [[100.5 * math.sin(0.5), 10.0, 100.5 * math.cos(0.5)]])


def test_book_lateral_velocity_saturates_at_v_tan_m_dt_so_a_step_turns_at_most_m_dt() -> None:
    """PHYSICS.md section 10: the book's lateral velocity is limited to ``V = v tan(M dt)``, so that the heading
    change ``atan(v_x / v)`` of a step is at most ``M dt`` whatever the command."""
    params = AircraftParams(book_faithful=True)
    dt, speed = 0.5, 100.0
    assert aircraft.lateral_limit(np.array([speed]), dt, params)[0] == pytest.approx(
        speed * math.tan(params.max_turn_rate * dt), rel=1e-12
    )
    for sign in (1.0, -1.0):
        start = aircraft.initial_state([[0.0, 1000.0, 0.0]], speed, 0.2)
        first, _ = aircraft.step(start, np.array([[0.0, 0.0, sign * 1e3]]), dt, params)  # lagged by a step
        second, _ = aircraft.step(first, np.zeros((1, 3)), dt, params)
        assert second.heading[0] == pytest.approx(0.2 + sign * params.max_turn_rate * dt, rel=1e-12)


def test_lagged_speed_loop_diverges_at_k_dt_above_one_where_the_clean_loop_converges() -> None:
    wide = {"max_acceleration": 1e6, "max_deceleration": 1e6, "min_speed": 1e-3, "max_speed": 1e9}
    gains = AutopilotGains(speed_gain=1.1)
    final = {}
    for book in (False, True):
        params = AircraftParams(book_faithful=book, **wide)
        state = aircraft.initial_state([[0.0, 1000.0, 0.0]], 1000.0, 0.0)
        demand = np.array([[1000.0, 1010.0, 0.0]])
        for _ in range(100):
            state, _ = aircraft.step(
                state, aircraft.autopilot(aircraft.tracking_errors(state, demand), params, gains), 1.0, params
            )
        final[book] = abs(state.speed[0] - 1010.0)
    assert final[False] < 1e-9 and final[True] > 10.0


@pytest.mark.parametrize("book", [False, True])
def test_batched_step_equals_looped_steps_bit_for_bit(book: bool) -> None:
    params = AircraftParams(book_faithful=book, wind_x=1.0, wind_z=-2.0, ceiling_altitude=3000.0)
    rng = np.random.default_rng(3)
    n = 50
    state = aircraft.initial_state(rng.uniform(0, 3000, (n, 3)), rng.uniform(60, 200, n), rng.uniform(-4, 4, n))
    states = [aircraft.AircraftState(*(np.array(f[i : i + 1]) for f in state)) for i in range(n)]
    for _ in range(20):
        demand = np.stack([rng.uniform(0, 3000, n), rng.uniform(60, 200, n), rng.uniform(-4, 4, n)], -1)
        wind = rng.uniform(-5, 5, n)
        if book:
            command = aircraft.book_autopilot(state, demand, 0.7, params, GAINS)
        else:
            command = aircraft.autopilot(aircraft.tracking_errors(state, demand), params, GAINS)
        state, climb = aircraft.step(state, command, 0.7, params, wind)
        for i in range(n):
            if book:
                c = aircraft.book_autopilot(states[i], demand[i : i + 1], 0.7, params, GAINS)
            else:
                c = aircraft.autopilot(aircraft.tracking_errors(states[i], demand[i : i + 1]), params, GAINS)
            assert np.array_equal(c, command[i : i + 1])
            states[i], climb_i = aircraft.step(states[i], c, 0.7, params, wind[i : i + 1])
            assert np.array_equal(climb_i, climb[i : i + 1])
    for field, batched in zip(aircraft.AircraftState._fields, state, strict=True):
        assert np.array_equal(np.concatenate([getattr(s, field) for s in states]), batched), field


@pytest.mark.parametrize(
    ("cls", "kwargs", "name"),
    [
        (AircraftParams, {"max_speed": 50.0}, "max_speed"),
        (AircraftParams, {"max_turn_rate": -0.1}, "max_turn_rate"),
        (AircraftParams, {"max_climb_rate": 0.0}, "max_climb_rate"),
        (AircraftParams, {"ceiling_altitude": -1.0}, "ceiling_altitude"),
        (AircraftParams, {"book_faithful": 1}, "book_faithful"),
        (AutopilotGains, {"climb_gain": 0.0}, "climb_gain"),
        (AutopilotGains, {"heading_gain": float("nan")}, "heading_gain"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(cls, kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        cls(**kwargs)


def test_book_heading_law_rejects_a_step_beyond_a_quarter_turn() -> None:
    with pytest.raises(ValueError, match="dt"):
        aircraft.lateral_limit(np.array([100.0]), 40.0, PARAMS)


def test_book_heading_law_rejects_a_step_of_exactly_a_quarter_turn() -> None:
    params = AircraftParams(max_turn_rate=math.pi, book_faithful=True)  # M dt = pi / 2 exactly at dt = 0.5
    with pytest.raises(ValueError, match="dt=0.5 is outside the allowed range"):
        aircraft.lateral_limit(np.array([100.0]), 0.5, params)


def test_book_autopilot_does_not_wrap_the_heading_error() -> None:
    """8.126 as printed: from psi = -3 to psi_d = 3 the raw error +6 turns left the long way (wrapped: -0.28, right)."""
    params = AircraftParams(book_faithful=True)
    state = aircraft.initial_state(np.zeros((1, 3)), 100.0, -3.0)
    demand = np.array([[0.0, 100.0, 3.0]])
    command = aircraft.book_autopilot(state, demand, 0.5, params, AutopilotGains())
    assert command[0, 2] == pytest.approx(float(aircraft.lateral_limit(np.array([100.0]), 0.5, params)[0]), rel=1e-12)


def test_equal_speed_limits_are_refused() -> None:
    with pytest.raises(ValueError, match="max_speed"):
        AircraftParams(min_speed=100.0, max_speed=100.0)
