"""Falling particle with exact ground contact and restitution (chapter 8.1, 8.12-8.18, 8.80).

Corrected forms from PHYSICS.md section 1: the velocity law is ``v = v0 - g t`` (the printed 8.5 copies the
height law), the ground-contact time is the positive root in the cancellation-free form, the signed
impact velocity is ``-sqrt(v0^2 + 2 g (h0 - r))``, and restitution scales only the *normal* velocity
component: ``v' = v - (1 + e)(v . N) N`` when ``v . N < 0``.

Conventions: y up, SI units, ``h`` is the height of the particle's centre above the ground plane
``y = 0``, so a particle of radius ``r`` touches the ground at ``h = r``. Gravity ``g`` is a positive
magnitude. Every function takes numpy arrays with a leading batch axis (scalars broadcast) and never
modifies its inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vegym.params import Params, check_positive, check_values, param
from vegym.physics.columns import flat_columns, floats

STANDARD_GRAVITY = 9.81


@dataclass(frozen=True)
class ParticleParams(Params):
    """A spherical particle falling under uniform gravity onto the plane y = 0."""

    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0, low_open=True)
    radius: float = param(0.0, "particle radius (m); the centre touches the ground at h = radius", low=0.0)


def state_at(h: np.ndarray, v: np.ndarray, t: np.ndarray, gravity: float) -> tuple[np.ndarray, np.ndarray]:
    """Height and vertical velocity after free flight of duration ``t`` (no ground): (8.5), (8.6)."""
    h, v, t = floats(h, v, t)
    return h + v * t - 0.5 * gravity * t * t, v - gravity * t


@njit(cache=True, error_model="numpy")
def ground_time_one(h: float, v: float, radius: float, gravity: float) -> float:
    """:func:`time_to_ground` of one particle (scalars, SI); the one compiled form that the array functions and
    BouncingBall-v0's kernel run."""
    height = h - radius
    disc = v * v + 2.0 * gravity * height
    if disc < 0.0:
        return math.inf
    s = math.sqrt(disc)
    if v > 0.0:
        return (v + s) / gravity
    if height <= 0.0:
        return 0.0
    return 2.0 * height / (s - v)


@njit(cache=True, error_model="numpy")
def impact_velocity_one(h: float, v: float, radius: float, gravity: float) -> float:
    """:func:`impact_velocity` of one particle (scalars, SI): ``-sqrt(v^2 + 2 g (h - r))``."""
    return -math.sqrt(v * v + 2.0 * gravity * (h - radius))


@njit(cache=True, error_model="numpy")
def apex_height_one(h: float, v: float, gravity: float) -> float:
    """:func:`apex_height` of one particle (scalars, SI)."""
    v_up = 0.0 if v < 0.0 else v
    return h + v_up * v_up / (2.0 * gravity)


@njit(cache=True)
def normal_impulse_one(v_n: float, restitution: float) -> float:
    """Change of the normal velocity component ``v . N`` (m/s) at an impact with restitution e, to subtract along
    ``N``: ``(1 + e) v_n`` when ``v_n < 0``, else 0 (scalars; :func:`restitute` runs it)."""
    return (1.0 + restitution) * v_n if v_n < 0.0 else 0.0


@njit(cache=True)
def _ground_each(h: np.ndarray, v: np.ndarray, radius: float, gravity: float) -> tuple[np.ndarray, np.ndarray]:
    t, v_g = np.empty(h.size), np.empty(h.size)
    for i in range(h.size):
        t[i] = ground_time_one(h[i], v[i], radius, gravity)
        v_g[i] = impact_velocity_one(h[i], v[i], radius, gravity)
    return t, v_g


@njit(cache=True)
def _apex_each(h: np.ndarray, v: np.ndarray, gravity: float) -> np.ndarray:
    out = np.empty(h.size)
    for i in range(h.size):
        out[i] = apex_height_one(h[i], v[i], gravity)
    return out


@njit(cache=True)
def _impulse_each(v_n: np.ndarray, restitution: np.ndarray) -> np.ndarray:
    out = np.empty(v_n.size)
    for i in range(v_n.size):
        out[i] = normal_impulse_one(v_n[i], restitution[i])
    return out


def time_to_ground(h: np.ndarray, v: np.ndarray, radius: float, gravity: float) -> np.ndarray:
    """Exact time until the centre reaches ``h = radius`` (the corrected 8.8/8.11).

    Uses the cancellation-free root: ``t = (v + s)/g`` if ``v > 0`` else ``2 (h - r)/(s - v)``, with
    ``s = sqrt(v^2 + 2 g (h - r))``. Returns ``0`` for a particle on the ground moving down (or at rest). Meant
    for ``h >= r`` (section 1; :func:`event_step` refuses less): below the ground it gives ``+inf`` where
    ``v^2 + 2 g (h - r) < 0``, otherwise 0 moving down and, moving up, the time it falls back through ``h = r``
    (the later root).
    """
    check_positive("gravity", gravity)  # a magnitude: the vector is (0, -g, 0)
    shape, (h, v) = flat_columns(h, v)
    return _ground_each(h, v, float(radius), float(gravity))[0].reshape(shape)[()]


