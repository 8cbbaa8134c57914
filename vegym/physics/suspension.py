"""Spring-mass with gravity and viscous damping on a moving base: the quarter-car of chapter 8.6 (8.89-8.98).

Corrected forms from PHYSICS.md section 8. Hooke's law with modulus ``lambda`` and natural length ``l`` gives the
stiffness ``k = lambda / l``. The book's per-step velocity factor ``k_d`` (8.96) is replaced by a viscous damper
``c`` (N s/m, a rate, so the motion does not depend on the step), and the book's per-step terrain difference ``h``
by the cumulative base displacement: the spring's foot, the wheel's axle, rides at ``y_b(t) = terrain(x(t)) + r_w``
(Suspension-v0 measures it from its start, ``terrain(x) - terrain(x_0)``: a constant shift).

Quarter-car, y up: a body of mass ``m`` at height ``y`` on top of a spring and a damper whose foot is the wheel
axle at height ``y_b``, moving at ``v_b = terrain'(x) dx/dt``::

    dv/dt = -(k/m) (y - y_b - l) - (c/m) (v - v_b) - g + u/m,    dy/dt = v

integrated with semi-implicit Euler (``v`` first, then ``y`` with the new ``v``), which is stable for
``(omega_n h)^2 + 2 (c/m) h < 4``. At rest on a level base ``y - y_b = l - m g / k``; the natural frequency is
``omega_n = sqrt(k/m) = sqrt(lambda / (m l))`` and the period ``2 pi sqrt(m l / lambda)``.

All functions take arrays with a leading batch axis (scalars broadcast) and never modify their inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vegym.params import Params, check_positive, param
from vegym.physics import vmath
from vegym.physics.columns import flat_columns, floats, scratch
from vegym.physics.particle import STANDARD_GRAVITY


@dataclass(frozen=True)
class SpringParams(Params):
    """A mass on a linear spring (Hooke's law with modulus and natural length) under gravity."""

    mass: float = param(2.0, "m, mass on the spring (kg)", low=0.0, low_open=True)
    modulus: float = param(
        80.0, "lambda, modulus of the spring (N); the tension is lambda e / l", low=0.0, low_open=True
    )
    natural_length: float = param(1.0, "l, natural length of the spring (m)", low=0.0, low_open=True)
    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0)

    @property
    def stiffness(self) -> float:
        """``k = lambda / l`` (N/m)."""
        return self.modulus / self.natural_length

    @property
    def natural_frequency(self) -> float:
        """``omega_n = sqrt(k / m)`` (rad/s)."""
        return math.sqrt(self.stiffness / self.mass)

    @property
    def period(self) -> float:
        """Undamped period ``2 pi sqrt(m l / lambda)`` (s)."""
        return 2.0 * math.pi / self.natural_frequency

    @property
    def static_length(self) -> float:
        """Spring length at rest under the mass on a level base, ``l - m g / k`` (m)."""
        return self.natural_length - self.mass * self.gravity / self.stiffness

    def max_stable_step(self, damping: float) -> float:
        """Largest semi-implicit Euler step (s) for the damper ``c``: the root of ``(omega_n h)^2 + 2 (c/m) h = 4``."""
        return vmath.stable_step(damping / self.mass, self.stiffness / self.mass)


@njit(cache=True)
def body_step(
    height: float,
    velocity: float,
    base: float,
    base_velocity: float,
    damping: float,
    dt: float,
    force: float,
    spring: tuple[float, float, float, float],
) -> tuple[float, float, float]:
    """One quarter-car, one semi-implicit Euler step (scalars, SI): new height, new velocity, acceleration applied.

    ``spring = (k, l, m, g)``. The one compiled form of the model: :func:`acceleration` and :func:`step` loop over it
    and Suspension-v0's step kernel inlines it.
    """
    stiffness, natural_length, mass, gravity = spring
    a = (-stiffness * (height - base - natural_length) + -damping * (velocity - base_velocity) + force) / mass - gravity
    new_velocity = velocity + dt * a
    return height + dt * new_velocity, new_velocity, a


