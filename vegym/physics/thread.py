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
never modify their inputs. The compiled functions behind them (:func:`advance`, :func:`accelerate`,
:func:`energies`) take a batch in the column layout (N, 2, n) (node, xy, batch), the positions as the chain
(N + 2, 2, n) of all points with the fixed ends, and are written as passes over the batch for SIMD code.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vegym.params import Params, param
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

    def validate(self) -> None:
        if self.gravity == 0.0 and not self.natural_length < self.spacing:
            reason = " without gravity, where a slack thread has no rest"
            spacing = (f"span / (n_nodes + 1) = {self.spacing:g}", self.spacing)
            raise self.between("natural_length", high=spacing, high_open=True, reason=reason)

    @property
    def spacing(self) -> float:
        """``span / (N + 1)`` (m): the length of each spring in the straight thread between the ends."""
        return self.span / (self.n_nodes + 1)

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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _tensions(
    chain: np.ndarray, c: tuple[float, float, float, float, float, float], scale: np.ndarray, out: np.ndarray
) -> None:
    """Tension vectors ``f_j = S (L_j - l) d_j / L_j`` (N) of the N + 1 springs, written into ``out`` (N + 1, 2, n)
    from the ``chain`` (N + 2, 2, n) of all points; ``scale`` (N + 1, n) receives ``S (L_j - l) / L_j`` (N/m).
    Each pass writes one row of each array (a pass writing two rows of one array compiles to slower code)."""
    stiffness, natural_length = c[0], c[1]
    for j in range(chain.shape[0] - 1):
        for i in range(chain.shape[2]):
            dx, dy = chain[j + 1, 0, i] - chain[j, 0, i], chain[j + 1, 1, i] - chain[j, 1, i]
            length = math.sqrt(dx * dx + dy * dy)
            scale[j, i] = stiffness * (length - natural_length) / length
        for k in range(2):
            for i in range(chain.shape[2]):
                out[j, k, i] = scale[j, i] * (chain[j + 1, k, i] - chain[j, k, i])


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _node_acceleration(
    j: int,
    k: int,
    i: int,
    tensions: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    c: tuple[float, float, float, float, float, float],
) -> float:
    """Acceleration (m/s^2) along axis k of thread i's node ``p_{j+1}`` (row j of ``velocities`` and ``forces``),
    between springs j and j + 1 of ``tensions``: ``(f_{j+1} - f_j - c v + u) / m - g y_hat``."""
    _, _, mass, gravity, drag, _ = c
    weight = gravity if k == 1 else 0.0  # subtracting 0.0 changes no bit
    return (tensions[j + 1, k, i] - tensions[j, k, i] - drag * velocities[j, k, i] + forces[j, k, i]) / mass - weight


@njit(cache=True, nogil=True, error_model="numpy")
def accelerate(
    chain: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    c: tuple[float, float, float, float, float, float],
    scale: np.ndarray,
    tensions: np.ndarray,
    out: np.ndarray,
) -> None:
    """Accelerations (N, 2, n) of a batch of threads (m/s^2), written into ``out``: springs, gravity, drag and the
    applied ``forces`` (N, 2, n) (N); ``c = ThreadParams.constants``; ``chain`` (N + 2, 2, n) holds all points,
    the fixed ends included, and ``velocities`` (N, 2, n) those of the interior nodes (the column layout);
    ``scale`` (N + 1, n) and ``tensions`` (N + 1, 2, n) are scratch (see :func:`_tensions`). Passes over the
    batch, for SIMD code."""
    _tensions(chain, c, scale, tensions)
    for j in range(velocities.shape[0]):
        for k in range(2):
            for i in range(velocities.shape[2]):
                out[j, k, i] = _node_acceleration(j, k, i, tensions, velocities, forces, c)


@njit(cache=True, nogil=True, error_model="numpy")
def advance(
    chain: np.ndarray,
    velocities: np.ndarray,
    forces: np.ndarray,
    dt: float,
    c: tuple[float, float, float, float, float, float],
    scale: np.ndarray,
    tensions: np.ndarray,
) -> None:
    """One semi-implicit Euler step of ``dt`` seconds of a batch of threads, in place on the interior nodes of
    ``chain`` and on ``velocities``, as :func:`accelerate` and then ``v <- v + dt a``, ``p <- p + dt v`` (arrays
    as there). Passes over the batch, for SIMD code: the model's one compiled form, behind :func:`step` and
    Thread-v0's kernel."""
    _tensions(chain, c, scale, tensions)
    for j in range(velocities.shape[0]):
        for k in range(2):
            for i in range(velocities.shape[2]):
                v = velocities[j, k, i] + dt * _node_acceleration(j, k, i, tensions, velocities, forces, c)
                velocities[j, k, i] = v
                chain[j + 1, k, i] = chain[j + 1, k, i] + dt * v