def impact_velocity(h: np.ndarray, v: np.ndarray, radius: float, gravity: float) -> np.ndarray:
    """Signed vertical velocity at the coming ground contact, ``-sqrt(v^2 + 2 g (h - r))`` (corrected 8.9).

    Exact by energy conservation; equal to ``v - g * time_to_ground(...)``.
    """
    check_positive("gravity", gravity)
    shape, (h, v) = flat_columns(h, v)
    return _ground_each(h, v, float(radius), float(gravity))[1].reshape(shape)[()]


def apex_height(h: np.ndarray, v: np.ndarray, gravity: float) -> np.ndarray:
    """Highest height of the centre in free flight from (h, v); ``h`` itself when moving down."""
    check_positive("gravity", gravity)
    shape, (h, v) = flat_columns(h, v)
    return _apex_each(h, v, float(gravity)).reshape(shape)[()]


def restitute(velocity: np.ndarray, normal: np.ndarray, restitution: np.ndarray) -> np.ndarray:
    """Velocity after an impact on a surface with unit outward normal ``normal`` (8.12-8.18, 8.80).

    ``velocity`` has shape (n, 3) (or (3,)); ``normal`` broadcasts against it; ``restitution`` (e in [0, 1])
    has shape (n,) or is a scalar. The normal component is reversed and scaled by e, the tangential one
    kept; a particle already leaving the surface (``v . N >= 0``) is returned unchanged.
    """
    check_values("restitution", restitution, 0.0, 1.0)
    velocity = np.asarray(velocity, dtype=np.float64)
    normal = np.broadcast_to(np.asarray(normal, dtype=np.float64), velocity.shape)
    v_n = np.sum(velocity * normal, axis=-1)
    shape, (v_n, e) = flat_columns(v_n, restitution)
    return velocity - _impulse_each(v_n, e).reshape(shape)[..., None] * normal


def event_step(
    h: np.ndarray,
    v: np.ndarray,
    dt: float,
    restitution: np.ndarray,
    params: ParticleParams,
    rest_speed: float = 1e-6,
) -> tuple[np.ndarray, np.ndarray]:
    """Advance a bouncing particle by ``dt`` exactly, resolving every ground contact inside the step.

    The clean event-exact step of PHYSICS.md section 1: fly to the contact, apply ``v = -e * v_g``, fly
    on with the rest of the step, repeat. A rebound slower than ``rest_speed`` (m/s) leaves the particle
    at rest on the ground (the Zeno guard: infinitely many bounces in finite time). After a rebound at u the
    later bounces follow in closed form, so the loop never runs on bounces that cannot change the result: with
    e < 1 they all end within ``2 u / (g (1 - e))`` (a step at least that long leaves the particle at rest),
    with e = 1 each lasts ``2 u / g`` (whole ones are skipped). The result does not depend on how a time span
    is split into steps. Finite ``h >= radius`` and ``v``, e in [0, 1], a finite ``dt >= 0`` and
    ``rest_speed > 0`` are required; a particle on the ground moving down bounces (with ``v = 0``, it rests).
    """
    h = np.array(h, dtype=np.float64, copy=True)
    v = np.array(v, dtype=np.float64, copy=True)
    e = np.broadcast_to(np.asarray(restitution, dtype=np.float64), h.shape)
    for name, values in (("h", h), ("v", v), ("restitution", e)):
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{name} must be finite, got {float(values[~np.isfinite(values)][0])!r}")
    check_values("restitution", e, 0.0, 1.0)
    if not (math.isfinite(dt) and dt >= 0.0):
        raise ValueError(f"dt={dt!r} is outside the allowed range [0, inf) s")
    if not rest_speed > 0.0:  # a bounce that never stops rebounding loops forever (Zeno)
        raise ValueError(f"rest_speed={rest_speed!r} is outside the allowed range (0, inf) m/s")
    if np.any(h < params.radius):
        raise ValueError(f"h={h.min()!r} is below the ground; the allowed range is h >= radius={params.radius}")
    g, r = params.gravity, params.radius
    t_left = np.full(h.shape, float(dt))
    active = np.ones(h.shape, dtype=bool)
    while np.any(active):  # on the ground moving down (at rest too) lands at once: it rebounds or stays at rest
        tg = time_to_ground(h, v, r, g)
        lands = active & (tg <= t_left)
        flies = active & ~lands
        h_fly, v_fly = state_at(h, v, t_left, g)
        h = np.where(flies, np.maximum(h_fly, r), h)  # short of the contact by ulps, rounding can dip below r
        v = np.where(flies, v_fly, v)
        rebound = -e * impact_velocity(h, v, r, g)
        t_left = np.where(lands, t_left - tg, t_left)
        h = np.where(lands, r, h)
        v = np.where(lands, rebound, v)
        settles = (e < 1.0) & (t_left * g * (1.0 - e) >= 2.0 * rebound)  # every later bounce ends in the step
        stops = lands & ((rebound < rest_speed) | settles)
        period = 2.0 * rebound / g
        np.fmod(t_left, period, out=t_left, where=lands & (e == 1.0) & (period > 0.0))
        v = np.where(stops, 0.0, v)
        active = lands & ~stops
    return h, v