@njit(cache=True)
def _step_each(
    height: np.ndarray,
    velocity: np.ndarray,
    base: np.ndarray,
    base_velocity: np.ndarray,
    damping: np.ndarray,
    force: np.ndarray,
    dt: float,
    spring: tuple[float, float, float, float],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    new_height, new_velocity, a = np.empty(height.size), np.empty(height.size), np.empty(height.size)
    for i in range(height.size):
        new_height[i], new_velocity[i], a[i] = body_step(
            height[i], velocity[i], base[i], base_velocity[i], damping[i], dt, force[i], spring
        )
    return new_height, new_velocity, a


def _spring(params: SpringParams) -> tuple[float, float, float, float]:
    return (params.stiffness, params.natural_length, params.mass, params.gravity)


def acceleration(
    height: np.ndarray,
    velocity: np.ndarray,
    base: np.ndarray,
    base_velocity: np.ndarray,
    damping: np.ndarray,
    params: SpringParams,
    force: np.ndarray | float = 0.0,
) -> np.ndarray:
    """Body acceleration (m/s^2, y up) of the quarter-car: spring, damper ``c`` (N s/m), gravity, actuator ``u`` (N)."""
    shape, columns = flat_columns(height, velocity, base, base_velocity, damping, force)
    return _step_each(*columns, 0.0, _spring(params))[2].reshape(shape)[()]


def step(
    height: np.ndarray,
    velocity: np.ndarray,
    base: np.ndarray,
    base_velocity: np.ndarray,
    damping: np.ndarray,
    dt: float,
    params: SpringParams,
    force: np.ndarray | float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One semi-implicit Euler step of ``dt`` seconds with the base at its start-of-step height and velocity.

    Returns the new height (m), the new velocity (m/s) and the acceleration applied over the step (m/s^2);
    ``dt`` must be positive.
    """
    check_positive("dt", dt)
    shape, columns = flat_columns(height, velocity, base, base_velocity, damping, force)
    return tuple(c.reshape(shape)[()] for c in _step_each(*columns, float(dt), _spring(params)))


def energy(height: np.ndarray, velocity: np.ndarray, base: np.ndarray, params: SpringParams) -> np.ndarray:
    """Mechanical energy (J) with the base held at ``base``: ``m v^2 / 2 + m g y + k (y - y_b - l)^2 / 2``."""
    p = params
    height, velocity, base = floats(height, velocity, base)
    extension = height - base - p.natural_length
    return 0.5 * p.mass * velocity * velocity + p.mass * p.gravity * height + 0.5 * p.stiffness * extension * extension


def transmissibility(omega: np.ndarray, damping: np.ndarray, params: SpringParams) -> np.ndarray:
    """Steady-state ratio of body to base amplitude under sinusoidal base motion at ``omega`` (rad/s):
    ``sqrt((k^2 + (c omega)^2) / ((k - m omega^2)^2 + (c omega)^2))``."""
    k, m = params.stiffness, params.mass
    cw2 = (np.asarray(damping) * np.asarray(omega)) ** 2
    return np.sqrt((k * k + cw2) / ((k - m * np.asarray(omega) ** 2) ** 2 + cw2))


@njit(cache=True, nogil=True, inline="always")
def terrain_into(
    distance: np.ndarray,
    amplitude: np.ndarray,
    wavenumber: np.ndarray,
    phase: np.ndarray,
    height: np.ndarray,
    slope: np.ndarray,
) -> None:
    """Terrain heights (m) and slopes at the distances x (n,) written into ``height`` and ``slope`` (n,): for each
    row, ``sum_j A_j sin(kappa_j x + phi_j)`` and its derivative, with ``amplitude`` (m), ``wavenumber`` (rad/m) and
    ``phase`` (rad) arrays (n, J). Written as passes over the batch for SIMD code, two per sinusoid: its angle and
    coefficients gathered from the columns into contiguous scratch, then its sine and cosine (``vmath.sincos``)
    added in. The one compiled form of the terrain, behind :func:`terrain` and Suspension-v0's step kernel."""
    n = len(distance)
    angle, sine_coefficient, cosine_coefficient = scratch(n), scratch(n), scratch(n)
    for i in range(n):
        height[i], slope[i] = 0.0, 0.0
    for j in range(amplitude.shape[1]):
        for i in range(n):
            angle[i] = wavenumber[i, j] * distance[i] + phase[i, j]
            sine_coefficient[i], cosine_coefficient[i] = amplitude[i, j], amplitude[i, j] * wavenumber[i, j]
        for i in range(n):
            sine, cosine = vmath.sincos(angle[i])
            height[i] += sine_coefficient[i] * sine
            slope[i] += cosine_coefficient[i] * cosine


def terrain(
    distance: np.ndarray, amplitude: np.ndarray, wavenumber: np.ndarray, phase: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Height (m) and slope of an undulating terrain ``sum_j A_j sin(kappa_j x + phi_j)`` at ``distance`` x (n,)
    (or a scalar: n = 1).

    ``amplitude`` (m), ``wavenumber`` (rad/m) and ``phase`` (rad) are (n, J) arrays, one row per terrain, or
    (1, J) (or (J,)): one terrain at every distance (:func:`terrain_into`). Other shapes raise ``ValueError``.
    """
    distance, *coefficients = floats(distance, amplitude, wavenumber, phase)
    distance = np.ascontiguousarray(np.atleast_1d(distance))
    if distance.ndim != 1:
        raise ValueError(f"distance has shape {distance.shape}; the allowed shapes are (n,) and ()")
    n = len(distance)
    rows = [np.atleast_2d(values) for values in coefficients]
    waves = rows[0].shape[-1]
    for name, values in zip(("amplitude", "wavenumber", "phase"), rows, strict=True):
        if values.ndim != 2 or values.shape[0] not in (1, n) or values.shape[1] != waves:
            raise ValueError(
                f"{name} has shape {values.shape}; the allowed shapes for {n} distances and {waves} sinusoids are "
                f"({n}, {waves}), one terrain per distance, and (1, {waves}), one terrain for all"
            )
    rows = [np.ascontiguousarray(np.broadcast_to(values, (n, waves))) for values in rows]
    height, slope = np.empty(n), np.empty(n)
    terrain_into(distance, *rows, height, slope)
    return height, slope


def skyhook_damping(body_velocity: np.ndarray, relative_velocity: np.ndarray, c_min: float, c_max: float) -> np.ndarray:
    """Semi-active (on-off) skyhook: ``c_max`` where ``v (v - v_b) > 0``, else ``c_min`` (N s/m).

    The damper can only resist the relative velocity ``v - v_b``; it is stiff when that force also opposes the
    body's absolute velocity ``v``, as a damper to a fixed "sky" would, and soft otherwise.
    """
    return np.where(body_velocity * relative_velocity > 0.0, c_max, c_min)


def continuous_skyhook_damping(
    body_velocity: np.ndarray, relative_velocity: np.ndarray, c_sky: float, c_min: float, c_max: float
) -> np.ndarray:
    """Semi-active continuous (clipped) skyhook: where ``v (v - v_b) > 0``, the ``c`` whose damper force
    ``-c (v - v_b)`` equals the sky damper's ``-c_sky v``, clipped to ``[c_min, c_max]``; elsewhere ``c_min`` (N s/m).

    Where the on-off law (:func:`skyhook_damping`) switches between the extremes, this one follows the sky force
    wherever the damper's range reaches it; with ``c_sky = c_max`` it is stiff exactly where the on-off law is
    stiff and the relative velocity is at most the body's.
    """
    body_velocity, relative_velocity = floats(body_velocity, relative_velocity)
    opposing = body_velocity * relative_velocity > 0.0
    ratio = np.divide(c_sky * body_velocity, relative_velocity, out=np.zeros(np.shape(opposing)), where=opposing)
    return np.where(opposing, np.clip(ratio, c_min, c_max), c_min)
