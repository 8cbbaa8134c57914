"""Projectile with a constant drift wind, exact ground impact and the aiming solution (8.63-8.71).

Corrected forms from PHYSICS.md section 6: the launch direction is
``d = (cos(el) cos(az), sin(el), cos(el) sin(az))`` with the elevation ``el`` above the horizon and the
azimuth ``az`` measured from +x toward +z (8.63-8.65); a constant wind ``w`` adds to the velocity *and* to
the position, ``p(t) = p0 + (v0 d + w) t + 1/2 g_vec t^2`` (the chapter's cross-wind remark, completed);
the ground impact is the time the centre of a projectile of radius ``r`` reaches ``y = r``, taken with
the cancellation-free root of section 1.

Conventions: y up, SI units, vectors as arrays of shape (n, 3) (a leading batch axis; (3,) broadcasts),
gravity a positive magnitude. The wind is a kinematic drift (the chapter's model), so keep ``w_y = 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from vegym.params import Params, param
from vegym.physics import vmath
from vegym.physics.columns import flat_columns, floats
from vegym.physics.particle import STANDARD_GRAVITY, ground_time_one, time_to_ground


@dataclass(frozen=True)
class ProjectileParams(Params):
    """A point-like (or spherical) projectile over the flat ground y = 0."""

    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0, low_open=True)
    radius: float = param(0.0, "projectile radius (m); it lands when its centre reaches y = radius", low=0.0)

    @property
    def gravity_vector(self) -> np.ndarray:
        """``(0, -g, 0)`` in m/s^2."""
        return np.array([0.0, -self.gravity, 0.0])


@njit(cache=True, error_model="numpy", inline="always")
def direction_one(elevation: float, azimuth: float) -> tuple[float, float, float]:
    """Unit launch direction ``(cos(el) cos(az), sin(el), cos(el) sin(az))`` from angles in radians (scalars); the
    one compiled form that :func:`launch_direction` and Projectile-v0's kernel run (:func:`~vegym.physics.vmath.sincos`,
    branch-free, so that the kernel's loop compiles to SIMD code)."""
    sin_el, cos_el = vmath.sincos(elevation)
    sin_az, cos_az = vmath.sincos(azimuth)
    return cos_el * cos_az, sin_el, cos_el * sin_az


