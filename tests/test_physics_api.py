"""The physics layer used directly, as a worked example would: shapes a student passes and parameters outside their
ranges either work as documented or raise a ValueError naming the parameter, its value and the allowed range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vegym.physics import aircraft, collision, particle, pendulum, projectile, suspension, thread, wheel


def test_terrain_of_one_road_at_many_distances() -> None:
    """One terrain row (1, J) evaluated along a road: broadcast to every distance, no read past the row."""
    x = np.linspace(0.0, 10.0, 500)
    amplitude, wavenumber, phase = [[0.1, 0.05]], [[1.0, 3.0]], [[0.0, 0.5]]
    height, slope = suspension.terrain(x, amplitude, wavenumber, phase)
    expected = 0.1 * np.sin(x) + 0.05 * np.sin(3.0 * x + 0.5)
    np.testing.assert_allclose(height, expected, atol=1e-15)
    np.testing.assert_allclose(slope, 0.1 * np.cos(x) + 0.15 * np.cos(3.0 * x + 0.5), atol=1e-15)


def test_terrain_rows_that_do_not_match_the_distances_raise() -> None:
    with pytest.raises(ValueError, match="amplitude"):
        suspension.terrain(np.zeros(3), np.ones((2, 1)), np.ones((2, 1)), np.zeros((2, 1)))


@pytest.mark.parametrize("e", [-0.5, 1.5, math.nan])
def test_impacts_refuse_a_restitution_outside_0_1(e: float) -> None:
    """event_step refuses e outside [0, 1]; so do the other impact laws (e > 1 creates energy)."""
    calls = [
        lambda: particle.restitute([1.0, -2.0, 0.0], [0.0, 1.0, 0.0], e),
        lambda: collision.direct_impact(2.0, -4.0, 5.0, 3.0, e),
        lambda: collision.oblique_impact([0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [-4.0, 0.0], 5.0, 3.0, e),
    ]
    for call in calls:
        with pytest.raises(ValueError, match=r"restitution=.*\[0, 1\]"):
            call()


@pytest.mark.parametrize("a", [0.0, -0.5])
def test_table_laws_refuse_a_deceleration_that_is_not_positive(a: float) -> None:
    for call in (
        lambda: collision.slide([0.0, 0.0], [1.0, 0.0], a),
        lambda: collision.speed_after(1.0, 0.5, a),
        lambda: collision.launch_speed(1.0, 0.5, a),
    ):
        with pytest.raises(ValueError, match=r"deceleration=.*\(0, inf\)"):
            call()


@pytest.mark.parametrize("g", [0.0, -9.81])
def test_particle_laws_refuse_a_gravity_that_is_not_a_positive_magnitude(g: float) -> None:
    """g is a positive magnitude (PHYSICS.md section 0); -9.81 would give an apex below the launch, silently."""
    for call in (
        lambda: particle.time_to_ground(10.0, 0.0, 0.0, g),
        lambda: particle.impact_velocity(10.0, 0.0, 0.0, g),
        lambda: particle.apex_height(0.0, 10.0, g),
    ):
        with pytest.raises(ValueError, match=r"gravity=.*\(0, inf\)"):
            call()


def test_pump_torque_refuses_a_negative_torque_limit() -> None:
    """np.clip(x, 1, -1) returns -1 everywhere: the pump would brake the swing it should drive."""
    with pytest.raises(ValueError, match=r"max_torque=-1.0 .*\[0, inf\)"):
        pendulum.pump_torque(0.1, 0.5, math.radians(45.0), 1.0, -1.0, pendulum.PendulumParams())


@pytest.mark.parametrize("dt", [0.0, -0.5, math.nan])
def test_aircraft_step_refuses_a_step_that_is_not_positive(dt: float) -> None:
    state = aircraft.initial_state([0.0, 1000.0, 0.0], 100.0, 0.0)
    with pytest.raises(ValueError, match=r"dt=.*\(0, inf\)"):
        aircraft.step(state, [[0.0, 0.0, 0.0]], dt, aircraft.AircraftParams())


def test_one_aircraft_takes_single_commands_and_demands() -> None:
    """initial_state takes one aircraft's (3,) position; its step, errors, autopilot and action maps take (3,) too."""
    params, gains = aircraft.AircraftParams(), aircraft.AutopilotGains()
    state = aircraft.initial_state([0.0, 1000.0, 0.0], 100.0, 0.0)
    errors = aircraft.tracking_errors(state, [1500.0, 150.0, 1.0])
    np.testing.assert_array_equal(errors, [[500.0, 50.0, 1.0]])
    command = aircraft.autopilot([500.0, 50.0, 1.0], params, gains)
    np.testing.assert_array_equal(command, aircraft.autopilot([[500.0, 50.0, 1.0]], params, gains))
    new, _ = aircraft.step(state, [0.0, 0.0, 0.0], 0.5, params)
    np.testing.assert_array_equal(new.position, [[0.0, 1000.0, 50.0]])
    action = aircraft.action_from_command([1.5, -10.0, 0.0], params)
    np.testing.assert_array_equal(aircraft.command_from_action([1.0, -1.0, 0.0], params), [[1.5, -10.0, 0.0]])
    np.testing.assert_array_equal(action, [[1.0, -1.0, 0.0]])


