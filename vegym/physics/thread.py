"""The elastic thread of mass points fixed at both ends (chapter 8.6.3, 8.99-8.112), in vector form.

Corrected form from PHYSICS.md section 9. N interior nodes ``p_1 .. p_N`` of mass m hang between the fixed ends
``p_0 = (0, 0)`` and ``p_{N+1} = (span, 0)`` (x along the span, y up), joined by N + 1 springs of stiffness S
(N/m) and natural length l. Spring j joins ``p_j`` and ``p_{j+1}``::

    d_j = p_{j+1} - p_j,   L_j = |d_j|,   f_j = S (L_j - l) d_j / L_j
    F_i = f_i - f_{i-1} - m g y_hat - c v_i + u_i,   a_i = F_i / m

with an air-drag coefficient c (N s/m) and actuator forces u_i (N). Semi-implicit Euler: ``v <- v + h a``, then
``p <- p + h v`` with the new v (the printed 8.110-8.111 pair is explicit Euler and drops the step from 8.111).
It is stable for ``h < 2 / omega_max``, with ``omega_max < 2 sqrt(S/m)``; :func:`step` enforces the safe rule
``h < sqrt(m/S)`` (and ``c h / m < 1``) and :func:`substeps` splits a longer step accordingly.

Positions and velocities are arrays (n, N, 2) (batch, node, xy); forces on interior nodes likewise. Functions
never modify their inputs.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vegym.params import Params, param
from vegym.physics.columns import pairwise_sum
from vegym.physics.particle import STANDARD_GRAVITY


@dataclass(frozen=True)
class ThreadParams(Params):
    """An elastic thread: N point masses joined by N + 1 identical springs between two fixed ends at equal height."""

    n_nodes: int = param(9, "N, interior mass points", low=1, high=256)
    node_mass: float = param(0.02, "m, mass of each point (kg)", low=0.0, low_open=True)
    stiffness: float = param(400.0, "S, spring stiffness (N/m)", low=0.0, low_open=True)
    natural_length: float = param(0.1, "l, natural length of each spring (m)", low=0.0, low_open=True)
    span: float = param(1.1, "distance between the fixed ends (m)", low=0.0, low_open=True)
    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0)
    drag: float = param(0.002, "c, viscous air drag on each point (N s/m)", low=0.0)

    @property
    def stable_step(self) -> float:
        """The safe semi-implicit Euler step bound (s): ``min(sqrt(m/S), m/c)``."""
        bound = math.sqrt(self.node_mass / self.stiffness)
        return min(bound, self.node_mass / self.drag) if self.drag > 0 else bound

    @property
    def constants(self) -> tuple[float, float, float, float, float, float]:
        """``(S, l, m, g, c, span)``, as the kernels take them (SI)."""
        return (self.stiffness, self.natural_length, self.node_mass, self.gravity, self.drag, self.span)

    @property
    def ends(self) -> np.ndarray:
        """The fixed end points ``p_0`` and ``p_{N+1}``, shape (2, 2)."""
        return np.array([[0.0, 0.0], [self.span, 0.0]])


def _chain(positions: np.ndarray, params: ThreadParams) -> np.ndarray:
    """All N + 2 points (n, N + 2, 2), the fixed ends included."""
    n = len(positions)
    ends = np.broadcast_to(params.ends, (n, 2, 2))
    return np.concatenate([ends[:, :1], positions, ends[:, 1:]], axis=1)


def spring_forces(positions: np.ndarray, params: ThreadParams) -> tuple[np.ndarray, np.ndarray]:
    """Tension vectors ``f_j`` (n, N + 1, 2) pulling ``p_j`` toward ``p_{j+1}`` (N), and the lengths ``L_j`` (m)."""
    d = np.diff(_chain(positions, params), axis=1)
    length = np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])
    return (params.stiffness * (length - params.natural_length) / length)[..., None] * d, length


@njit(cache=True)
def accelerate(
    positions: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    c: tuple[float, float, float, float, float, float],
    out: np.ndarray,
) -> None:
    """Accelerations (N, 2) of one thread's nodes (m/s^2), written into ``out``: springs, gravity, drag and the
    applied forces (N, 2) (N); ``c = ThreadParams.constants``. The one compiled form of the model, behind
    :func:`acceleration`, :func:`step` and Thread-v0's kernel."""
    stiffness, natural_length, mass, gravity, drag, span = c
    n = len(positions)
    before_x, before_y = 0.0, 0.0
    for j in range(n + 1):  # spring j joins p_j and p_{j+1}; p_0 = (0, 0) and p_{N+1} = (span, 0) are fixed
        x0, y0 = (0.0, 0.0) if j == 0 else (positions[j - 1, 0], positions[j - 1, 1])
        x1, y1 = (span, 0.0) if j == n else (positions[j, 0], positions[j, 1])
        dx, dy = x1 - x0, y1 - y0
        length = math.sqrt(dx * dx + dy * dy)
        tension = stiffness * (length - natural_length) / length
        fx, fy = tension * dx, tension * dy
        if j > 0:
            i = j - 1
            out[i, 0] = (fx - before_x - drag * velocities[i, 0] + forces[i, 0]) / mass
            out[i, 1] = (fy - before_y - drag * velocities[i, 1] + forces[i, 1]) / mass - gravity
        before_x, before_y = fx, fy


