"""Thread-v0: damp a plucked elastic thread of mass points with bounded forces at a few actuated nodes."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces
from numba import njit

from vegym import rng
from vegym.envs.base import Info, KernelCall, State, Task, VegymEnv, VegymVectorEnv
from vegym.params import Params, invalid, param
from vegym.physics import thread
from vegym.physics.particle import STANDARD_GRAVITY
from vegym.physics.thread import ThreadParams

_PLUCK_STREAM = 1
MOST_SUBSTEPS = 1000
"""Most substeps per control step: a thread needing more (stiffness or drag far beyond a thread's, a step of
seconds) is refused, since it would step thousands of times slower than at the defaults (3)."""


@dataclass(frozen=True)
class ThreadEnvParams(Params):
    """Parameters of Thread-v0 (SI units; x along the span from the left end, y up)."""

    n_nodes: int = param(9, "N, interior mass points", low=1, high=64)
    node_mass: float = param(0.02, "m, mass of each point (kg)", low=0.0, low_open=True)
    stiffness: float = param(400.0, "S, spring stiffness (N/m)", low=0.0, low_open=True)
    natural_length: float = param(0.1, "l, natural length of each of the N + 1 springs (m)", low=0.0, low_open=True)
    span: float = param(1.1, "distance between the fixed ends (m)", low=0.0, low_open=True)
    gravity: float = param(STANDARD_GRAVITY, "gravitational acceleration magnitude (m/s^2)", low=0.0)
    drag: float = param(0.002, "c, viscous air drag on each point (N s/m)", low=0.0)
    n_actuators: int = param(3, "actuated nodes, spread evenly along the thread", low=1, high=64)
    max_force: float = param(0.5, "largest force of an actuator along x and along y (N)", low=0.0, low_open=True)
    dt: float = param(0.01, "control step (s); split into stable substeps", low=0.0, low_open=True, high=1.0)
    pluck_min: float = param(0.03, "smallest pluck height (m)", low=0.0, low_open=True)
    pluck_max: float = param(
        0.1, "largest pluck height (m); the unit of observed displacements", low=0.0, low_open=True
    )
    pluck_margin: float = param(
        0.2, "the pluck point is at least this fraction of the span from an end", low=0.0, high=0.5, high_open=True
    )
    velocity_scale: float = param(3.0, "node speed of a full unit of observation (m/s)", low=0.0, low_open=True)
    settle_fraction: float = param(
        0.01,
        "settled (success, the episode ends) when the excess energy is at most this fraction of the initial",
        low=0.0,
        low_open=True,
        high=1.0,
        high_open=True,
    )
    effort_weight: float = param(0.01, "cost per second of full force on every actuator (quadratic)", low=0.0)

    def validate(self) -> None:
        if self.n_actuators > self.n_nodes:
            raise self.between("n_actuators", high="n_nodes")
        if self.pluck_min > self.pluck_max:
            raise self.between("pluck_min", high="pluck_max")
        if thread.substeps(self.dt, self.physics) > MOST_SUBSTEPS:
            # substeps of at most half the stable step min(sqrt(m/S), m/c): that step at least 2 dt / MOST_SUBSTEPS
            m, rate = self.node_mass, 0.5 * MOST_SUBSTEPS / self.dt
            why = f"node_mass={m!r} and dt={self.dt!r}: at most {MOST_SUBSTEPS} stable substeps per step"
            if self.drag == 0.0 or math.sqrt(m / self.stiffness) < m / self.drag:  # the spring's bound binds
                raise self.between("stiffness", high=(f"{m * rate * rate:.6g}", m * rate * rate), reason=f" for {why}")
            raise self.between("drag", high=(f"{m * rate:.6g}", m * rate), reason=f" for {why}")
        try:
            rest = thread.static_equilibrium(self.physics)
        except RuntimeError as error:  # too slack (natural_length=300), or too soft or too long for the solver
            sizes = {  # the size (m) each gives the thread: the largest is named
                "natural_length": (self.n_nodes + 1) * self.natural_length,
                "span": self.span,
                "stiffness": self.node_mass * self.gravity * (self.n_nodes + 1) / self.stiffness,
            }
            name = max(sizes, key=sizes.__getitem__)
            raise invalid(name, getattr(self, name), f"where the rest-shape solver converges: {error}") from None
        (weakest, strongest), scale = self._weakest_plucks(rest, (self.pluck_min, self.pluck_max))
        least = 1e-14 * scale / self.settle_fraction  # 50 times the rounding of the energy, per settle_fraction
        if not weakest > least:  # rounding would decide when the episode settles, or the pluck adds no energy
            shape = self.named("n_nodes", "node_mass", "stiffness", "natural_length", "span", "gravity")
            told = f"a pluck of pluck_min adds {weakest:.3g} J to the thread of {shape}, of {scale:.3g} J"
            if strongest > least:  # about: the pluck's energy grows as its height squared
                allowed = f"about [{self.pluck_max * math.sqrt(least / strongest):.3g}, pluck_max] ({told}"
            else:
                allowed = f"empty for so soft a thread ({told}, one of pluck_max {strongest:.3g} J"
            allowed += f"; settle_fraction={self.settle_fraction!r} needs {least:.3g} J)"
            raise invalid("pluck_min", self.pluck_min, allowed)

    def _weakest_plucks(self, rest: np.ndarray, heights: tuple[float, ...]) -> tuple[list[float], float]:
        """The least energy (J) a pluck of each of ``heights`` (m) adds to the thread at rest (``rest``, (N, 2)), up
        or down at 65 points of the pluck's range, and the scale of the thread's energy (J: the sizes of its
        gravity and elastic parts)."""
        physics = self.physics
        resting = float(thread.energy(rest[None], np.zeros((1, *rest.shape)), physics)[0])
        at = self.span * np.linspace(self.pluck_margin, 1.0 - self.pluck_margin, 65)[:, None]
        weakest = []
        for height in heights:
            up_and_down = np.concatenate([np.full_like(at, height), np.full_like(at, -height)])
            shapes = plucked(rest, np.concatenate([at, at]), up_and_down, self.span)
            weakest.append(float(np.min(thread.energy(shapes, np.zeros_like(shapes), physics))) - resting)
        gravity = self.node_mass * self.gravity * float(np.sum(rest[:, 1]))
        return weakest, abs(gravity) + abs(resting - gravity)

    @property
    def physics(self) -> ThreadParams:
        """The thread physics parameters."""
        return self.subset(ThreadParams)

    @property
    def actuated(self) -> np.ndarray:
        """0-based indices of the actuated nodes: ``(k + 1)(N + 1)/(K + 1)`` (1-based) rounded toward the middle,
        so the set is mirror symmetric (indices 2, 4, 6 at the defaults: nodes 3, 5, 7 of 9) unless N is even and
        K odd, where the middle actuator has no middle node and takes the one on its right."""
        middle = 0.5 * (self.n_nodes + 1)
        at = (np.arange(self.n_actuators) + 1) * (self.n_nodes + 1) / (self.n_actuators + 1)
        return np.where(at > middle, np.ceil(at - 0.5), np.floor(at + 0.5)).astype(np.int64) - 1


def plucked(rest: np.ndarray, at: np.ndarray, height: np.ndarray, span: float) -> np.ndarray:
    """Positions (n, N, 2) (m) of the thread at rest (``rest``, (N, 2)) with a triangular pluck each: raised by
    ``height`` (n, 1) (m, negative down) at ``at`` (n, 1) (m along the span), in proportion to the distance from
    the nearer end."""
    x = rest[:, 0]
    # both sides are computed: a pluck at an end (pluck_margin=0, or subnormal) divides by 0 (or overflows) on the
    # side not taken
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        shape = np.where(x <= at, x / at, (span - x) / (span - at))
    positions = np.repeat(rest[None], len(at), axis=0)
    positions[..., 1] += height * shape
    return positions


STEP_CONSTANTS = ("max_force", "dt", "settle_fraction", "effort_weight", "pluck_max", "velocity_scale")
"""Parameters the kernels read, in the order of their constants array (SI units, see the fields)."""


_BLOCK = 64
"""Threads the step kernel advances at once in the column layout: its scratch (58 KiB at 9 nodes) stays in the
second-level cache with the rows it reads (the fastest of 32 to 256 here)."""


@njit(cache=True, nogil=True, error_model="numpy")
def _step_kernel(
    action: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    initial_excess: np.ndarray,
    excess: np.ndarray,
    actuated: np.ndarray,
    substeps: int,
    rest_energy: float,
    equilibrium: np.ndarray,
    c: np.ndarray,
    physics: tuple[float, float, float, float, float, float],
    forces: np.ndarray,
    energy: np.ndarray,
    fraction: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    success: np.ndarray,
    terminated: np.ndarray,
    obs: np.ndarray,
) -> None:
    """The whole step and the next observation, in place on the state arrays (``positions``, ``velocities``,
    ``excess``) and into the outputs (``forces`` to ``obs``): ``substeps`` semi-implicit Euler steps of the thread
    (``thread.advance``) under the actuator forces (N), then its energy (J); ``c`` holds the parameters named in
    ``STEP_CONSTANTS`` and ``physics`` is ``ThreadParams.constants``. The scratch buffers are this call's own, so
    calls on different rows may run at once.

    Written as passes over the batch for SIMD code: blocks of ``_BLOCK`` threads go into the column layout of
    ``thread.advance`` (the chain (N + 2, 2, block) of points with the fixed ends and the velocities (N, 2, block);
    the columns past the last thread repeat the block's first), are advanced and summed there, and go back; the
    reward and the observation are passes of their own."""
    max_force, dt, settle_fraction, effort_weight = c[0], c[1], c[2], c[3]
    n, n_nodes, n_actions = len(action), positions.shape[1], action.shape[1]
    flat_action, flat_forces = action.reshape(-1), forces.reshape(-1)
    for i in range(len(flat_action)):
        flat_forces[i] = max_force * flat_action[i]
    width = min(n, _BLOCK)
    chain, v, applied = np.empty((n_nodes + 2, 2, width)), np.empty((n_nodes, 2, width)), np.zeros((n_nodes, 2, width))
    chain[0], chain[n_nodes + 1, 0], chain[n_nodes + 1, 1] = 0.0, physics[5], 0.0  # the fixed ends
    scale, tensions = np.empty((n_nodes + 1, width)), np.empty((n_nodes + 1, 2, width))
    work, squares = np.empty((2 * n_nodes + 1, width)), np.empty((n_actions, width))
    block_energy, energy_term, effort = np.empty(width), np.empty(width), np.empty(width)
    p_rows, v_rows = positions.reshape(n, 2 * n_nodes), velocities.reshape(n, 2 * n_nodes)
    p_columns, v_columns = chain[1 : n_nodes + 1].reshape(2 * n_nodes, width), v.reshape(2 * n_nodes, width)
    h = dt / substeps
    for start in range(0, n, width):
        count = min(width, n - start)
        _to_columns(p_rows, start, count, p_columns)
        _to_columns(v_rows, start, count, v_columns)
        for k in range(n_actions):
            node, xy = actuated[k // 2], k % 2
            for i in range(count):
                applied[node, xy, i] = forces[start + i, k // 2, xy]
                squares[k, i] = action[start + i, k] * action[start + i, k]
            for i in range(count, width):
                applied[node, xy, i], squares[k, i] = applied[node, xy, 0], squares[k, 0]
        for _ in range(substeps):
            thread.advance(chain, v, applied, h, physics, scale, tensions)
        thread.energies(chain, v, physics, work, block_energy)
        thread.column_sums(squares, effort)
        for i in range(count):
            r = start + i
            energy[r] = block_energy[i]
            excess[r] = block_energy[i] - rest_energy
            fraction[r] = excess[r] / initial_excess[r]
            settled = fraction[r] <= settle_fraction
            energy_term[i] = -dt * fraction[r]
            effort[i] = -effort_weight * dt * (effort[i] / n_actions)  # the sum of squares becomes the term
            reward[r] = energy_term[i] + effort[i]
            success[r], terminated[r] = settled, settled
        for i in range(count):  # a pass of its own: strided stores would keep the reward's pass from SIMD code
            terms[start + i, 0], terms[start + i, 1] = energy_term[i], effort[i]
        for i in range(count):  # back to the rows
            for k in range(2 * n_nodes):
                p_rows[start + i, k], v_rows[start + i, k] = p_columns[k, i], v_columns[k, i]
    _observe_kernel(positions, velocities, excess, initial_excess, equilibrium, c, obs)


@njit(cache=True, nogil=True, inline="always")
def _to_columns(rows: np.ndarray, start: int, count: int, columns: np.ndarray) -> None:
    """Rows ``start`` to ``start + count`` of ``rows`` (n, m) transposed into the first ``count`` columns of
    ``columns`` (m, width), in tiles of 16 rows (vector loads along the rows' stride); the columns past ``count``
    repeat the first."""
    m, width = columns.shape
    tiled = count - count % 16
    for tile in range(0, tiled, 16):
        for k in range(m):
            for i in range(tile, tile + 16):
                columns[k, i] = rows[start + i, k]
    for k in range(m):
        for i in range(tiled, count):
            columns[k, i] = rows[start + i, k]
        for i in range(count, width):
            columns[k, i] = columns[k, 0]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _observe_kernel(
    positions: np.ndarray,
    velocities: np.ndarray,
    excess: np.ndarray,
    initial_excess: np.ndarray,
    equilibrium: np.ndarray,
    c: np.ndarray,
    obs: np.ndarray,
) -> None:
    """Observations (n, 4 N + 1) into ``obs``; ``c`` holds the parameters named in ``STEP_CONSTANTS``. Loops over
    each row's coordinates innermost, for SIMD code, scaled by reciprocals (divisions are slower)."""
    per_pluck, per_speed = 1.0 / c[4], 1.0 / c[5]
    n, size = len(excess), 2 * positions.shape[1]
    p, v, rest = positions.reshape(n, size), velocities.reshape(n, size), equilibrium.reshape(-1)
    for i in range(n):  # one loop per part of the row: a loop writing two parts of one array compiles to slower code
        for k in range(size):
            obs[i, k] = min(max((p[i, k] - rest[k]) * per_pluck, -1.0), 1.0)
        for k in range(size):
            obs[i, size + k] = min(max(v[i, k] * per_speed, -1.0), 1.0)
    for i in range(n):  # f / (1 + f) of the fraction f = E / E0 left, as E / (E0 + E): 1/2 at the release, bounded
        left = max(excess[i], 0.0)
        obs[i, 2 * size] = left / (initial_excess[i] + left)


class ThreadTask(Task[ThreadEnvParams]):
    """Batched logic of Thread-v0 (see :class:`ThreadEnv`)."""

    params_cls = ThreadEnvParams
    renderer = "vegym.render.thread:ThreadRenderer"

    def __init__(self, params: ThreadEnvParams) -> None:
        super().__init__(params)
        self.physics = params.physics
        self.actuated = params.actuated
        self.substeps = thread.substeps(params.dt, self.physics)
        self.equilibrium = thread.static_equilibrium(self.physics)
        self.rest_energy = float(
            thread.energy(self.equilibrium[None], np.zeros((1, params.n_nodes, 2)), self.physics)[0]
        )
        n_obs = 4 * params.n_nodes + 1
        low = np.full(n_obs, -1.0, np.float32)
        low[-1] = 0.0
        self.observation_space = spaces.Box(low, np.ones(n_obs, np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (2 * params.n_actuators,), np.float32)
        self._constants = np.array([getattr(params, name) for name in STEP_CONSTANTS], dtype=np.float64)
        self._physics_constants = self.physics.constants

    @property
    def control_rate(self) -> float:
        return 1.0 / self.params.dt

    def initial_state(self, keys: np.ndarray) -> State:
        p = self.params
        u = rng.uniform(keys, _PLUCK_STREAM, 3)
        at = p.span * (p.pluck_margin + (1.0 - 2.0 * p.pluck_margin) * u[:, :1])
        height = (p.pluck_min + (p.pluck_max - p.pluck_min) * u[:, 1:2]) * np.where(u[:, 2:] < 0.5, 1.0, -1.0)
        positions = plucked(self.equilibrium, at, height, p.span)
        velocities = np.zeros_like(positions)
        excess = thread.energy(positions, velocities, self.physics) - self.rest_energy
        return {"positions": positions, "velocities": velocities, "initial_excess": excess, "excess": excess.copy()}

    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        return {
            "forces": ((self.params.n_actuators, 2), np.float64),
            "energy": ((), np.float64),
            "fraction": ((), np.float64),
            "terms": ((2,), np.float64),
            "success": ((), np.bool_),
        }

    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        return _step_kernel, (
            action, state["positions"], state["velocities"], state["initial_excess"], state["excess"],
            self.actuated, self.substeps, self.rest_energy, self.equilibrium, self._constants,
            self._physics_constants, out["forces"], out["energy"], out["fraction"], out["terms"], out["reward"],
            out["success"], out["terminated"], out["obs"],
        )  # fmt: skip

    def info(self, state: State, out: State) -> Info:
        terms = out["terms"]
        return {
            "positions": state["positions"],
            "velocities": state["velocities"],
            "forces": out["forces"],
            "energy": out["energy"],
            "excess_energy": state["excess"],
            "energy_fraction": out["fraction"],
            "dt": self.params.dt,
            "reward_terms": {"energy": terms[:, 0], "effort": terms[:, 1]},
            "is_success": out["success"],
        }

    def observe(self, state: State, obs: np.ndarray) -> None:
        _observe_kernel(
            state["positions"], state["velocities"], state["excess"], state["initial_excess"], self.equilibrium,
            self._constants, obs,
        )  # fmt: skip


class ThreadEnv(VegymEnv[ThreadEnvParams]):
    """Vibration damping: bring a plucked elastic thread to rest with a few force actuators.

    ## Description
    The elastic thread of the chapter (8.6.3, 8.99-8.112) in the vector form of PHYSICS.md section 9: N point
    masses m joined by N + 1 springs (stiffness S, natural length l) between two fixed ends ``span`` apart, under
    gravity and a light air drag, integrated with semi-implicit Euler in as many substeps as keep them within half
    the stability bound, ``h <= min(sqrt(m/S), m/c) / 2`` (3 per step at the defaults, at most ``MOST_SUBSTEPS``,
    1000). At the defaults the thread is
    pretensioned (10 springs of 0.1 m over 1.1 m) and sags 6 cm at rest; its slowest mode rings at 2.4 Hz and,
    with the air drag alone, the energy takes 46 s to fall to 1%. Each episode plucks it: one point is pulled up
    or down and the thread released at rest from the triangle it makes. Actuators at ``n_actuators`` nodes push
    with bounded forces and must take the energy out quickly.

    ## Action Space
    ``Box(-1, 1, (2 K,), float32)`` for K = ``n_actuators``: the force ``(u_x, u_y) = max_force (a_2k, a_2k+1)``
    (N) on actuated node k (nodes 3, 5 and 7 of 9 counted from 1 at the defaults; their 0-based indices, 2, 4
    and 6, are the ``actuated`` property of the parameters), held over the step.

    ## Observation Space
    ``Box(low, 1, (4 N + 1,), float32)``: each node's displacement from the rest shape, ``(x, y)`` over
    ``pluck_max``, then each node's velocity over ``velocity_scale``, both clipped to [-1, 1] (nodes from the
    left); last, the fraction f of the episode's initial excess energy left, as ``f / (1 + f)`` in [0, 1): 0.5 at
    the release, 0.0099 at the 1% that ends the episode, and still telling apart the many times the initial energy
    that random forces pump in (``low`` is -1 except for this entry, 0).

    ## Rewards
    ``energy``: ``-dt E_x / E_x0``, where the excess energy ``E_x`` is the mechanical energy (kinetic, gravity,
    elastic) above that of the thread at rest and ``E_x0`` its value at the release, so the return is minus the
    time integral of the energy fraction left; ``effort``: ``-effort_weight dt mean(a^2)``.

    ## Starting State
    The rest shape (found once per parameter set by Newton's method) plus a triangular pluck: at a point uniform
    in ``[pluck_margin, 1 - pluck_margin]`` of the span, with a height uniform in ``[pluck_min, pluck_max]``
    (3 to 10 cm), up or down with equal chances; all nodes at rest. Drawn from the episode seed.

    ## Episode End
    Terminated when the excess energy is at most ``settle_fraction`` (1%) of the initial one
    (``info["is_success"]``); truncated after ``max_episode_steps`` (500 steps of 0.01 s when registered). Over
    seeds 0-49 (``tests/test_thread.py``) velocity feedback settles every pluck, in 0.59 s on average and 0.99 s
    at most (mean return -0.115); without forces the thread rings on (-3.95) and random forces keep it shaking
    (-35.4).

    ## Arguments
    ``gymnasium.make("vegym/Thread-v0", render_mode=None, **params)`` with the fields of
    :class:`ThreadEnvParams`. ``info`` per step (SI, x along the span, y up): ``positions`` and ``velocities``
    (N, 2) of the nodes, ``forces`` (K, 2) applied, ``energy`` (J), ``excess_energy`` (J), ``energy_fraction``
    (excess over the initial excess), ``dt``, ``reward_terms``, ``is_success``. Reference controller: collocated
    velocity feedback ``u_k = -c_fb v_k`` at the actuated nodes, saturated (``agents.analytic``).

    ## Version History
    * v0: initial version.
    """

    task_cls = ThreadTask


class ThreadVectorEnv(VegymVectorEnv[ThreadEnvParams]):
    """Native vector twin of :class:`ThreadEnv` (same task code, NEXT_STEP autoreset)."""

    task_cls = ThreadTask