def test_thread_positions_must_match_the_parameters() -> None:
    """A thread of 5 nodes with parameters for 9 used to run as a 5-node thread; an unbatched (N, 2) shape, as
    static_equilibrium returns, used to fail with numpy's 'axes don't match array'."""
    p = thread.ThreadParams()
    rest = thread.static_equilibrium(p)
    x = np.linspace(0.0, p.span, 7)[1:-1]
    five = np.stack([x, np.full(5, -0.05)], axis=-1)[None]
    for call in (
        lambda: thread.acceleration(five, 0.0, 0.0, p),
        lambda: thread.step(five, 0.0, 0.0, 1e-3, p),
        lambda: thread.energy(five, 0.0, p),
    ):
        with pytest.raises(ValueError, match=r"positions.*\(n, 9, 2\)"):
            call()
    with pytest.raises(ValueError, match=r"positions.*\(n, 9, 2\).*\(9, 2\)"):
        thread.step(rest, 0.0, 0.0, 1e-3, p)
    assert thread.step(rest[None], 0.0, 0.0, 1e-3, p)[0].shape == (1, 9, 2)


def test_projectile_position_and_velocity_take_lists() -> None:
    """Lists used to be concatenated (``[10, 10, 0] + [0, 0, 0]`` has six elements) before numpy saw them."""
    params = projectile.ProjectileParams()
    np.testing.assert_allclose(
        projectile.position_at([0, 0, 0], [10, 10, 0], [1, 0, 0], 1.0, params), [11.0, 10.0 - 4.905, 0.0]
    )
    np.testing.assert_allclose(projectile.velocity_at([10, 10, 0], [1, 0, 0], 1.0, params), [11.0, 0.19, 0.0])


@pytest.mark.parametrize("dt", [0.0, -0.01, math.nan])
def test_pendulum_and_spring_steps_refuse_a_step_that_is_not_positive(dt: float) -> None:
    with pytest.raises(ValueError, match=r"dt=.*\(0, inf\)"):
        pendulum.step(0.1, 0.0, 0.0, dt, pendulum.PendulumParams())
    with pytest.raises(ValueError, match=r"dt=.*\(0, inf\)"):
        suspension.step(0.3, 0.0, 0.0, 0.0, 1000.0, dt, suspension.SpringParams())


def test_an_impact_of_spheres_at_one_centre_raises() -> None:
    """The line of centres is undefined there; the compiled kernel divided by zero."""
    with pytest.raises(ValueError, match=r"c_a and c_b coincide at \[1.0, 2.0\]"):
        collision.oblique_impact(
            [[0.0, 0.0], [1.0, 2.0]], [[1.0, 0.0], [1.0, 2.0]], [1.0, 0.0], [0.0, 0.0], 1.0, 1.0, 1.0
        )


