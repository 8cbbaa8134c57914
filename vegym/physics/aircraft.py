"""First-order aircraft (8.113-8.128) and the chapter's autopilot, in the corrected form of PHYSICS.md section 10.

State ``(x, y, z, v, psi)``: position (y = altitude), horizontal airspeed ``v`` along the heading and the
heading ``psi`` of section 0 (forward ``f = (sin psi, 0, cos psi)``; a positive turn is a left turn,
anticlockwise seen from +y; ``psi`` is kept in [-pi, pi)). The commands ``(a, v_y, omega)`` are the
acceleration along the track (m/s^2), the climb rate (m/s) and the turn rate (rad/s), saturated at
``[-A_dec, A_acc] x [-V_des, V_cli] x [-M, M]``. One step of length ``dt`` holds them constant::

    v'  = clip(v + a dt, v_min, v_max);   a_bar = (v' - v) / dt
    dd  = v dt + a_bar dt^2 / 2;   dpsi = omega dt
    x' = x + dd sinc(dpsi/2) sin(psi + dpsi/2) + w_x dt;   z' = z + dd sinc(dpsi/2) cos(psi + dpsi/2) + w_z dt
    y' = clip(y + (v_y + w_y) dt, floor, ceiling);   psi' = wrap(psi + dpsi)

The chord at the mid-heading is exact for constant speed (no special case at omega = 0). ``(w_x, w_z)`` is a
constant horizontal wind drift (a parameter); ``w_y``, the vertical air velocity (steady draft plus gusts),
is an input array drawn by the caller, so these functions stay pure. ``v`` is the horizontal speed; the true
airspeed is ``sqrt(v^2 + v_y^2)``.

``book_faithful=True`` reproduces the printed variant for teaching: a one-step command lag (8.120, 8.124:
the step applies the *previous* step's ``a`` and ``v_y``), the whole step flown on the old heading (8.115),
and the heading law 8.126-8.127 in which the third command is a lateral velocity ``v_x`` (m/s, saturated at
``V = v tan(M dt)``, also lagged) giving ``dpsi = atan(v_x / v)`` per step, so the turn rate scales as 1/dt.

The array functions take arrays with a leading batch axis and never modify their inputs; :func:`fly` and
:func:`wrap_angle` are the scalar numba kernels they (and the env's step) run. No gymnasium here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from vegym.params import Params, check_positive, param
from vegym.physics import vmath
from vegym.physics.columns import flat_columns

STANDARD_RATE = math.radians(3.0)
"""The standard-rate turn, 3 degrees per second (rad/s)."""
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class AircraftParams(Params):
    """Command saturations and flight envelope of the first-order aircraft (SI units, radians)."""

    max_acceleration: float = param(1.5, "A_acc, largest acceleration along the track (m/s^2)", low=0.0, low_open=True)
    max_deceleration: float = param(2.0, "A_dec, largest deceleration (m/s^2, a magnitude)", low=0.0, low_open=True)
    max_climb_rate: float = param(15.0, "V_cli, largest climb rate (m/s)", low=0.0, low_open=True)
    max_descent_rate: float = param(10.0, "V_des, largest descent rate (m/s, a magnitude)", low=0.0, low_open=True)
    max_turn_rate: float = param(STANDARD_RATE, "M, largest turn rate (rad/s)", low=0.0, high=math.pi, low_open=True)
    min_speed: float = param(60.0, "v_min, slowest horizontal airspeed (m/s)", low=0.0, low_open=True)
    max_speed: float = param(200.0, "v_max, fastest horizontal airspeed (m/s)", low=0.0, low_open=True)
    floor_altitude: float = param(0.0, "lowest altitude (m); the descent is cut there", infinite=True)
    ceiling_altitude: float = param(math.inf, "highest altitude (m); the climb is cut there", infinite=True)
    wind_x: float = param(0.0, "constant horizontal wind drift, x component (m/s)")
    wind_z: float = param(0.0, "constant horizontal wind drift, z component (m/s)")
    book_faithful: bool = param(False, "printed variant: lagged commands, old-heading step, 8.126-8.127 heading law")

    def validate(self) -> None:
        if self.max_speed <= self.min_speed:
            raise self.between("max_speed", "min_speed", low_open=True)
        if self.ceiling_altitude <= self.floor_altitude:
            raise self.between("ceiling_altitude", "floor_altitude", low_open=True)

    @property
    def command_low(self) -> np.ndarray:
        """Lower command limits ``(-A_dec, -V_des, -M)`` (SI)."""
        return -np.array([self.max_deceleration, self.max_descent_rate, self.max_turn_rate])

    @property
    def command_high(self) -> np.ndarray:
        """Upper command limits ``(A_acc, V_cli, M)`` (SI)."""
        return np.array([self.max_acceleration, self.max_climb_rate, self.max_turn_rate])


@dataclass(frozen=True)
class AutopilotGains(Params):
    """Gains of the chapter's autopilot (8.119, 8.123, corrected 8.126). Monotone responses need ``k dt <= 1``."""

    speed_gain: float = param(0.5, "k_a, acceleration per airspeed error (1/s)", low=0.0, low_open=True)
    climb_gain: float = param(0.2, "k_v, climb rate per altitude error (1/s)", low=0.0, low_open=True)
    heading_gain: float = param(0.5, "k_psi, turn rate per heading error (1/s)", low=0.0, low_open=True)
    book_heading_gain: float = param(
        1.0, "k_phi of the printed 8.126, lateral velocity per heading error (m/s/rad)", low=0.0, low_open=True
    )


