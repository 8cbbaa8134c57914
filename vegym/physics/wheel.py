"""Rolling wheel, gear trains and the steerable wheel (chapter 8.19-8.43).

Corrected forms from PHYSICS.md sections 2 and 3: the rim speed of meshing gears is ``omega * r`` (a linear
speed), so an external mesh gives ``omega_b = -omega_a r_a / r_b``, a ring (internal) gear the same with ``+``,
and a chain of n external gears ``(-1)^(n-1) r_1 / r_n``. A wheel of radius r rolled a distance d has turned
``d / r`` radians; its model matrix is ``T(d, r, 0) R_z(-d / r)`` (8.27: translate after rotating). The
steerable wheel holds its speed v and heading increment ``phi = omega dt`` constant over a step and moves along
the exact arc, whose chord is ``v dt sinc(phi / 2)`` at the mid-step heading (no special case at ``phi = 0``).

Conventions (PHYSICS.md section 0): y up, SI units, radians, column vectors; homogeneous 4x4 matrices and all
arrays carry a leading batch axis (scalars broadcast) and inputs are never modified. Heading ``psi``: forward is
``f(psi) = (sin psi, 0, cos psi)``, left is ``l(psi) = (cos psi, 0, -sin psi)``, and psi increases toward l (a
positive turn is a left turn, anticlockwise seen from +y). The book's steering angle is ``theta = psi + pi/2``.
The roll angle ``alpha`` grows by ``v dt / r`` as the wheel rolls forward.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from vegym.params import Params, param
from vegym.physics import vmath
from vegym.physics.columns import flat_columns


@dataclass(frozen=True)
class WheelParams(Params):
    """A rigid wheel of radius r rolling without slipping on the ground plane y = 0."""

    radius: float = param(0.3, "wheel radius (m); the centre rides at height y = radius", low=0.0, low_open=True)


class Pose(NamedTuple):
    """Batched state of a steerable wheel: centre ``(x, z)`` on the ground plane (m), heading and roll (rad)."""

    x: np.ndarray
    z: np.ndarray
    heading: np.ndarray
    roll: np.ndarray


@njit(cache=True, inline="always")
def wrap_one(angle: float) -> float:
    """One angle wrapped into ``[-pi, pi]`` (rad): ``(a + pi) mod 2 pi - pi`` (``pi`` itself only through rounding),
    by :func:`vegym.physics.vmath.wrap_angle` (SIMD-friendly, Python's ``%`` bit for bit for ``|a| < 5 pi``)."""
    return vmath.wrap_angle(angle)


@njit(cache=True)
def _wrap_each(angles: np.ndarray) -> np.ndarray:
    out = np.empty(angles.size)
    for i in range(angles.size):
        out[i] = wrap_one(angles[i])
    return out


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angles (any shape, rad) wrapped into ``[-pi, pi]`` by :func:`wrap_one`."""
    shape, (angle,) = flat_columns(angle)
    return _wrap_each(angle).reshape(shape)[()]


def roll_angle(distance: np.ndarray, radius: float) -> np.ndarray:
    """Angle (rad) a wheel of ``radius`` turns through while rolling ``distance`` (m) without slipping."""
    return np.asarray(distance, dtype=np.float64) / radius


def mesh_ratio(driver_radius: np.ndarray, driven_radius: np.ndarray, internal: bool = False) -> np.ndarray:
    """``omega_driven / omega_driver`` of two meshing gears (8.19, 8.20): ``-r_a / r_b``, or ``+`` for a ring gear.

    Equal rim speeds: ``omega_a r_a = -omega_b r_b`` (external). Tooth counts may stand in for the radii.
    """
    ratio = np.asarray(driver_radius, dtype=np.float64) / np.asarray(driven_radius, dtype=np.float64)
    return ratio if internal else -ratio


def train_speeds(omega: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Angular speeds (..., n) of a chain of n external gears with ``radii`` (..., n), gear 0 turning at ``omega``."""
    radii = np.asarray(radii, dtype=np.float64)
    speeds = [np.broadcast_to(np.asarray(omega, dtype=np.float64), radii.shape[:-1])]
    for i in range(1, radii.shape[-1]):
        speeds.append(speeds[-1] * mesh_ratio(radii[..., i - 1], radii[..., i]))
    return np.stack(speeds, axis=-1)


def train_ratio(radii: np.ndarray) -> np.ndarray:
    """``omega_n / omega_1 = (-1)^(n-1) r_1 / r_n`` of a chain of n external gears (the idlers cancel)."""
    radii = np.asarray(radii, dtype=np.float64)
    sign = -1.0 if radii.shape[-1] % 2 == 0 else 1.0
    return sign * radii[..., 0] / radii[..., -1]


def translation(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Homogeneous translations ``T(x, y, z)``, shape (n, 4, 4)."""
    x, y, z = np.broadcast_arrays(*(np.atleast_1d(np.asarray(c, dtype=np.float64)) for c in (x, y, z)))
    m = np.zeros((*x.shape, 4, 4))
    m[..., 0, 0] = m[..., 1, 1] = m[..., 2, 2] = m[..., 3, 3] = 1.0
    m[..., 0, 3], m[..., 1, 3], m[..., 2, 3] = x, y, z
    return m


def rotation_y(angle: np.ndarray) -> np.ndarray:
    """Homogeneous rotations ``R_y(angle)`` (anticlockwise seen from +y: +z turns toward +x), shape (n, 4, 4)."""
    a = np.atleast_1d(np.asarray(angle, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    m = np.zeros((*a.shape, 4, 4))
    m[..., 0, 0], m[..., 0, 2], m[..., 2, 0], m[..., 2, 2] = c, s, -s, c
    m[..., 1, 1] = m[..., 3, 3] = 1.0
    return m


def rotation_z(angle: np.ndarray) -> np.ndarray:
    """Homogeneous rotations ``R_z(angle)`` (anticlockwise seen from +z: +x turns toward +y), shape (n, 4, 4)."""
    a = np.atleast_1d(np.asarray(angle, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    m = np.zeros((*a.shape, 4, 4))
    m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1] = c, -s, s, c
    m[..., 2, 2] = m[..., 3, 3] = 1.0
    return m


def transform(matrices: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply homogeneous matrices (n, 4, 4) to points (k, 3) or (n, k, 3); returns (n, k, 3)."""
    points = np.asarray(points, dtype=np.float64)
    points = np.broadcast_to(points, (len(matrices), *points.shape[-2:]))
    return np.einsum("nij,nkj->nki", matrices[:, :3, :3], points) + matrices[:, None, :3, 3]


def rolling_matrix(distance: np.ndarray, radius: float) -> np.ndarray:
    """Model matrix (n, 4, 4) of a wheel rolled ``distance`` toward +x: ``T(d, r, 0) R_z(-d / r)`` (8.27).

    The wheel is modelled centred at the origin in the object's xy plane. Example (8.28): with ``r = 1`` and
    ``d = 2 pi`` the point ``(0, -1, 0)`` maps to ``(2 pi, 0, 0)``.
    """
    d = np.asarray(distance, dtype=np.float64)
    return translation(d, radius, 0.0) @ rotation_z(-roll_angle(d, radius))


def forward(heading: np.ndarray) -> np.ndarray:
    """Unit forward vectors ``f(psi) = (sin psi, 0, cos psi)``, shape (n, 3)."""
    psi = np.atleast_1d(np.asarray(heading, dtype=np.float64))
    return np.stack([np.sin(psi), np.zeros_like(psi), np.cos(psi)], axis=-1)


def left(heading: np.ndarray) -> np.ndarray:
    """Unit left vectors ``l(psi) = y x f = (cos psi, 0, -sin psi)``, shape (n, 3)."""
    psi = np.atleast_1d(np.asarray(heading, dtype=np.float64))
    return np.stack([np.cos(psi), np.zeros_like(psi), -np.sin(psi)], axis=-1)


@njit(cache=True, inline="always", error_model="numpy")
def arc_step(
    x: float, z: float, heading: float, roll: float, speed: float, yaw_rate: float, dt: float, radius: float
) -> tuple[float, float, float, float]:
    """:func:`steer_step` for one wheel in scalars (SI, rad): ``(x, z, heading, roll)`` after ``dt``.

    The one compiled form of the arc (:func:`oriented_arc_step`'s first four results): :func:`steer_step` loops over
    it and SteerableWheel-v0's step kernel inlines it. Branch-free (sine and cosine from
    :func:`vegym.physics.vmath.sincos`), so a loop over wheels runs as SIMD code.
    """
    return oriented_arc_step(x, z, heading, roll, speed, yaw_rate, dt, radius)[:4]


@njit(cache=True, inline="always", error_model="numpy")
def oriented_arc_step(
    x: float, z: float, heading: float, roll: float, speed: float, yaw_rate: float, dt: float, radius: float
) -> tuple[float, float, float, float, float, float]:
    """:func:`arc_step`, and the sine and cosine of the heading after it: those of the mid-step heading turned by
    the second half of the turn (within 2e-15 of ``vmath.sincos`` of the heading for turns up to 6 rad a step,
    without its range reduction)."""
    distance = speed * dt
    phi = yaw_rate * dt
    half_turn = np.pi * (0.5 * phi / np.pi)  # np.sinc's argument, so the chord rounds as np.sinc(phi / 2 pi) does
    sin_half, cos_half = vmath.sincos(half_turn)
    chord = distance * (sin_half / half_turn if half_turn != 0.0 else 1.0)
    sin_mid, cos_mid = vmath.sincos(heading + 0.5 * phi)
    return (
        x + chord * sin_mid,
        z + chord * cos_mid,
        wrap_one(heading + phi),
        roll + distance / radius,
        sin_mid * cos_half + cos_mid * sin_half,
        cos_mid * cos_half - sin_mid * sin_half,
    )


@njit(cache=True)
def _steer_arrays(
    x: np.ndarray,
    z: np.ndarray,
    heading: np.ndarray,
    roll: np.ndarray,
    speed: np.ndarray,
    yaw_rate: np.ndarray,
    dt: float,
    radius: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    out = np.empty((4, x.size))
    for i in range(x.size):
        out[0, i], out[1, i], out[2, i], out[3, i] = arc_step(
            x[i], z[i], heading[i], roll[i], speed[i], yaw_rate[i], dt, radius
        )
    return out[0], out[1], out[2], out[3]


def steer_step(pose: Pose, speed: np.ndarray, yaw_rate: np.ndarray, dt: float, params: WheelParams) -> Pose:
    """Advance a steerable wheel by ``dt`` at constant speed v (m/s) and yaw rate omega (rad/s): exact arc.

    With ``phi = omega dt`` (the book's heading increment) and ``s = v dt sinc(phi / 2)`` (the chord):
    ``x' = x + s sin(psi + phi/2)``, ``z' = z + s cos(psi + phi/2)``, ``psi' = wrap(psi + phi)``,
    ``alpha' = alpha + v dt / r``. This is the book's turning case (8.29-8.34, rotation about the turn centre)
    and reduces to its straight case (8.42, 8.43) at ``phi = 0`` exactly; a negative ``dt`` steps back.
    """
    shape, columns = flat_columns(*pose, speed, yaw_rate)
    new = _steer_arrays(*columns, float(dt), params.radius)
    return Pose(*(c.reshape(shape) for c in new))


def turn_radius(speed: np.ndarray, yaw_rate: np.ndarray) -> np.ndarray:
    """Signed turn radius ``R = v / omega = v dt / phi`` (m); positive turns left, infinite when going straight."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(speed, dtype=np.float64) / np.asarray(yaw_rate, dtype=np.float64)


def turn_centre(pose: Pose, speed: np.ndarray, yaw_rate: np.ndarray) -> np.ndarray:
    """Centre ``(x, z)`` (n, 2) of the circle driven at constant v and omega: ``P + R l(psi)`` (8.31-8.34).

    Not finite when ``omega = 0`` (straight line).
    """
    radius = turn_radius(speed, yaw_rate)
    with np.errstate(invalid="ignore"):
        return np.stack([pose.x + radius * np.cos(pose.heading), pose.z - radius * np.sin(pose.heading)], axis=-1)


def wheel_matrix(pose: Pose, params: WheelParams) -> np.ndarray:
    """Render model matrix (n, 4, 4): ``M = T(x, r, z) R_y(psi - pi/2) R_z(-alpha)``.

    The wheel is modelled centred at the origin in the object's xy plane, rolling toward +x with its axle
    along z: ``R_z(-alpha)`` rolls it (8.26), ``R_y(psi - pi/2)`` turns +x onto ``f(psi)``, ``T`` lifts the centre
    to the radius. It equals the book's ``T(x, r, z) R_y(theta) R_z(+alpha)`` (8.37, forward along -x) applied
    to the model turned half a revolution about y. With ``psi = pi/2`` it is :func:`rolling_matrix`.
    """
    return (
        translation(pose.x, params.radius, pose.z)
        @ rotation_y(np.asarray(pose.heading) - 0.5 * np.pi)
        @ rotation_z(-np.asarray(pose.roll))
    )