@njit(cache=True, nogil=True)
def column_sums(values: np.ndarray, out: np.ndarray) -> None:
    """Each column of ``values`` (m, n) summed into ``out`` (n,) as ``columns.pairwise_sum`` (numpy's ``np.sum``
    of a 1-d array) sums it, bit for bit, in passes over the columns for SIMD code; ``values`` is overwritten (its
    first eight rows accumulate). ``out`` may be a row of a C-contiguous ``values`` beyond the first ``m``."""
    m, n = values.shape
    if m < 8:
        for i in range(n):
            out[i] = 0.0
        for k in range(m):
            for i in range(n):
                out[i] += values[k, i]
        return
    if m > 128:
        half = m // 2
        half -= half % 8
        left = np.empty(n)
        column_sums(values[:half], left)
        column_sums(values[half:], out)
        for i in range(n):
            out[i] = left[i] + out[i]
        return
    for k in range(8, m - m % 8, 8):
        for t in range(8):
            for i in range(n):
                values[t, i] = values[t, i] + values[k + t, i]
    for i in range(n):
        out[i] = ((values[0, i] + values[1, i]) + (values[2, i] + values[3, i])) + (
            (values[4, i] + values[5, i]) + (values[6, i] + values[7, i])
        )
    for k in range(m - m % 8, m):
        for i in range(n):
            out[i] += values[k, i]


@njit(cache=True, nogil=True)
def energies(
    chain: np.ndarray,
    velocities: np.ndarray,
    c: tuple[float, float, float, float, float, float],
    scratch: np.ndarray,
    out: np.ndarray,
) -> None:
    """:func:`energy` of a batch of threads (J) written into ``out`` (n,), each sum in numpy's order
    (:func:`column_sums`); ``chain`` (N + 2, 2, n) and ``velocities`` (N, 2, n) as in :func:`accelerate`
    (C-contiguous) and ``scratch`` a C-contiguous (2 N + 1, n)."""
    stiffness, natural_length, mass, gravity = c[0], c[1], c[2], c[3]
    n_nodes, batch = velocities.shape[0], velocities.shape[2]
    v, total = velocities.reshape(2 * n_nodes, batch), scratch[2 * n_nodes]
    for k in range(2 * n_nodes):  # the squares in the order of the nodes' (x, y) pairs
        for i in range(batch):
            scratch[k, i] = v[k, i] * v[k, i]
    column_sums(scratch[: 2 * n_nodes], total)
    for i in range(batch):
        out[i] = 0.5 * mass * total[i]
    for j in range(n_nodes):
        for i in range(batch):
            scratch[j, i] = chain[j + 1, 1, i]
    column_sums(scratch[:n_nodes], total)
    for i in range(batch):
        out[i] = out[i] + mass * gravity * total[i]
    for j in range(n_nodes + 1):
        for i in range(batch):
            dx, dy = chain[j + 1, 0, i] - chain[j, 0, i], chain[j + 1, 1, i] - chain[j, 1, i]
            stretch = math.sqrt(dx * dx + dy * dy) - natural_length
            scratch[j, i] = stretch * stretch
    column_sums(scratch[: n_nodes + 1], total)
    for i in range(batch):
        out[i] = out[i] + 0.5 * stiffness * total[i]


def _check_positions(positions: np.ndarray | list, params: ThreadParams) -> None:
    """``ValueError`` unless ``positions`` is a batch (n, N, 2) of the parameters' N interior nodes."""
    shape = np.shape(positions)
    if len(shape) != 3 or shape[1:] != (params.n_nodes, 2):
        hint = "; add the batch axis, positions[None]" if shape == (params.n_nodes, 2) else ""
        raise ValueError(
            f"positions must have shape (n, {params.n_nodes}, 2) (n_nodes={params.n_nodes}), got {shape}{hint}"
        )


def _columns(*arrays: np.ndarray | float) -> list[np.ndarray]:
    """``arrays`` broadcast to one batch shape (n, N, 2), as new C-contiguous float64 arrays in the column layout
    (N, 2, n) of the compiled functions."""
    shape = np.broadcast_shapes(*(np.shape(a) for a in arrays))
    return [
        np.array(np.broadcast_to(np.asarray(a, dtype=np.float64), shape).transpose(1, 2, 0), order="C") for a in arrays
    ]


def _chain_columns(positions: np.ndarray, params: ThreadParams) -> np.ndarray:
    """A batch of positions (N, 2, n) in the column layout, with the fixed ends added: (N + 2, 2, n)."""
    chain = np.empty((len(positions) + 2, 2, positions.shape[2]))
    chain[0], chain[1:-1], chain[-1] = 0.0, positions, params.ends[1][:, None]
    return chain