@njit(cache=True)
def advance(
    positions: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    dt: float,
    c: tuple[float, float, float, float, float, float],
    scratch: np.ndarray,
) -> None:
    """One semi-implicit Euler step of ``dt`` seconds of one thread, in place on ``positions`` and ``velocities``
    (N, 2); ``scratch`` (N, 2) receives the accelerations."""
    accelerate(positions, velocities, forces, c, scratch)
    for i in range(len(positions)):
        for k in range(2):
            velocities[i, k] = velocities[i, k] + dt * scratch[i, k]
            positions[i, k] = positions[i, k] + dt * velocities[i, k]


@njit(cache=True)
def energy_one(
    positions: np.ndarray,
    velocities: np.ndarray,
    c: tuple[float, float, float, float, float, float],
    scratch: np.ndarray,
) -> float:
    """:func:`energy` of one thread (J), summed in numpy's order; ``scratch`` holds at least 2 N + 2 floats."""
    stiffness, natural_length, mass, gravity, _, span = c
    n = len(positions)
    squares = scratch[: 2 * n]
    for i in range(n):
        squares[2 * i], squares[2 * i + 1] = velocities[i, 0] * velocities[i, 0], velocities[i, 1] * velocities[i, 1]
    kinetic = 0.5 * mass * pairwise_sum(squares)
    heights = scratch[:n]
    for i in range(n):
        heights[i] = positions[i, 1]
    potential = mass * gravity * pairwise_sum(heights)
    stretches = scratch[: n + 1]
    for j in range(n + 1):
        x0, y0 = (0.0, 0.0) if j == 0 else (positions[j - 1, 0], positions[j - 1, 1])
        x1, y1 = (span, 0.0) if j == n else (positions[j, 0], positions[j, 1])
        dx, dy = x1 - x0, y1 - y0
        stretch = math.sqrt(dx * dx + dy * dy) - natural_length
        stretches[j] = stretch * stretch
    return kinetic + potential + 0.5 * stiffness * pairwise_sum(stretches)


@njit(cache=True)
def _accelerate_each(
    positions: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    c: tuple[float, float, float, float, float, float],
) -> np.ndarray:
    out = np.empty_like(positions)
    for b in range(len(positions)):
        accelerate(positions[b], velocities[b], forces[b], c, out[b])
    return out


@njit(cache=True)
def _advance_each(
    positions: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    dt: float,
    c: tuple[float, float, float, float, float, float],
) -> None:
    scratch = np.empty(positions.shape[1:])
    for b in range(len(positions)):
        advance(positions[b], velocities[b], forces[b], dt, c, scratch)


@njit(cache=True)
def _energy_each(
    positions: np.ndarray, velocities: np.ndarray, c: tuple[float, float, float, float, float, float]
) -> np.ndarray:
    out, scratch = np.empty(len(positions)), np.empty(2 * positions.shape[1] + 2)
    for b in range(len(positions)):
        out[b] = energy_one(positions[b], velocities[b], c, scratch)
    return out


def _batch(*arrays: np.ndarray | float) -> list[np.ndarray]:
    """``arrays`` broadcast to one shape (n, N, 2) as new contiguous float64 arrays."""
    shape = np.broadcast_shapes(*(np.shape(a) for a in arrays))
    return [np.array(np.broadcast_to(np.asarray(a, dtype=np.float64), shape)) for a in arrays]


def acceleration(
    positions: np.ndarray, velocities: np.ndarray, forces: np.ndarray | float, params: ThreadParams
) -> np.ndarray:
    """Node accelerations (n, N, 2) (m/s^2): springs, gravity, drag and the applied forces ``u`` (N)."""
    return _accelerate_each(*_batch(positions, velocities, forces), params.constants)


def step(
    positions: np.ndarray, velocities: np.ndarray, forces: np.ndarray | float, dt: float, params: ThreadParams
) -> tuple[np.ndarray, np.ndarray]:
    """One semi-implicit Euler step of ``dt`` seconds; the new (positions, velocities).

    Raises ``ValueError`` if ``dt`` breaks the stability bound :attr:`ThreadParams.stable_step`.
    """
    if not 0.0 < dt < params.stable_step:
        raise ValueError(
            f"dt={dt!r} is outside the stable range (0, {params.stable_step:.4g}) s: semi-implicit Euler needs "
            "dt < sqrt(m/S) and dt < m/c; split the step (thread.substeps)"
        )
    positions, velocities, forces = _batch(positions, velocities, forces)
    _advance_each(positions, velocities, forces, float(dt), params.constants)
    return positions, velocities


