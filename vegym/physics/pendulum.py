"""The simple pendulum of chapter 8.5 with both printed sign errors fixed, and energy pumping.

Corrected form from PHYSICS.md section 7: the printed scheme ``d' = d - v dt``, ``a = g d / L`` has two sign errors
that cancel; fixed, the angle theta (rad, from the downward vertical, anticlockwise positive) and the angular
velocity omega obey::

    d omega / dt = -(g/L) sin(theta) - (b / (m L^2)) omega + tau / (m L^2),    d theta / dt = omega

with a viscous pivot damping b (N m s/rad) and a torque tau (N m) at the pivot. Semi-implicit Euler updates omega
first and then theta with the new omega; its energy ``E = m L^2 omega^2 / 2 + m g L (1 - cos theta)`` stays
bounded without drift (explicit Euler makes it grow). In arc length, ``d = L theta`` and ``v = L omega``.

The array functions take arrays with a leading batch axis (scalars broadcast) and never modify their inputs; each
runs one of the scalar numba kernels (``*_of``, :func:`swing`) that PendulumPump-v0's step kernel also runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vegym.params import Params, check_positive, check_values, param
from vegym.physics import vmath
from vegym.physics.columns import flat_columns
from vegym.physics.particle import STANDARD_GRAVITY


@dataclass(frozen=True)
class PendulumParams(Params):
    """A point mass on a rigid massless rod, pivoting in a vertical plane."""

    length: float = param(1.0, "L, rod length (m)", low=0.0, low_open=True)
    mass: float = param(1.0, "m, bob mass (kg)", low=0.0, low_open=True)
    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0, low_open=True)
    damping: float = param(0.05, "b, viscous pivot damping (N m s/rad)", low=0.0)

    @property
    def inertia(self) -> float:
        """``m L^2`` (kg m^2)."""
        return self.mass * self.length * self.length

    @property
    def weight_moment(self) -> float:
        """``m g L`` (J): the energy of a swing to the horizontal; ``2 m g L`` reaches the top."""
        return self.mass * self.gravity * self.length

    @property
    def small_angle_period(self) -> float:
        """``T0 = 2 pi sqrt(L / g)`` (s)."""
        return 2.0 * math.pi * math.sqrt(self.length / self.gravity)

    def max_stable_step(self) -> float:
        """Largest semi-implicit Euler step (s) about the hanging position: the root of
        ``(g/L) h^2 + 2 (b / (m L^2)) h = 4``."""
        return vmath.stable_step(self.damping / self.inertia, self.gravity / self.length)


@njit(cache=True)
def acceleration_of(
    theta: float, omega: float, torque: float, g_over_l: float, damping: float, inertia: float
) -> float:
    """One pendulum's ``-(g/L) sin theta - (b / (m L^2)) omega + tau / (m L^2)`` (rad/s^2), in scalars (branch-free:
    :func:`vmath.sincos`)."""
    return -g_over_l * vmath.sincos(theta)[0] + (torque - damping * omega) / inertia


@njit(cache=True)
def swing(
    theta: float, omega: float, torque: float, dt: float, g_over_l: float, damping: float, inertia: float
) -> tuple[float, float]:
    """One pendulum, one semi-implicit Euler step of ``dt`` s: the new (theta, omega), in scalars.

    The one compiled form of the integrator: :func:`step` loops over it and PendulumPump-v0's step kernel inlines it.
    """
    new_omega = omega + dt * acceleration_of(theta, omega, torque, g_over_l, damping, inertia)
    return theta + dt * new_omega, new_omega


@njit(cache=True)
def energy_of(theta: float, omega: float, inertia: float, weight_moment: float) -> float:
    """One pendulum's ``m L^2 omega^2 / 2 + m g L (1 - cos theta)`` (J), in scalars (branch-free:
    :func:`vmath.sincos`)."""
    return energy_from_cos(vmath.sincos(theta)[1], omega, inertia, weight_moment)


@njit(cache=True)
def energy_from_cos(cos_theta: float, omega: float, inertia: float, weight_moment: float) -> float:
    """:func:`energy_of` from ``cos theta``, for a caller that has it already, in scalars."""
    return 0.5 * inertia * omega * omega + weight_moment * (1.0 - cos_theta)


@njit(cache=True, inline="always", error_model="numpy")
def amplitude_of(energy_: float, weight_moment: float) -> float:
    """One swing's amplitude ``arccos(clip(1 - E / (m g L), -1, 1))`` (rad), in scalars (branch-free:
    :func:`vmath.acos`)."""
    return vmath.acos(min(max(1.0 - energy_ / weight_moment, -1.0), 1.0))


@njit(cache=True)
def _acceleration_each(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray, g_over_l: float, damping: float, inertia: float
) -> np.ndarray:
    out = np.empty(theta.size)
    for i in range(theta.size):
        out[i] = acceleration_of(theta[i], omega[i], torque[i], g_over_l, damping, inertia)
    return out


@njit(cache=True)
def _swing_each(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray, dt: float, g_over_l: float, damping: float, inertia: float
) -> tuple[np.ndarray, np.ndarray]:
    new_theta, new_omega = np.empty(theta.size), np.empty(theta.size)
    for i in range(theta.size):
        new_theta[i], new_omega[i] = swing(theta[i], omega[i], torque[i], dt, g_over_l, damping, inertia)
    return new_theta, new_omega


@njit(cache=True)
def _energy_each(theta: np.ndarray, omega: np.ndarray, inertia: float, weight_moment: float) -> np.ndarray:
    out = np.empty(theta.size)
    for i in range(theta.size):
        out[i] = energy_of(theta[i], omega[i], inertia, weight_moment)
    return out


@njit(cache=True)
def _amplitude_each(energy_: np.ndarray, weight_moment: float) -> np.ndarray:
    out = np.empty(energy_.size)
    for i in range(energy_.size):
        out[i] = amplitude_of(energy_[i], weight_moment)
    return out


def angular_acceleration(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray | float, params: PendulumParams
) -> np.ndarray:
    """``-(g/L) sin theta - (b / (m L^2)) omega + tau / (m L^2)`` (rad/s^2), by :func:`acceleration_of`."""
    p = params
    shape, (theta, omega, torque) = flat_columns(theta, omega, torque)
    return _acceleration_each(theta, omega, torque, p.gravity / p.length, p.damping, p.inertia).reshape(shape)[()]


def step(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray | float, dt: float, params: PendulumParams
) -> tuple[np.ndarray, np.ndarray]:
    """One semi-implicit Euler step of ``dt`` seconds with the torque held: the new (theta, omega). theta is not
    wrapped; ``dt`` must be positive."""
    check_positive("dt", dt)
    p = params
    shape, (theta, omega, torque) = flat_columns(theta, omega, torque)
    new_theta, new_omega = _swing_each(theta, omega, torque, float(dt), p.gravity / p.length, p.damping, p.inertia)
    return new_theta.reshape(shape)[()], new_omega.reshape(shape)[()]


def energy(theta: np.ndarray, omega: np.ndarray, params: PendulumParams) -> np.ndarray:
    """``m L^2 omega^2 / 2 + m g L (1 - cos theta)`` (J), zero at rest hanging down."""
    shape, (theta, omega) = flat_columns(theta, omega)
    return _energy_each(theta, omega, params.inertia, params.weight_moment).reshape(shape)[()]


def amplitude_energy(amplitude: np.ndarray, params: PendulumParams) -> np.ndarray:
    """Energy (J) of a swing of amplitude theta* (rad): ``m g L (1 - cos theta*)``, the energy at rest there."""
    return energy(amplitude, 0.0, params)


def period(amplitude: np.ndarray, params: PendulumParams) -> np.ndarray:
    """Exact period (s) of the undamped swing of amplitude theta0 (rad, in ``[0, pi]``):
    ``T = 4 sqrt(L/g) K(sin^2(theta0 / 2))`` (PHYSICS.md section 7; ``K`` the complete elliptic integral of the first
    kind, scipy's ``ellipk`` of the parameter ``m = k^2``). ``T0 = 2 pi sqrt(L/g)`` at 0, infinite at ``pi``."""
    from scipy.special import ellipk  # here, not at import: only this function needs scipy

    check_values("amplitude", amplitude, 0.0, math.pi)
    half_sine = np.sin(0.5 * np.asarray(amplitude, dtype=np.float64))
    return 4.0 * math.sqrt(params.length / params.gravity) * ellipk(half_sine * half_sine)


def energy_amplitude(energy_: np.ndarray, params: PendulumParams) -> np.ndarray:
    """Amplitude (rad) of the undamped swing with this energy: ``arccos(1 - E / (m g L))``; pi from ``2 m g L`` up
    (the pendulum goes over the top), 0 for ``E <= 0``."""
    shape, (energy_,) = flat_columns(energy_)
    return _amplitude_each(energy_, params.weight_moment).reshape(shape)[()]


def pump_torque(
    theta: np.ndarray,
    omega: np.ndarray,
    target_amplitude: np.ndarray,
    gain: float,
    max_torque: float,
    params: PendulumParams,
) -> np.ndarray:
    """Energy pumping toward the swing of amplitude theta*: ``tau = sat(k_E (E* - E) omega, +-tau_max)`` (N m).

    The torque's power ``tau omega = k_E (E* - E) omega^2`` has the sign of ``E* - E``, so the energy moves
    toward ``E* = m g L (1 - cos theta*)``; ``gain`` k_E is in N m per (J rad/s).
    """
    check_values("max_torque", max_torque, 0.0, math.inf, high_open=True)
    error = amplitude_energy(target_amplitude, params) - energy(theta, omega, params)
    return np.clip(gain * error * omega, -max_torque, max_torque)