def _rows(columns: np.ndarray) -> np.ndarray:
    """An array in the column layout (N, 2, n) as a new batch (n, N, 2)."""
    return np.ascontiguousarray(columns.transpose(2, 0, 1))


def acceleration(
    positions: np.ndarray, velocities: np.ndarray, forces: np.ndarray | float, params: ThreadParams
) -> np.ndarray:
    """Node accelerations (n, N, 2) (m/s^2): springs, gravity, drag and the applied forces ``u`` (N)."""
    _check_positions(positions, params)
    positions, velocities, forces = _columns(positions, velocities, forces)
    n_nodes, _, n = positions.shape
    out = np.empty_like(positions)
    scale, tensions = np.empty((n_nodes + 1, n)), np.empty((n_nodes + 1, 2, n))
    accelerate(_chain_columns(positions, params), velocities, forces, params.constants, scale, tensions, out)
    return _rows(out)


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
    _check_positions(positions, params)
    positions, velocities, forces = _columns(positions, velocities, forces)
    n_nodes, _, n = positions.shape
    chain, scale, tensions = (
        _chain_columns(positions, params),
        np.empty((n_nodes + 1, n)),
        np.empty((n_nodes + 1, 2, n)),
    )
    advance(chain, velocities, forces, float(dt), params.constants, scale, tensions)
    return _rows(chain[1:-1]), _rows(velocities)


def substeps(dt: float, params: ThreadParams, margin: float = 0.5) -> int:
    """Number of equal substeps that splits ``dt`` into steps of at most ``margin`` times the stable step."""
    stable = margin * params.stable_step  # 0 where sqrt(m / S) or m / c underflows (node_mass=5e-324, say)
    count = dt / stable if stable > 0.0 else math.inf
    return max(1, math.ceil(count)) if count < 2.0**63 else 2**63 - 1  # the ceil of inf raised OverflowError


def energy(positions: np.ndarray, velocities: np.ndarray, params: ThreadParams) -> np.ndarray:
    """Mechanical energy (n,) (J): kinetic ``sum m |v|^2 / 2`` + gravity ``sum m g y`` + elastic
    ``sum S (L - l)^2 / 2``."""
    _check_positions(positions, params)
    positions, velocities = _columns(positions, velocities)
    out = np.empty(positions.shape[2])
    scratch = np.empty((2 * len(positions) + 1, len(out)))
    energies(_chain_columns(positions, params), velocities, params.constants, scratch, out)
    return out


@functools.lru_cache(maxsize=32)
@np.errstate(over="ignore", invalid="ignore", divide="ignore")  # a far too slack thread overflows: refused, no warning
def static_equilibrium(params: ThreadParams, tolerance: float = 1e-12) -> np.ndarray:
    """The thread at rest (N, 2) under gravity (m): the minimum of the potential energy, by damped Newton steps.

    It starts from a parabola of the arc length ``(N + 1) l`` (at least 1% of the span deep). Each step solves
    ``(K + mu I) dp = F`` with the tangent stiffness K (``S [(1 - l/L) I + (l/L) d d^T / L^2]`` per spring), ``mu``
    raised until the matrix is positive definite, and halves dp until the potential energy drops or the residual
    force halves; it stops when the largest residual force is below ``tolerance`` times ``m g + S max(l, span /
    (N + 1))`` (the weight and the tension's scale: a taut thread's tension, ``S (span / (N + 1) - l)``, can be
    far above ``S l``). Raises ``RuntimeError`` without convergence or at an unstable equilibrium. The result is
    read-only.
    """
    p = params
    n = p.n_nodes
    x = p.span * np.arange(1, n + 1) / (n + 1)
    slack = max((n + 1) * p.natural_length - p.span, 0.0)
    depth = max(math.sqrt(3.0 * p.span * slack / 8.0), 0.01 * p.span)
    positions = np.stack([x, -4.0 * depth * x * (p.span - x) / (p.span * p.span)], axis=-1)[None]  # not **: no error
    scale = p.node_mass * p.gravity + p.stiffness * max(p.natural_length, p.spacing)
    zero = np.zeros_like(positions)

    def force(at: np.ndarray) -> np.ndarray:
        return p.node_mass * acceleration(at, zero, 0.0, p).reshape(-1)

    residual = force(positions)
    for _ in range(200):
        if not np.all(np.isfinite(residual)):  # a thread so slack that its sag overflows (stiffness=1e-300, say)
            raise RuntimeError(f"no static equilibrium found for {p}: the forces overflow")
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