class AircraftState(NamedTuple):
    """A batch of aircraft: ``position`` (n, 3) m, ``speed`` (n,) m/s, ``heading`` (n,) rad in [-pi, pi).

    ``command`` (n, 3) holds the saturated commands of the last step; the book-faithful variant applies
    them one step late.
    """

    position: np.ndarray
    speed: np.ndarray
    heading: np.ndarray
    command: np.ndarray


@njit(cache=True, inline="always")
def wrap_angle(angle: float) -> float:
    """One angle wrapped to [-pi, pi) (rad): ``a - 2 pi floor((a + pi) / 2 pi)``, round-off at the ends to -pi.
    Branch-free (a float floor and selects), so that a loop over a batch compiles to SIMD code."""
    wrapped = angle - _TWO_PI * np.floor((angle + math.pi) / _TWO_PI)
    return max(-math.pi if wrapped >= math.pi else wrapped, -math.pi)


@njit(cache=True)
def _wrap_each(angles: np.ndarray) -> np.ndarray:
    out = np.empty(angles.size)
    for i in range(angles.size):
        out[i] = wrap_angle(angles[i])
    return out


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles (any shape, rad) wrapped to [-pi, pi) by :func:`wrap_angle` (a numpy scalar for a scalar, as
    :func:`vegym.physics.wheel.wrap_angle`)."""
    shape, (angle,) = flat_columns(angle)
    return _wrap_each(angle).reshape(shape)[()]


def _clip_columns(values: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(n, k) values clipped column by column to scalar limits (much faster than broadcasting (k,) bounds)."""
    out = np.empty(values.shape)
    for j in range(values.shape[1]):
        np.clip(values[:, j], low[j], high[j], out=out[:, j])
    return out


def _commands(values: np.ndarray) -> np.ndarray:
    """Triples (n, 3) as float64; one aircraft's (3,) as a batch of one."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        values = values[None]
    if values.ndim != 2 or values.shape[1] != 3:
        raise ValueError(f"expected (n, 3) or (3,) values, got shape {values.shape}")
    return values


def initial_state(position: np.ndarray, speed: np.ndarray, heading: np.ndarray) -> AircraftState:
    """Aircraft at ``position`` (n, 3), ``speed`` (n,) and ``heading`` (n,), with zero previous commands."""
    position = np.array(position, dtype=np.float64, ndmin=2)
    n = len(position)
    speed = np.broadcast_to(np.asarray(speed, dtype=np.float64), (n,)).copy()
    heading = wrap(np.broadcast_to(np.asarray(heading, dtype=np.float64), (n,)))
    return AircraftState(position, speed, heading, np.zeros((n, 3)))


def lateral_limit(speed: np.ndarray, dt: float, params: AircraftParams) -> np.ndarray:
    """The book's largest lateral velocity ``V = v tan(M dt)`` (m/s), so that ``atan(v_x / v) <= M dt``."""
    if params.max_turn_rate * dt >= 0.5 * np.pi:
        raise ValueError(f"dt={dt!r} is outside the allowed range (0, pi / (2 max_turn_rate)) of the book heading law")
    return np.asarray(speed, dtype=np.float64) * np.tan(params.max_turn_rate * dt)