@njit(cache=True)
def _direction_each(elevation: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    out = np.empty((elevation.size, 3))
    for i in range(elevation.size):
        out[i, 0], out[i, 1], out[i, 2] = direction_one(elevation[i], azimuth[i])
    return out


def launch_direction(elevation: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """Unit launch direction (n, 3) from elevation and azimuth in radians (8.63-8.65)."""
    shape, columns = flat_columns(elevation, azimuth)
    return _direction_each(*columns).reshape(*shape, 3)


def launch_velocity(elevation: np.ndarray, azimuth: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Launch velocity (n, 3) in m/s relative to the air (8.66-8.68, without wind)."""
    return np.asarray(speed, dtype=np.float64)[..., None] * launch_direction(elevation, azimuth)


def position_at(
    p0: np.ndarray, v0: np.ndarray, wind: np.ndarray, t: np.ndarray, params: ProjectileParams
) -> np.ndarray:
    """Position (n, 3) at time ``t`` (n,) after launch: ``p0 + (v0 + w) t + 1/2 g_vec t^2`` (8.69-8.71)."""
    p0, v0, wind = floats(p0, v0, wind)
    t = np.asarray(t, dtype=np.float64)[..., None]
    return p0 + (v0 + wind) * t + 0.5 * params.gravity_vector * t * t


def velocity_at(v0: np.ndarray, wind: np.ndarray, t: np.ndarray, params: ProjectileParams) -> np.ndarray:
    """Ground-relative velocity (n, 3) at time ``t``: ``v0 + w + g_vec t``."""
    v0, wind = floats(v0, wind)
    return v0 + wind + params.gravity_vector * np.asarray(t, dtype=np.float64)[..., None]


def impact_time(p0: np.ndarray, v0: np.ndarray, wind: np.ndarray, params: ProjectileParams) -> np.ndarray:
    """Exact time (n,) at which the centre reaches ``y = radius`` (the corrected section 8.4.2)."""
    u = np.asarray(v0, dtype=np.float64) + wind
    return time_to_ground(np.asarray(p0)[..., 1], u[..., 1], params.radius, params.gravity)


@njit(cache=True, error_model="numpy")
def landing_one(
    p0: tuple[float, float, float],
    v0: tuple[float, float, float],
    wind: tuple[float, float, float],
    gravity: float,
    radius: float,
) -> tuple[float, float, float]:
    """Landing ``x``, ``z`` (m) and flight time (s) of one shot from ``p0`` at air-relative ``v0`` in the drift
    ``wind`` (3-tuples, m and m/s): :func:`position_at` at the exact ground time (scalars, the one compiled form
    that :func:`impact_point` and Projectile-v0's kernel run)."""
    t = ground_time_one(p0[1], v0[1] + wind[1], radius, gravity)
    half_g = 0.5 * 0.0  # g_vec / 2 across the ground: (0, -g, 0) has no horizontal part
    x = p0[0] + (v0[0] + wind[0]) * t + half_g * t * t
    z = p0[2] + (v0[2] + wind[2]) * t + half_g * t * t
    return x, z, t


@njit(cache=True)
def _landing_each(p0: np.ndarray, v0: np.ndarray, wind: np.ndarray, gravity: float, radius: float) -> np.ndarray:
    out = np.empty((len(p0), 3))  # x, z, t
    for i in range(len(p0)):
        out[i, 0], out[i, 1], out[i, 2] = landing_one(
            (p0[i, 0], p0[i, 1], p0[i, 2]), (v0[i, 0], v0[i, 1], v0[i, 2]), (wind[i, 0], wind[i, 1], wind[i, 2]),
            gravity, radius,
        )  # fmt: skip
    return out


def impact_point(
    p0: np.ndarray, v0: np.ndarray, wind: np.ndarray, params: ProjectileParams
) -> tuple[np.ndarray, np.ndarray]:
    """Landing point (n, 3), with ``y = radius``, and flight time (n,)."""
    arrays = floats(p0, v0, wind)
    shape = np.broadcast_shapes(*(a.shape for a in arrays))
    p0, v0, wind = (np.ascontiguousarray(np.broadcast_to(a, shape)).reshape(-1, 3) for a in arrays)
    out = _landing_each(p0, v0, wind, float(params.gravity), float(params.radius))
    point = np.empty((len(out), 3))
    point[:, 0], point[:, 1], point[:, 2] = out[:, 0], params.radius, out[:, 1]
    return point.reshape(shape), out[:, 2].reshape(shape[:-1])


def firing_solution(
    delta: np.ndarray, wind: np.ndarray, speed: np.ndarray, params: ProjectileParams, lob: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Elevation, azimuth (rad), flight time (s) and a reachability mask to hit ``p0 + delta`` at ``speed``.

    ``delta`` (n, 3) is the target's position relative to the launch point (for a projectile of radius r,
    aim its centre at the target's ground point raised by r). With ``a = g_vec / 2`` the flight time T
    solves the quartic of PHYSICS.md section 6,
    ``|a|^2 T^4 + 2 (w.a) T^3 + (|w|^2 - 2 delta.a - v^2) T^2 - 2 (delta.w) T + |delta|^2 = 0``,
    whose real positive roots are found batched (eigenvalues of the companion matrices, then two Newton
    polishes). The smallest root is direct (low-angle) fire, the largest a lob. The launch direction is then
    ``d = (delta - w T - a T^2) / (v T)``. Where no positive root exists the target is out of range at this
    speed: the mask is False and the returned angles are the wind-free maximum-range shot toward the target
    (:func:`max_range_elevation` from the height ``-delta_y`` above it).
    """
    delta = np.atleast_2d(np.asarray(delta, dtype=np.float64))
    wind = np.broadcast_to(np.asarray(wind, dtype=np.float64), delta.shape)
    speed = np.broadcast_to(np.asarray(speed, dtype=np.float64), delta.shape[:1])
    a = 0.5 * params.gravity_vector
    coeffs = np.stack(
        [
            np.full(speed.shape, a @ a),
            2.0 * wind @ a,
            np.einsum("ij,ij->i", wind, wind) - 2.0 * delta @ a - speed * speed,
            -2.0 * np.einsum("ij,ij->i", delta, wind),
            np.einsum("ij,ij->i", delta, delta),
        ],
        axis=-1,
    )
    monic = coeffs[:, 1:] / coeffs[:, :1]
    companion = np.zeros((len(speed), 4, 4))
    companion[:, 0, :] = -monic
    companion[:, 1, 0] = companion[:, 2, 1] = companion[:, 3, 2] = 1.0
    roots = np.linalg.eigvals(companion)
    real = np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots.real))
    candidates = np.where(real & (roots.real > 0), roots.real, np.nan)
    reachable = np.any(np.isfinite(candidates), axis=-1)
    with np.errstate(all="ignore"):
        flight_time = (np.fmax if lob else np.fmin).reduce(candidates, axis=-1)
        derivative = coeffs[:, :4] * np.array([4.0, 3.0, 2.0, 1.0])
        for _ in range(2):
            value = np.polynomial.polynomial.polyval(flight_time, coeffs[:, ::-1].T, tensor=False)
            slope = np.polynomial.polynomial.polyval(flight_time, derivative[:, ::-1].T, tensor=False)
            step = np.where(np.abs(slope) > 0, value / slope, 0.0)
            flight_time = flight_time - np.where(np.isfinite(step), step, 0.0)
        t = flight_time[:, None]
        direction = (delta - wind * t - a * t * t) / (speed[:, None] * t)
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    elevation = np.arcsin(np.clip(direction[:, 1], -1.0, 1.0))
    azimuth = np.arctan2(direction[:, 2], direction[:, 0])
    bearing = np.arctan2(delta[:, 2], delta[:, 0])
    fallback = max_range_elevation(speed, -delta[:, 1], params)
    elevation = np.where(reachable, elevation, fallback)
    azimuth = np.where(reachable, azimuth, bearing)
    return elevation, azimuth, np.where(reachable, flight_time, np.nan), reachable


def max_range(speed: np.ndarray, height: np.ndarray, params: ProjectileParams) -> np.ndarray:
    """Greatest wind-free horizontal range (m) at ``speed`` (m/s) from ``height`` (m) above the landing level.

    Closed form: ``(v / g) sqrt(v^2 + 2 g h)`` at the elevation :func:`max_range_elevation`.
    """
    v, h, g = np.asarray(speed, dtype=np.float64), np.asarray(height, dtype=np.float64), params.gravity
    return v / g * np.sqrt(v * v + 2.0 * g * h)


def max_range_elevation(speed: np.ndarray, height: np.ndarray, params: ProjectileParams) -> np.ndarray:
    """Elevation (rad) of the greatest wind-free range at ``speed`` (m/s) from ``height`` (m) above the landing
    level: ``asin(v / sqrt(2 (v^2 + g h)))``, 45 degrees from the landing level, flatter from above it; straight up
    (pi/2) where the landing level is at or above the apex of a vertical shot (``h <= -v^2 / (2 g)``)."""
    v, h = np.asarray(speed, dtype=np.float64), np.asarray(height, dtype=np.float64)
    square = 2.0 * (v * v + params.gravity * h)
    with np.errstate(divide="ignore", invalid="ignore"):
        sine = np.where(square > 0.0, v / np.sqrt(np.maximum(square, 0.0)), 1.0)
    return np.arcsin(np.minimum(sine, 1.0))