def substeps(dt: float, params: ThreadParams, margin: float = 0.5) -> int:
    """Number of equal substeps that splits ``dt`` into steps of at most ``margin`` times the stable step."""
    return max(1, math.ceil(dt / (margin * params.stable_step)))


def energy(positions: np.ndarray, velocities: np.ndarray, params: ThreadParams) -> np.ndarray:
    """Mechanical energy (n,) (J): kinetic ``sum m |v|^2 / 2`` + gravity ``sum m g y`` + elastic
    ``sum S (L - l)^2 / 2``."""
    return _energy_each(*_batch(positions, velocities), params.constants)


@functools.lru_cache(maxsize=32)
def static_equilibrium(params: ThreadParams, tolerance: float = 1e-12) -> np.ndarray:
    """The thread at rest (N, 2) under gravity (m): the minimum of the potential energy, by damped Newton steps.

    It starts from a parabola of the arc length ``(N + 1) l`` (at least 1% of the span deep). Each step solves
    ``(K + mu I) dp = F`` with the tangent stiffness K (``S [(1 - l/L) I + (l/L) d d^T / L^2]`` per spring), ``mu``
    raised until the matrix is positive definite, and halves dp until the potential energy drops or the residual
    force halves; it stops when the largest residual force is below ``tolerance`` times ``m g + S l``. Raises
    ``RuntimeError`` without convergence or at an unstable equilibrium. The result is read-only.
    """
    p = params
    n = p.n_nodes
    x = p.span * np.arange(1, n + 1) / (n + 1)
    slack = max((n + 1) * p.natural_length - p.span, 0.0)
    depth = max(math.sqrt(3.0 * p.span * slack / 8.0), 0.01 * p.span)
    positions = np.stack([x, -4.0 * depth * x * (p.span - x) / p.span**2], axis=-1)[None]
    scale = p.node_mass * p.gravity + p.stiffness * p.natural_length
    zero = np.zeros_like(positions)

    def force(at: np.ndarray) -> np.ndarray:
        return p.node_mass * acceleration(at, zero, 0.0, p).reshape(-1)

    residual = force(positions)
    for _ in range(200):
        stiffness = -_force_jacobian(positions[0], p)
        if np.max(np.abs(residual)) <= tolerance * scale:
            if np.linalg.eigvalsh(stiffness)[0] <= 0.0:
                raise RuntimeError(f"the equilibrium found for {p} is unstable")
            result = positions[0]
            result.flags.writeable = False
            return result
        shift = 0.0
        while np.linalg.eigvalsh(stiffness + shift * np.eye(2 * n))[0] <= 0.0:
            shift = max(2.0 * shift, 1e-6 * p.stiffness)
        delta = np.linalg.solve(stiffness + shift * np.eye(2 * n), residual).reshape(positions.shape)
        potential = energy(positions, zero, p)[0]
        t = 1.0
        while t > 1e-10:
            trial = positions + t * delta
            trial_residual = force(trial)
            lower = energy(trial, zero, p)[0] < potential
            if lower or np.max(np.abs(trial_residual)) < 0.5 * np.max(np.abs(residual)):
                break
            t *= 0.5
        positions, residual = trial, trial_residual
    raise RuntimeError(f"no static equilibrium found for {p}")


def mode_frequencies(params: ThreadParams) -> np.ndarray:
    """Angular frequencies (2N,) (rad/s, ascending) of the small oscillations about the rest shape: the square
    roots of the eigenvalues of the tangent stiffness over m. Without gravity (a straight taut thread) they are
    ``2 sqrt(T / (m L)) sin(k pi / (2 (N + 1)))`` across the thread, with the tension ``T = S (L - l)`` and the
    spring length L, and ``2 sqrt(S / m) sin(k pi / (2 (N + 1)))`` along it, k = 1..N."""
    stiffness = -_force_jacobian(static_equilibrium(params), params)
    return np.sqrt(np.linalg.eigvalsh(stiffness) / params.node_mass)


def _force_jacobian(positions: np.ndarray, params: ThreadParams) -> np.ndarray:
    """``dF / dp`` (2N, 2N) of the net spring and gravity forces on the interior nodes at ``positions`` (N, 2)."""
    p = params
    n = p.n_nodes
    d = np.diff(_chain(positions[None], p)[0], axis=0)
    length = np.sqrt(np.sum(d * d, axis=-1))
    ratio = p.natural_length / length
    unit = d / length[:, None]
    k = p.stiffness * (
        (1.0 - ratio)[:, None, None] * np.eye(2) + ratio[:, None, None] * unit[:, :, None] * unit[:, None]
    )
    jacobian = np.zeros((2 * n, 2 * n))
    for i in range(n):
        block = slice(2 * i, 2 * i + 2)
        jacobian[block, block] = -k[i] - k[i + 1]
        if i + 1 < n:
            after = slice(2 * i + 2, 2 * i + 4)
            jacobian[block, after] = k[i + 1]
            jacobian[after, block] = k[i + 1]
    return jacobian