def saturate(command: np.ndarray, speed: np.ndarray, dt: float, params: AircraftParams) -> np.ndarray:
    """Commands (n, 3) clipped to their limits (8.119, 8.123, 8.126 read as saturations).

    The third command is the turn rate omega in ``[-M, M]``, or with ``book_faithful`` the lateral velocity
    ``v_x`` in ``[-V, V]`` (:func:`lateral_limit`).
    """
    command = _commands(command)
    out = _clip_columns(command, params.command_low, params.command_high)
    if params.book_faithful:
        lateral = lateral_limit(speed, dt, params)
        out[:, 2] = np.clip(command[:, 2], -lateral, lateral)
    return out


@njit(cache=True, inline="always")
def fly(
    x: float,
    y: float,
    z: float,
    v: float,
    psi: float,
    command: tuple[float, float, float],
    vertical_wind: float,
    dt: float,
    envelope: tuple[float, float, float, float, float, float],
    book_faithful: bool,
) -> tuple[float, float, float, float, float]:
    """One aircraft, one step of ``dt`` s under the applied ``command = (a, v_y, omega or v_x)``, in scalars.

    ``envelope = (v_min, v_max, floor, ceiling, wind_x, wind_z)``; returns ``(x', y', z', v', psi')`` (SI, rad).
    The one compiled form of the model: :func:`step` loops over it and Aircraft-v0's step kernel inlines it. The
    clean model is branch-free (sine and cosine by :func:`vmath.sincos`), so a loop over a batch of it compiles
    to SIMD code.
    """
    accel, climb, turn = command
    min_speed, max_speed, floor, ceiling, wind_x, wind_z = envelope
    v_new = min(max(v + accel * dt, min_speed), max_speed)
    distance = 0.5 * (v + v_new) * dt
    if book_faithful:
        dpsi = math.atan(turn / v)
        chord, course = distance, psi
    else:
        dpsi = turn * dt
        half_turn = np.pi * (0.5 * dpsi / np.pi)  # np.sinc's argument, so the chord rounds as np.sinc does
        chord = distance * (vmath.sincos(half_turn)[0] / half_turn if half_turn != 0.0 else 1.0)
        course = psi + 0.5 * dpsi
    sine, cosine = vmath.sincos(course)
    return (
        x + chord * sine + wind_x * dt,
        min(max(y + (climb + vertical_wind) * dt, floor), ceiling),
        z + chord * cosine + wind_z * dt,
        v_new,
        wrap_angle(psi + dpsi),
    )


