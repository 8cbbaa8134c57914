"""The simple pendulum of chapter 8.5 with both printed sign errors fixed, and energy pumping.

Corrected form from PHYSICS.md section 7: the printed scheme ``d' = d - v dt``, ``a = g d / L`` has two sign errors
that cancel; fixed, the angle theta (rad, from the downward vertical, anticlockwise positive) and the angular
velocity omega obey::

    d omega / dt = -(g/L) sin(theta) - (b / (m L^2)) omega + tau / (m L^2),    d theta / dt = omega

with a viscous pivot damping b (N m s/rad) and a torque tau (N m) at the pivot. Semi-implicit Euler updates omega
first and then theta with the new omega; its energy ``E = m L^2 omega^2 / 2 + m g L (1 - cos theta)`` stays
bounded without drift (explicit Euler makes it grow). In arc length, ``d = L theta`` and ``v = L omega``.

All functions take arrays with a leading batch axis (scalars broadcast) and never modify their inputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vegym.params import Params, param
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
        beta, w2 = self.damping / self.inertia, self.gravity / self.length
        return (math.sqrt(beta * beta + 4.0 * w2) - beta) / w2


def angular_acceleration(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray | float, params: PendulumParams
) -> np.ndarray:
    """``-(g/L) sin theta - (b / (m L^2)) omega + tau / (m L^2)`` (rad/s^2)."""
    p = params
    return -(p.gravity / p.length) * np.sin(theta) + (torque - p.damping * omega) / p.inertia


def step(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray | float, dt: float, params: PendulumParams
) -> tuple[np.ndarray, np.ndarray]:
    """One semi-implicit Euler step of ``dt`` seconds with the torque held: the new (theta, omega). theta is not
    wrapped."""
    new_omega = omega + dt * angular_acceleration(theta, omega, torque, params)
    return theta + dt * new_omega, new_omega


def energy(theta: np.ndarray, omega: np.ndarray, params: PendulumParams) -> np.ndarray:
    """``m L^2 omega^2 / 2 + m g L (1 - cos theta)`` (J), zero at rest hanging down."""
    return 0.5 * params.inertia * omega * omega + params.weight_moment * (1.0 - np.cos(theta))


def amplitude_energy(amplitude: np.ndarray, params: PendulumParams) -> np.ndarray:
    """Energy (J) of a swing of amplitude theta* (rad): ``m g L (1 - cos theta*)``."""
    return params.weight_moment * (1.0 - np.cos(amplitude))


def energy_amplitude(energy_: np.ndarray, params: PendulumParams) -> np.ndarray:
    """Amplitude (rad) of the undamped swing with this energy: ``arccos(1 - E / (m g L))``; pi from ``2 m g L`` up
    (the pendulum goes over the top), 0 for ``E <= 0``."""
    return np.arccos(np.clip(1.0 - np.asarray(energy_) / params.weight_moment, -1.0, 1.0))


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
    error = amplitude_energy(target_amplitude, params) - energy(theta, omega, params)
    return np.clip(gain * error * omega, -max_torque, max_torque)