def test_free_flight_spring_energy_and_skyhook_take_lists() -> None:
    """As the other array functions do; lists used to raise TypeError (``list * list``)."""
    h, v = particle.state_at([10.0, 5.0], [0.0, 2.0], [1.0, 1.0], 9.81)
    np.testing.assert_allclose(h, [10.0 - 4.905, 5.0 + 2.0 - 4.905])
    np.testing.assert_allclose(v, [-9.81, 2.0 - 9.81])
    spring = suspension.SpringParams()
    np.testing.assert_array_equal(
        suspension.energy([0.3, 0.4], [0.0, 1.0], [0.0, 0.0], spring),
        suspension.energy(np.array([0.3, 0.4]), np.array([0.0, 1.0]), np.zeros(2), spring),
    )
    np.testing.assert_array_equal(
        suspension.continuous_skyhook_damping([1.0, -1.0], [2.0, 0.5], 1000.0, 100.0, 3000.0), [500.0, 100.0]
    )


@pytest.mark.parametrize("m", [0.0, -1.0, math.nan])
def test_the_impact_laws_refuse_a_mass_that_is_not_positive(m: float) -> None:
    for call in (
        lambda: collision.direct_impact(2.0, -4.0, m, 3.0, 0.5),
        lambda: collision.oblique_impact([0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, 0.0], 5.0, m, 0.5),
        lambda: collision.energy_loss(1.0, 5.0, m, 0.5),
        lambda: collision.deflection_angle(0.3, m, 3.0, 0.5),
        lambda: collision.reduced_mass(m, 3.0),
    ):
        with pytest.raises(ValueError, match=r"mass_[ab]=.*\(0, inf\)"):
            call()


def test_energy_loss_and_deflection_refuse_a_restitution_above_1() -> None:
    """energy_loss(..., e=1.5) returned a negative loss, silently."""
    with pytest.raises(ValueError, match=r"restitution=1.5 is outside the allowed range \[0, 1\]"):
        collision.energy_loss(1.0, 5.0, 3.0, 1.5)
    with pytest.raises(ValueError, match=r"restitution=1.5 is outside the allowed range \[0, 1\]"):
        collision.deflection_angle(0.3, 5.0, 3.0, 1.5)


def test_terrain_and_the_aircraft_functions_refuse_rows_of_another_width() -> None:
    """A (n, 1) wavenumber beside a (n, 3) amplitude would broadcast silently."""
    with pytest.raises(ValueError, match="wavenumber"):
        suspension.terrain(np.zeros(3), np.ones((3, 3)), np.ones((3, 1)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"\(n, 3\) or \(3,\)"):
        aircraft.autopilot(np.zeros((2, 4)), aircraft.AircraftParams(), aircraft.AutopilotGains())


def test_one_command_steps_every_aircraft_and_other_row_counts_raise() -> None:
    """(3,) and (1, 3) commands broadcast to every aircraft: the compiled flight read one command row per aircraft
    and, given one row for three, flew the second and third on memory past it."""
    params = aircraft.AircraftParams()
    state = aircraft.initial_state([[0.0, 1000.0, 0.0]] * 3, [100.0, 120.0, 130.0], [0.0, 0.0, 0.0])
    each, _ = aircraft.step(state, [[1.5, 5.0, 0.01]] * 3, 1.0, params)
    for command in ([1.5, 5.0, 0.01], [[1.5, 5.0, 0.01]]):
        new, climb = aircraft.step(state, command, 1.0, params)
        np.testing.assert_array_equal(new.speed, each.speed)
        np.testing.assert_array_equal(new.position, each.position)
        np.testing.assert_array_equal(climb, [5.0, 5.0, 5.0])
    with pytest.raises(ValueError, match="command has 2 rows for 3 aircraft"):
        aircraft.step(state, [[1.5, 5.0, 0.01]] * 2, 1.0, params)


def test_the_angle_wraps_and_the_range_laws_return_scalars_for_scalars_and_arrays_for_arrays() -> None:
    """aircraft.wrap returned a 0-d array for a scalar where wheel.wrap_angle returns a numpy scalar, and max_range
    took scalars only where its twin max_range_elevation takes arrays (session 24's physics review)."""
    params = projectile.ProjectileParams()
    for law, args in (
        (aircraft.wrap, (4.0,)),
        (wheel.wrap_angle, (4.0,)),
        (projectile.max_range, (20.0, 1.0, params)),
        (projectile.max_range_elevation, (20.0, 1.0, params)),
    ):
        one = law(*args)
        assert isinstance(one, np.float64), law
        many = law(*(np.full(3, a) if isinstance(a, float) else a for a in args))
        assert isinstance(many, np.ndarray) and many.shape == (3,) and np.all(many == one), law