@njit(cache=True)
def _fly_each(
    position: np.ndarray,
    speed: np.ndarray,
    heading: np.ndarray,
    applied: np.ndarray,
    vertical_wind: np.ndarray,
    dt: float,
    envelope: tuple[float, float, float, float, float, float],
    book_faithful: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    n = len(speed)
    new_position, new_speed, new_heading, climb = np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        x, y, z, new_speed[i], new_heading[i] = fly(
            position[i, 0],
            position[i, 1],
            position[i, 2],
            speed[i],
            heading[i],
            (applied[i, 0], applied[i, 1], applied[i, 2]),
            vertical_wind[i],
            dt,
            envelope,
            book_faithful,
        )
        new_position[i, 0], new_position[i, 1], new_position[i, 2] = x, y, z
        climb[i] = (y - position[i, 1]) / dt
    return new_position, new_speed, new_heading, climb


def envelope(params: AircraftParams) -> tuple[float, float, float, float, float, float]:
    """``(v_min, v_max, floor, ceiling, wind_x, wind_z)`` of :func:`fly` (SI)."""
    return (
        float(params.min_speed),
        float(params.max_speed),
        float(params.floor_altitude),
        float(params.ceiling_altitude),
        float(params.wind_x),
        float(params.wind_z),
    )


def step(
    state: AircraftState,
    command: np.ndarray,
    dt: float,
    params: AircraftParams,
    vertical_wind: np.ndarray | float = 0.0,
) -> tuple[AircraftState, np.ndarray]:
    """One step of ``dt`` seconds under ``command`` (n, 3), or (3,) or (1, 3) for every aircraft; returns the new
    state and the climb rate applied.

    ``vertical_wind`` (n,) or scalar is the air's vertical velocity during the step (m/s, + up: steady draft
    plus gusts, drawn by the caller). The climb rate returned is ``(y' - y) / dt``, drafts and the altitude
    limits included.
    """
    check_positive("dt", dt)
    n, command = len(state.speed), _commands(command)
    if len(command) not in (1, n):
        raise ValueError(f"command has {len(command)} rows for {n} aircraft: give (n, 3), or (3,) or (1, 3) for all")
    new_command = saturate(np.broadcast_to(command, (n, 3)), state.speed, dt, params)
    applied = state.command if params.book_faithful else new_command
    _, (vertical_wind, _) = flat_columns(vertical_wind, state.speed)  # (n,), however it was given
    position, speed, heading, climb = _fly_each(
        *(np.ascontiguousarray(a, dtype=np.float64) for a in (state.position, state.speed, state.heading, applied)),
        vertical_wind,
        float(dt),
        envelope(params),
        bool(params.book_faithful),
    )
    return AircraftState(position, speed, heading, new_command), climb


def tracking_errors(state: AircraftState, demand: np.ndarray) -> np.ndarray:
    """Errors (n, 3) to the demand ``(y_d, v_d, psi_d)``: ``(y_d - y, v_d - v, wrap(psi_d - psi))`` (8.118-8.125)."""
    demand = _commands(demand)
    return np.stack(
        [
            demand[:, 0] - state.position[:, 1],
            demand[:, 1] - state.speed,
            wrap(demand[:, 2] - state.heading),
        ],
        axis=-1,
    )


def autopilot(errors: np.ndarray, params: AircraftParams, gains: AutopilotGains) -> np.ndarray:
    """The chapter's autopilot, corrected: three decoupled saturated P loops on the errors (n, 3).

    ``a = clip(k_a v_err, -A_dec, A_acc)``, ``v_y = clip(k_v y_err, -V_des, V_cli)``,
    ``omega = clip(k_psi wrap(psi_err), -M, M)``; returns commands (n, 3) in SI units.
    """
    errors = _commands(errors)
    raw = np.stack(
        [gains.speed_gain * errors[:, 1], gains.climb_gain * errors[:, 0], gains.heading_gain * wrap(errors[:, 2])],
        axis=-1,
    )
    return _clip_columns(raw, params.command_low, params.command_high)


def book_autopilot(
    state: AircraftState, demand: np.ndarray, dt: float, params: AircraftParams, gains: AutopilotGains
) -> np.ndarray:
    """The autopilot as printed, for the ``book_faithful`` step: commands ``(a, v_y, v_x)`` (n, 3).

    Speed and altitude loops as in :func:`autopilot`; the heading loop is 8.126,
    ``v_x = clip(k_phi (psi_d - psi), -V, V)`` with ``V = v tan(M dt)`` and the error *not* wrapped.
    """
    demand = _commands(demand)
    command = autopilot(tracking_errors(state, demand), params, gains)
    lateral = lateral_limit(state.speed, dt, params)
    command[:, 2] = np.clip(gains.book_heading_gain * (demand[:, 2] - state.heading), -lateral, lateral)
    return command


def command_from_action(action: np.ndarray, params: AircraftParams) -> np.ndarray:
    """Commands (n, 3) in SI from normalised actions in [-1, 1]: ``u >= 0`` scales the upper limits, ``u < 0``
    the lower ones, so 0 holds speed, altitude and heading. Actions outside [-1, 1] map past the limits, unclipped
    (:func:`step` saturates commands)."""
    action = _commands(action)
    command = np.empty(action.shape)
    for j, (low, high) in enumerate(zip(params.command_low, params.command_high, strict=True)):
        u = action[:, j]
        command[:, j] = u * np.where(u >= 0.0, high, -low)
    return command


def action_from_command(command: np.ndarray, params: AircraftParams) -> np.ndarray:
    """Inverse of :func:`command_from_action` on the saturation box (commands are clipped to it first)."""
    command = _clip_columns(_commands(command), params.command_low, params.command_high)
    for j, (low, high) in enumerate(zip(params.command_low, params.command_high, strict=True)):
        c = command[:, j]
        command[:, j] = c / np.where(c >= 0.0, high, -low)
    return command
