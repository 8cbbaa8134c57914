"""The one dynamics implementation behind every vegym env, and its single and native-vector front ends.

A :class:`Task` is the whole env logic over *batches* of episodes, a state being a dict of numpy arrays with a
leading batch axis: ``initial_state(keys)`` draws fresh episodes, ``step(state, action, out)`` advances every
episode in place and writes the step's results into the arrays of ``outputs(n)``, ``observe(state, obs)``
writes the observations. The steps run as numba kernels that loop over the episodes, so the same code serves
:class:`VegymEnv` (a batch of one, its arrays reused from step to step) and :class:`VegymVectorEnv`
(``num_envs`` episodes, Gymnasium's NEXT_STEP autoreset, large batches split over the CPU cores). All randomness
is counter-based on per-episode keys (:mod:`vegym.rng`), so sub-env ``i`` of a vector env reset with ``seed=s``
follows exactly the single env reset with ``seed=s + i``, step for step, whatever the other sub-envs do.
"""

from __future__ import annotations

import abc
import collections
import contextlib
import dataclasses
import functools
import importlib
import itertools
import numbers
import os
import sys
import types
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any, ClassVar, Generic, TypeVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit

from vegym import rng
from vegym.envs.kernel_call import bind_kernel
from vegym.envs.kernel_split import FLAGGED, SPLIT_MIN_ROWS, SplitKernel, flagged_rows
from vegym.params import Params, with_arguments

P = TypeVar("P", bound=Params)
State = dict[str, np.ndarray]
Info = dict[str, Any]
KernelCall = tuple[Callable[..., Any], tuple[Any, ...]]
"""A kernel and its arguments: ``kernel(*args)`` does the work."""

ACTION_TOLERANCE = 1e-6
"""Actions may exceed [-1, 1] by this much (float32 round-off) and are then clipped; more is an error."""
PARALLEL_MIN_ENVS = 32768
"""Vector envs with at least this many sub-envs start, observe and restart in chunks of at least half this many
rows, at most one per CPU core, on a thread pool (the kernels release the GIL); smaller batches run in the calling
thread, where a pool's threads would cost more than they save (handing a chunk to a sleeping thread took about
130 us on the 2-core VM this was measured on, a whole 8,192-env step of the SIMD kernels 0.3-0.6 ms). Steps, the
hot path, split from ``kernel_split.SPLIT_MIN_ROWS`` rows per core instead, on helper threads that spin between
steps."""
SPLIT_RESTART_ROWS = 1024
"""Restarts of at least this many rows after a split step are split too, between the calling thread and the step's
helpers, which are still spinning: where the step's chunks do not restart their own rows (a task with episode
constants, say; none of the registered envs)."""


class Task(abc.ABC, Generic[P]):
    """Batched task logic over frozen parameters: observation, action mapping, reward, termination.

    Subclasses set ``params_cls``, build ``observation_space`` and ``action_space`` (single-env spaces) in
    ``__init__``, and implement the methods below. ``state`` dicts always carry ``key`` (uint64 episode keys)
    and ``step`` (steps taken in the episode), maintained by the front ends. ``step_call``, ``observe``,
    ``start`` and ``restart_call`` must work on any row slice of the state (the vector env hands them
    chunks of its arrays, concurrently).
    """

    params_cls: ClassVar[type[Params]]
    renderer: ClassVar[str] = ""
    """``"module:Class"`` of the renderer, imported only when a render mode is asked for."""
    episode_constants: ClassVar[tuple[str, ...]] = ()
    """State arrays that the info returns and that are fixed for an episode: only :meth:`start` and :meth:`restart`
    write them, every element of a row they start. The vector env's infos return read-only views of them, not
    copies, and its state gets new ones before episodes start."""

    planned_length_param: ClassVar[str | None] = None
    """The parameter holding the episode length the task plans for (a demand schedule's end, a charge for the
    steps left), the registered ``max_episode_steps``; None if the task plans for no length."""

    observation_space: spaces.Box
    action_space: spaces.Box

    def __init__(self, params: P) -> None:
        self.params = params

    @property
    def planned_steps(self) -> int | None:
        """The episode length (steps) the task plans for (:attr:`planned_length_param`), or None."""
        return None if self.planned_length_param is None else getattr(self.params, self.planned_length_param)

    @property
    def plan_changed(self) -> bool:
        """Whether the planned episode length differs from its default, the registered time limit."""
        name = self.planned_length_param
        if name is None:
            return False
        return self.planned_steps != next(f.default for f in dataclasses.fields(self.params) if f.name == name)

    def warn_unplanned_length(self, what: str, hint: str = "") -> None:
        """Warn that episodes run past the planned length (``what`` says how; ``hint``, advice appended): they
        outlive the task's demand schedule or its charge for the steps left, and only its parameter
        changes the plan. A shorter time limit is not warned of here: it cuts episodes, as truncation does (before
        the schedule's final hold, with charges that still count the planned steps); the vector env warns of one
        that cuts a plan changed alone."""
        name = self.planned_length_param
        gym.logger.warn(
            f"{what}, but the task plans episodes of {name}={self.planned_steps} steps (its demand schedule or its "
            f"charge for the steps left){hint}; to change the episode length pass both {name}=N and "
            "max_episode_steps=N"
        )

    @property
    @abc.abstractmethod
    def control_rate(self) -> float:
        """Steps per simulated second (the render frame rate)."""

    @abc.abstractmethod
    def initial_state(self, keys: np.ndarray) -> State:
        """Fresh episode states for the episode keys ``keys`` (n,), drawing randomness from them only. Arrays may
        share memory; whoever steps the state passes it through :func:`owned` first (the front ends do)."""

    def start(self, state: State, keys: np.ndarray, rows: np.ndarray) -> None:
        """Start the episodes of ``keys`` in the rows ``rows`` (int indices) of ``state``, in place (``key`` and
        ``step`` are the front end's). Tasks that restart often (short episodes) override it with a kernel."""
        for name, value in self.initial_state(keys).items():
            state[name][rows] = value

    def restart(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        """Start the next episode of the episodes ``rows`` (distinct int indices) of ``state``, in place: their
        ``key`` advanced to :func:`rng.next_key` of itself, the episodes started and observed into those rows of
        ``obs`` (their ``step`` is the front end's, zero already). A single env's reset without a seed and the
        vector env's autoreset run it: by :meth:`restart_call`'s kernel where there is one."""
        call = self.restart_call(state, rows, obs)
        if call is None:
            self.restart_by_parts(state, rows, obs)
        else:
            kernel, args = call
            kernel(*args)

    def restart_by_parts(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        """:meth:`restart` by numpy gathers and :meth:`start`: the reference that restart kernels are tested
        against."""
        keys = rng.next_key(state["key"][rows])
        self.start(state, keys, rows)
        state["key"][rows] = keys
        self.observe_rows(state, rows, obs)

    def restart_call(self, state: State, rows: np.ndarray, obs: np.ndarray) -> KernelCall | None:
        """The one kernel call that does :meth:`restart`'s work for these arguments, or None (then
        :meth:`restart_by_parts` does it). Tasks whose episodes restart often (short episodes) return one; the
        single env binds it once, as :meth:`step_call`'s. A large vector env runs it in its step's threads at once
        (:meth:`VegymVectorEnv._restart_call_to_split`). For a task without episode constants, each chunk of a split
        step runs it on its own rows after its step, given the chunk's rows of the state, of ``obs`` and of the keys,
        and ``rows`` within the chunk (the call is made with the bool autoreset flags in place of ``rows``:
        :meth:`VegymVectorEnv._split_task`). Otherwise the split runs it after the step: for fewer rows than the
        batch, over parts of ``rows`` (``SPLIT_RESTART_ROWS`` or more), passing the other arguments whole, so the
        kernel must read and write the rows ``rows`` of the state and of ``obs`` only (and the task's constants), and
        one that observes every row returns None there (Projectile's); for every row, over chunks of rows as
        :meth:`step_call`'s."""
        return None

    @abc.abstractmethod
    def output_shapes(self) -> dict[str, tuple[tuple[int, ...], type]]:
        """Per-episode shape and dtype of every array ``step`` writes besides ``reward`` and ``terminated``."""

    def outputs(self, n: int) -> State:
        """Uninitialised output arrays of one step of ``n`` episodes: ``reward`` (float64), ``terminated`` (bool),
        ``obs`` (the observations after the step, float32) and those of :meth:`output_shapes`, batch axis first."""
        out = {
            "reward": np.empty(n),
            "terminated": np.empty(n, np.bool_),
            "obs": np.empty((n, *self.observation_space.shape), np.float32),
        }
        for name, (shape, dtype) in self.output_shapes().items():
            out[name] = np.empty((n, *shape), dtype)
        return out

    def step(self, state: State, action: np.ndarray, out: State) -> None:
        """Advance every episode of ``state`` in place by one step with actions (n, action_dim) in [-1, 1],
        writing the results and the next observations into the arrays of ``out`` (from :meth:`outputs`): the
        kernel of :meth:`step_call`."""
        kernel, args = self.step_call(state, action, out)
        kernel(*args)

    @abc.abstractmethod
    def step_call(self, state: State, action: np.ndarray, out: State) -> KernelCall:
        """The kernel call that does all of :meth:`step`'s work on these arrays, a demand schedule's changes
        too (``out["obs"]`` shows the state after all of the step). The single env binds it once to its own arrays
        (:func:`bind_kernel`), so its arguments must be those arrays (``state``'s, ``action``, ``out``'s, the
        task's own) and constants, never values computed from the state. A large vector env runs it over chunks of
        rows at once (:class:`kernel_split.SplitKernel`), splitting the arrays of ``state``, ``out`` and ``action``
        passed as they are (not views) and passing the others whole: each row's results must depend on its own rows
        and the task's constants only, which the kernel must not write."""

    @abc.abstractmethod
    def info(self, state: State, out: State) -> Info:
        """The step's ``info``: views of ``state`` (after the step) and of ``out``, or Python scalars for
        constants; never arrays computed from them, since the single env builds it once and reads it each step."""

    @abc.abstractmethod
    def observe(self, state: State, obs: np.ndarray) -> None:
        """Write the observations (n, obs_dim) into ``obs`` (float32), inside ``observation_space``."""

    def observe_rows(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        """Write the observations of the episodes ``rows`` (int indices) into those rows of ``obs`` (n, obs_dim).
        Tasks may override it with a kernel over the rows; this one observes every episode when ``rows`` are an
        eighth or more of them (cheaper than gathering their states), else the gathered rows."""
        if 8 * len(rows) >= len(obs):
            obs[rows] = self.observation(state)[rows]
        else:
            obs[rows] = self.observation(rows_of(state, rows))

    def transition(self, state: State, action: np.ndarray) -> tuple[State, State, Info]:
        """One step as a pure function, for tests and analysis (the envs step in place): a copy of ``state``
        advanced by ``action`` (n, action_dim) with its ``step`` counted (if it has one), the step's outputs
        (``reward``, ``terminated``, ``obs``, ...) and its info; ``state`` is left as it was."""
        after = owned({name: value.copy() for name, value in state.items()})
        out = self.outputs(len(action))
        self.step(after, np.asarray(action, dtype=np.float64), out)
        if "step" in after:
            after["step"] += 1
        return after, out, self.info(after, out)

    def observation(self, state: State) -> np.ndarray:
        """The observations (n, obs_dim) of ``state``, in a new array."""
        obs = np.empty((len(next(iter(state.values()))), *self.observation_space.shape), np.float32)
        self.observe(state, obs)
        return obs


@njit(cache=True, nogil=True, error_model="numpy")
def _check_actions(source: np.ndarray, tolerance: float) -> int:
    """0 where every number of ``source`` (C-contiguous) lies within ``tolerance`` of [-1, 1], else 1 for NaN/inf or
    2 for values further out; read only. The first pass is branch-free, so that it runs as SIMD code; only a bad
    action is looked at again."""
    values, limit, bad = source.reshape(-1), 1.0 + tolerance, False
    for j in range(values.size):
        bad |= not abs(np.float64(values[j])) <= limit  # also NaN
    if not bad:
        return 0
    for j in range(values.size):
        if not np.isfinite(np.float64(values[j])):
            return 1
    return 2


@njit(cache=True, nogil=True, inline="always")
def _clip_into(source: np.ndarray, target: np.ndarray) -> None:
    """``target`` (float64) = ``source`` (C-contiguous, as many numbers) clipped to [-1, 1], in one SIMD pass: the
    values within the tolerance of :func:`_check_actions` outside it are clipped so."""
    values, flat = source.reshape(-1), target.reshape(-1)
    for j in range(values.size):
        flat[j] = min(max(np.float64(values[j]), -1.0), 1.0)


@njit(cache=True, nogil=True)
def _clip_actions(load: np.ndarray, source: np.ndarray, target: np.ndarray) -> None:
    """:func:`_clip_into` where ``load[0]``: a split step's first call, which converts the checked actions of its
    chunk's rows, or none where the calling thread loaded them (:meth:`VegymVectorEnv.step`)."""
    if load[0]:
        _clip_into(source, target)


@njit(cache=True, nogil=True)
def _load_actions(source: np.ndarray, target: np.ndarray, tolerance: float) -> int:
    """Copy ``source`` (C-contiguous, ``target.size`` numbers) into the float64 array ``target`` (C order), clipping
    values within ``tolerance`` outside [-1, 1], where :func:`_check_actions` finds them all so; returns its
    status (0: copied)."""
    status = _check_actions(source, tolerance)
    if status == 0:
        _clip_into(source, target)
    return status


@njit(cache=True, nogil=True)
def _end_step(
    step: np.ndarray,
    resetting: np.ndarray,
    max_steps: int,
    reward: np.ndarray,
    terminated: np.ndarray,
    active: np.ndarray,
    truncated: np.ndarray,
    autoreset: np.ndarray,
) -> None:
    """A vector step's bookkeeping, in place, in one branch-free pass: the step counted in ``step``, which is 0
    for the ``resetting`` sub-envs (they start an episode now, with reward 0 and not terminated); ``active`` the
    others; ``truncated`` where an active sub-env reached ``max_steps`` steps; ``autoreset`` where it terminated
    or truncated. Row by row: a split step's last call."""
    for i in range(len(step)):
        a = not resetting[i]
        counted = (step[i] + 1) * a
        step[i] = counted
        active[i] = a
        reward[i] = reward[i] if a else 0.0
        ended = terminated[i] & a
        cut = a & (counted >= max_steps)
        terminated[i], truncated[i], autoreset[i] = ended, cut, ended | cut


def action_shapes(n: int, dim: int) -> frozenset[tuple[int, ...]]:
    """The shapes in which ``n`` actions of ``dim`` numbers are taken: ``(n, dim)``, a single env's ``(dim,)`` and
    ``(n,)`` for one-dimensional actions (and, by :func:`check_actions`, any shape of one number for one)."""
    return frozenset({(n, dim), *([(dim,)] if n == 1 else []), *([(n,)] if dim == 1 else [])})


def _is_real(value: Any) -> bool:
    """Whether an element of an object array is a real number (a 0-d array holding one too). Numpy would read None
    as NaN, drop an imaginary part and parse a string."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    return isinstance(value, numbers.Real | np.bool_)


def check_actions(action: Any, target: np.ndarray, expected: tuple[int, ...] | None = None) -> np.ndarray:
    """Load ``action`` into ``target`` (float64, ``(n, action_dim)``) and return it. ValueError on another shape
    (also taken: a single env's ``(action_dim,)``, ``(n,)`` for one-dimensional actions, a scalar for one
    number; the error names ``expected``, by default ``target``'s shape), on anything but real numbers (None,
    complex numbers, strings), on NaN/inf and on values outside [-1, 1] by more than ``ACTION_TOLERANCE`` (those
    within are clipped)."""
    a = action if isinstance(action, np.ndarray) else np.asarray(action)
    if not (a.shape in action_shapes(*target.shape) or a.size == target.size == 1):
        raise ValueError(f"action has shape {a.shape}; expected {expected or target.shape}")
    if a.dtype.kind in "cSUV" or (a.dtype.kind == "O" and not all(map(_is_real, a.flat))):
        raise ValueError(f"action {action!r} is not an array of real numbers")
    if a.dtype.kind not in "fiu" or not a.dtype.isnative or not 4 <= a.dtype.itemsize <= 8:
        try:  # bool, float16, long double, object, big-endian, ...: converted by numpy first
            a = np.asarray(a, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"action {action!r} is not an array of real numbers: {error}") from None
    if not a.flags.c_contiguous:
        a = np.ascontiguousarray(a)
    status = _load_actions(a, target, ACTION_TOLERANCE)
    if status == 1:
        raise ValueError(f"action contains NaN or inf: {a!r}")
    if status == 2:
        raise ValueError(f"action {a!r} is outside the action space [-1, 1]")
    return target


_FLOAT32 = np.dtype(np.float32)
_NO_LIMIT = int(np.iinfo(np.int64).max)
"""The step count of :func:`_end_step` without a time limit."""
_DIRECT_DTYPES = (_FLOAT32, np.dtype(np.float64))


class ActionLoader:
    """Loads and checks actions as :func:`check_actions` does, into one float64 ``(n, action_dim)`` array that it
    reuses; float32 and float64 arrays of the shapes an env steps with take a short path (no conversions)."""

    def __init__(self, n: int, action_shape: tuple[int, ...], single: bool = False) -> None:
        self.target = np.empty((n, *action_shape))
        self._direct_shapes = action_shapes(*self.target.shape)
        self._expected = action_shape if single else self.target.shape  # the shape that errors name

    @property
    def direct_shapes(self) -> frozenset[tuple[int, ...]]:
        """The shapes of the actions it takes as they are (:func:`action_shapes`)."""
        return self._direct_shapes

    def __call__(self, action: Any) -> np.ndarray:
        """``action`` loaded into the target array (the array returned); ValueError as :func:`check_actions`."""
        if (
            type(action) is np.ndarray
            and action.shape in self._direct_shapes
            and action.dtype in _DIRECT_DTYPES
            and action.flags.c_contiguous
            and _load_actions(action, self.target, ACTION_TOLERANCE) == 0
        ):
            return self.target
        return check_actions(action, self.target, self._expected)  # other arrays, and the errors


def single_action_loader(loader: ActionLoader) -> Callable[[Any], np.ndarray]:
    """``loader`` (of one action of shape ``(dim,)``) as a single env calls it every step: a float32 or float64
    array of shape ``(dim,)`` whose numbers all lie in [-1, 1] is read as Python floats and stored through a
    memoryview (about 0.3 us, against 0.7-0.9 us for the numba copy's call); anything else goes to ``loader``.
    Generated code with the numbers unpacked by name, since a loop costs as much again."""
    target = loader.target
    if target.ndim != 2 or target.shape[0] != 1 or target.shape[1] == 0:
        return loader
    names = [f"x{j}" for j in range(target.shape[1])]
    source = (
        "def load(action, ndarray=np.ndarray, shape=target.shape[1:], dtypes=_DIRECT_DTYPES,"
        " values=memoryview(target.reshape(-1)), target=target, loader=loader):\n"
        "    if type(action) is ndarray and action.shape == shape and action.dtype in dtypes:\n"
        f"        {', '.join(names)}, = action.tolist()\n"
        f"        if {' and '.join(f'-1.0 <= {x} <= 1.0' for x in names)}:\n"  # False for NaN
        f"            {'; '.join(f'values[{j}] = {x}' for j, x in enumerate(names))}\n"
        "            return target\n"
        "    return loader(action)\n"
    )
    return _define(source, {"np": np, "_DIRECT_DTYPES": _DIRECT_DTYPES, "target": target, "loader": loader})


@functools.lru_cache(maxsize=256)
def _compiled(source: str) -> types.CodeType:
    """The compiled code of a generated reader's source: compiling takes 0.1-0.3 ms, and an env builds its readers
    again whenever a state is put back, on unpickling and on deepcopy, with the same source for the same env."""
    return compile(source, "<vegym generated>", "exec")


def _define(source: str, namespace: dict[str, Any]) -> Callable[..., Any]:
    """The one function that ``source`` defines, run in ``namespace`` (which gives its defaults' values)."""
    before = set(namespace)
    exec(_compiled(source), namespace)  # noqa: S102
    (name,) = set(namespace) - before - {"__builtins__"}
    return namespace[name]


def load_object(path: str) -> Any:
    """Import ``"package.module:Name"``."""
    module, name = path.split(":")
    return getattr(importlib.import_module(module), name)


def rows_of(arrays: State, rows: slice | np.ndarray) -> State:
    """The rows ``rows`` of every array: views for a slice, copies for indices."""
    return {name: value[rows] for name, value in arrays.items()}


def _entries(value: Any, num_envs: int) -> list[Any]:
    """Every sub-env's entry of a vector info value, as the single env would report it: Python scalars from a 1-d
    array (one ``tolist``, also for object arrays), rows of one fresh copy of a wider array, split nested dicts."""
    if isinstance(value, Mapping):
        return split_info(value, num_envs)
    value = np.asarray(value)  # a wrapper's list, say
    if value.ndim == 1:
        return value.tolist()
    return list(np.array(value))


def split_info(info: Mapping[str, Any], num_envs: int) -> list[Info]:
    """Gymnasium's vector info (arrays with ``_key`` masks, nested dicts alike) as one dict per sub-env, as a single
    env reports it (the SB3 adapter's ``infos``, a rendering vector env's renderers). Each value is converted as a
    whole, not entry by entry: entry by entry took 160-190 us of the adapter's 220-250 us step at 16 envs."""
    out: list[Info] = [{} for _ in range(num_envs)]
    every = range(num_envs)
    for key, value in info.items():
        if key.startswith("_"):
            continue
        entries = _entries(value, num_envs)
        mask = info.get(f"_{key}")
        for i in every if mask is None or np.all(mask) else np.flatnonzero(mask).tolist():
            out[i][key] = entries[i]
    return out


def _columns_of_row(value: np.ndarray) -> tuple[np.ndarray, int, int] | None:
    """For ``value`` a ``(1, k)`` view of columns of a C-contiguous ``(1, m)`` array: that array and the columns
    ``[start, stop)``; otherwise None."""
    base = value.base
    if not (
        isinstance(base, np.ndarray)
        and base.ndim == value.ndim == 2
        and base.shape[0] == value.shape[0] == 1
        and base.dtype == value.dtype
        and base.flags.c_contiguous
        and value.strides[1] == base.itemsize
    ):
        return None
    start = (value.__array_interface__["data"][0] - base.__array_interface__["data"][0]) // base.itemsize
    return base, start, start + value.shape[1]


def row_reader(info: Mapping[str, Any]) -> Callable[[], Info]:
    """A function that reads row 0 of the batched (nested) info dict ``info`` into a fresh dict: Python scalars
    from 1-d arrays, copies of the row of others, Python scalars (constants) as they are. Built once over views
    that stay valid; the reading is one generated function (no loop), since it runs on every single-env step.
    Values that are columns of one output array (Billiards's six 2-vectors of its ``shot``, say) are slices of one
    copy of its row: a fresh numpy array costs about 0.15 us to make and free, a slice of one about 0.1 us."""
    getters: list[Callable[[], Any]] = []
    columns = {id(value): _columns_of_row(value) for value in _leaves(info) if isinstance(value, np.ndarray)}
    taken: dict[int, list[tuple[int, int]]] = collections.defaultdict(list)  # id of an output array -> its columns
    for value in _leaves(info):
        found = columns.get(id(value))
        if found is not None:
            taken[id(found[0])].append((found[1], found[2]))
    # slices of one copy only where no two entries' columns overlap (or are one value twice): entries must not alias
    shared = {base for base, spans in taken.items() if len(spans) > 1 and _disjoint(spans)}
    row_copies: dict[int, int] = {}  # id of a shared output array -> index of its row's copy

    def display(tree: Mapping[str, Any]) -> str:
        items = []
        for name, value in tree.items():
            if isinstance(value, Mapping):
                items.append(f"{name!r}: {display(value)}")
                continue
            found = columns.get(id(value))
            if found is not None and id(found[0]) in shared:
                base, start, stop = found
                if id(base) not in row_copies:
                    row_copies[id(base)] = len(getters)
                    getters.append(base[0].copy)
                items.append(f"{name!r}: row{row_copies[id(base)]}[{start}:{stop}]")
                continue
            if not isinstance(value, np.ndarray):
                getters.append(itertools.repeat(value).__next__)
            elif value.ndim == 1:
                getters.append(value[:1].item)
            else:
                getters.append(value[0].copy)
            items.append(f"{name!r}: g{len(getters) - 1}()")
        return "{" + ", ".join(items) + "}"

    source = display(info)
    defaults = ", ".join(f"g{i}=g[{i}]" for i in range(len(getters)))  # local names: no tuple lookups per call
    copies = "".join(f"    row{i} = g{i}()\n" for i in row_copies.values())
    return _define(f"def read({defaults}):\n{copies}    return {source}\n", {"g": tuple(getters)})


def _disjoint(spans: list[tuple[int, int]]) -> bool:
    """Whether the half-open ranges ``[start, stop)`` overlap nowhere."""
    ordered = sorted(spans)
    return all(stop <= next_start for (_, stop), (next_start, _) in itertools.pairwise(ordered))


def _copies_state(info: Mapping[str, Any], updated_ids: set[int], copied_ids: set[int]) -> bool:
    """Whether :meth:`VegymVectorEnv._vector_info` copies an array of ``info`` itself, reading it: (a view of) one of
    the state arrays ``updated_ids`` that is not one of those whose copies a split step makes (``copied_ids``)."""
    return any(
        isinstance(value, np.ndarray)
        and id(value) not in copied_ids
        and (id(value) in updated_ids or id(value.base) in updated_ids)
        for value in _leaves(info)
    )


def _leaves(tree: Mapping[str, Any]) -> Iterator[Any]:
    """The values of a nested dict, depth first."""
    for value in tree.values():
        if isinstance(value, Mapping):
            yield from _leaves(value)
        else:
            yield value


def owned(state: State) -> State:
    """``state`` with every array its own C-contiguous, writeable memory (copies of views, read-only or shared
    arrays), since the front ends update states in place."""
    seen: set[int] = set()
    for name, value in state.items():
        if id(value) in seen or value.base is not None or not value.flags.c_contiguous or not value.flags.writeable:
            state[name] = value = np.array(value, order="C")
        seen.add(id(value))
    return state


_ROW_0 = np.zeros(1, dtype=np.intp)
"""The rows argument of a single env's :meth:`Task.start` and :meth:`Task.restart`."""


def check_reset_options(options: Mapping[str, Any], known: tuple[str, ...]) -> None:
    """Refuse reset options other than ``known`` (a misspelled ``reset_mask``, or CartPole's ``low``/``high``,
    would otherwise be ignored without a word)."""
    unknown = sorted(set(options) - set(known))
    if unknown:
        takes = f"only {', '.join(map(repr, known))}" if known else "no options"
        raise ValueError(f"reset options {unknown} are not understood: this env's reset takes {takes}")


class VegymEnv(gym.Env[np.ndarray, np.ndarray], Generic[P]):
    """A Gymnasium env running a :class:`Task` on a batch of one.

    Subclasses set ``task_cls`` and a docstring; ``__init__(render_mode=None, **params)`` builds the frozen
    parameter dataclass, so every keyword lands in ``spec.kwargs`` and an unknown one raises ``TypeError``.
    The state arrays are allocated at the first reset, the action and output arrays in ``__init__``, and all are
    reused, the task's kernels bound to them (a new ``env.state`` dict, a snapshot put back say, is bound at the
    next step, reset or render, and the renderer's record starts again from it; an array replaced inside the dict
    is not seen: update arrays in place); what ``step`` and ``reset`` return are fresh copies.
    """

    task_cls: ClassVar[type[Task]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 1}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """List the task's parameters in the subclass's ``## Arguments`` section."""
        super().__init_subclass__(**kwargs)
        if "task_cls" in cls.__dict__ and cls.__doc__:
            cls.__doc__ = with_arguments(cls.__doc__, cls.task_cls.params_cls)

    def __init__(self, render_mode: str | None = None, **params: Any) -> None:
        self.task = self.task_cls(self.task_cls.params_cls.of(**params))
        self.params: P = self.task.params  # type: ignore[assignment]
        self.metadata = {**type(self).metadata, "render_fps": self.task.control_rate}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r} is not one of {self.metadata['render_modes']}")
        self.render_mode = render_mode
        self.observation_space = self.task.observation_space
        self.action_space = self.task.action_space
        self.state: State | None = None
        self._bound_state: State | None = None
        self._action_loader = ActionLoader(1, self.action_space.shape, single=True)
        self._load_action = single_action_loader(self._action_loader)
        planned = self.task.planned_steps
        self._warn_past = sys.maxsize if planned is None else planned  # the step count that warns; then never again
        self._terminated_at = -1
        """The step count at which the episode terminated (-1: none): a step from that count warns that reset() is
        due (a reset, or a state put back from another count, in place or as a new dict, needs no warning)."""
        self._out = self.task.outputs(1)
        self._renderer: Any = None
        self._window: Any = None

    def _bind(self, state: State) -> None:
        """Make ``state`` the env's, with the per-step work bound to its arrays and the outputs: the task's kernel
        calls (:func:`bind_kernel`), the info reader and readers of the outputs' row 0. At the first reset, on
        unpickling, and when ``self.state`` was replaced by another dict."""
        out = self._out
        self._run_step = bind_kernel(*self.task.step_call(state, self._action_loader.target, out))
        restart = self.task.restart_call(state, _ROW_0, out["obs"])
        self._restart = bind_kernel(*(restart or (self.task.restart_by_parts, (state, _ROW_0, out["obs"]))))
        self._read_info = row_reader(self.task.info(state, out))
        self._read_obs = out["obs"][0].copy
        self._read_reward = out["reward"][:1].item
        self._read_terminated = out["terminated"][:1].item
        self._steps = memoryview(state["step"])  # the step count, read and written without numpy's indexing
        self.state = self._bound_state = state

    def _adopt(self, state: State) -> None:
        """Bind ``state``, a dict put in place of ``self.state`` (a snapshot put back, say, to step on from), and
        start the renderer's record (its trail, the shots it shows) again from it."""
        self._bind(state)
        if self.render_mode is not None:
            self._get_renderer().reset(self._snapshot())

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, Info]:
        """Start an episode: the seeded one, or without a seed the next one of this env's sequence (the first drawn
        from ``np_random``). There are no reset options; any key in ``options`` raises ``ValueError``."""
        if options:
            check_reset_options(options, ())
        if seed is not None and not _is_integer(seed):
            raise TypeError(f"seed={seed!r}: expected an int (numpy's too) or None")
        seeded = rng.seed_keys([seed]) if seed is not None else None  # a bad seed raises before anything changes
        state = self.state
        if state is not None and state is not self._bound_state:
            self._bind(state)
        if seeded is None and state is not None:
            # the next episode of the sequence, which one-step episodes (Projectile's, Billiards's) start after every
            # step: kept short, without gymnasium's Env.reset, which does nothing without a seed
            self._steps[0] = 0
            self._restart()
        else:
            super().reset(seed=None if seed is None else int(seed))  # gymnasium's takes Python ints only
            if state is None:
                key = seeded if seeded is not None else self.np_random.integers(0, 2**64, 1, np.uint64)
                self._bind(owned({**self.task.initial_state(key), "key": key, "step": np.zeros(1, dtype=np.int64)}))
                self.task.observe(self.state, self._out["obs"])
            else:
                state["key"][:] = seeded
                self.task.start(state, state["key"], _ROW_0)
                state["step"][0] = 0
                self.task.observe(state, self._out["obs"])
        if self.render_mode is not None:
            self._get_renderer().reset(self._snapshot())
            if self.render_mode == "human":
                self.render()
        return self._read_obs(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, Info]:
        """One step. After a step that returned ``terminated`` (or ``truncated``, the time limit's) call ``reset()``:
        a step from a terminal state warns and goes on from it (Projectile fires again) in an episode that the task
        never starts; one past the planned length warns once. (The env tells a terminal state by its step count, so
        a state put back at the count of the step that terminated warns too.)"""
        state = self.state
        if state is None or state is not self._bound_state:
            if state is None:
                raise gym.error.ResetNeeded("Call reset() before step().")
            self._adopt(state)
        self._load_action(action)
        if self._steps[0] == self._terminated_at:
            gym.logger.warn(
                f"{type(self).__name__}: step() after the episode terminated; call reset() first (this step goes on "
                "from its final state, in an episode that the task never starts)"
            )
        self._run_step()
        steps = self._steps
        count = steps[0] + 1
        steps[0] = count
        if count > self._warn_past:
            hint = "; where the time limit truncated it, call reset() first"
            self.task.warn_unplanned_length(f"{type(self).__name__}: an episode has run {count} steps", hint)
            self._warn_past = sys.maxsize
        info = self._read_info()
        if self.render_mode is not None:
            self._get_renderer().record(self._snapshot(), info)
            if self.render_mode == "human":
                self.render()
        terminated = self._read_terminated()
        self._terminated_at = count if terminated else -1
        return self._read_obs(), self._read_reward(), terminated, False, info

    def _snapshot(self) -> State:
        """A copy of the state for the renderer to keep (the env updates its own in place)."""
        return {name: value.copy() for name, value in self.state.items()}  # type: ignore[union-attr]

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to make().")
            return None
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() before render().")
        if self.state is not self._bound_state:
            self._adopt(self.state)
        frame = self._get_renderer().draw()
        if self.render_mode == "rgb_array":
            return frame
        if self._window is None:
            from vegym.render.window import Window

            self._window = Window(type(self).__name__, self.metadata["render_fps"])
        self._window.show(frame)
        return None

    def _get_renderer(self) -> Any:
        if self._renderer is None:
            self._renderer = load_object(self.task.renderer)(self.params)
        return self._renderer

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    _BOUND = (
        "_bound_state", "_load_action", "_run_step", "_restart", "_read_info", "_read_obs", "_read_reward",
        "_read_terminated", "_steps",
    )  # fmt: skip
    """What :meth:`_bind` sets, and the action loader: functions over this env's arrays, rebuilt over an unpickled
    copy's."""

    def __getstate__(self) -> dict[str, Any]:
        state = {name: value for name, value in self.__dict__.items() if name not in self._BOUND}
        state["_window"] = None
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.__dict__.setdefault("_terminated_at", -1)  # a pickle from before it
        self._load_action = single_action_loader(self._action_loader)
        self._bound_state = None
        if self.state is not None:
            self._bind(self.state)


MALLOC_MMAP_THRESHOLD_MAX = 32 << 20
"""glibc's ceiling on its dynamic mmap threshold (64-bit), bytes."""


def _recycle_step_memory(nbytes: int) -> None:
    """Have glibc's malloc serve blocks of up to ``nbytes`` (at most 32 MiB) from its heap and keep the freed ones
    there, rather than map fresh pages for each and fault them in one by one (a vector step's outputs and info
    copies, allocated and dropped every step: 256 page faults per step of 8,192 Projectile envs, a third of its
    time). glibc raises its mmap threshold to the size of a freed mapped block and its heap trim threshold to twice
    that, so allocating and freeing one block of ``nbytes`` once is enough; other allocators just see one block."""
    np.empty(min(nbytes, MALLOC_MMAP_THRESHOLD_MAX), np.uint8)  # freed at once


THREADS_VARIABLE = "VEGYM_NUM_THREADS"
"""Environment variable: the most threads a vector env's step, reset or observation may use (1: the calling thread
only); unset, the CPU cores this process may run on."""


def _thread_count() -> int:
    """Threads a vector env may use: ``VEGYM_NUM_THREADS`` where set (``ValueError`` unless a positive integer),
    else the CPU cores this process may run on."""
    value = os.environ.get(THREADS_VARIABLE)
    if value is None:
        return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    if not value.strip().isdigit() or int(value) < 1:
        raise ValueError(f"{THREADS_VARIABLE}={value!r} is outside the allowed range: integers in [1, inf)")
    return int(value)


def _split_helpers(num_envs: int) -> int:
    """Helper threads for a vector step of ``num_envs`` sub-envs: one per chunk of ``SPLIT_MIN_ROWS`` rows beyond
    the calling thread's, within :func:`_thread_count`."""
    return max(0, min(_thread_count(), num_envs // SPLIT_MIN_ROWS) - 1)


_pool: ThreadPoolExecutor | None = None


def _forget_pool() -> None:
    """In a forked child: the parent's pool threads do not exist there; start a new pool when needed."""
    global _pool
    _pool = None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def _chunk_rows(n: int, chunks: int) -> np.ndarray:
    """For each of ``n`` rows, its index within its chunk, of ``chunks`` as :class:`kernel_split.SplitKernel` splits
    them."""
    return np.concatenate([np.arange(n * (k + 1) // chunks - n * k // chunks) for k in range(chunks)])


def _in_chunks(n: int, run: Callable[[slice], None]) -> None:
    """``run(rows)`` over row slices that cover ``range(n)``: for large ``n`` one chunk of at least
    ``PARALLEL_MIN_ENVS // 2`` rows per CPU core, on threads. Returns once every chunk has finished."""
    global _pool
    chunks = min(_thread_count(), n // (PARALLEL_MIN_ENVS // 2)) if n >= PARALLEL_MIN_ENVS else 1
    if chunks <= 1:
        run(slice(0, n))
        return
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=_thread_count(), thread_name_prefix="vegym")
    bounds = [n * k // chunks for k in range(chunks + 1)]
    futures = [_pool.submit(run, slice(bounds[k], bounds[k + 1])) for k in range(1, chunks)]
    try:
        run(slice(bounds[0], bounds[1]))
    finally:  # never leave a chunk writing into the state after returning, even on an error
        for future in futures:
            future.result()


def _is_integer(value: Any) -> bool:
    """Whether ``value`` is an integer of any type, numpy's too, but not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _count(name: str, value: Any, alternatives: str = "") -> int:
    """``value`` as a Python int of at least 1 (any integer type but bool); ValueError naming ``name`` (and the
    ``alternatives`` text) otherwise."""
    if not _is_integer(value) or value < 1:
        raise ValueError(f"{name}={value!r} is outside the allowed range: integers in [1, inf){alternatives}")
    return int(value)


class VegymVectorEnv(VectorEnv, Generic[P]):
    """A native Gymnasium vector env running a :class:`Task` on ``num_envs`` episodes at once.

    NEXT_STEP autoreset: the step after a sub-env terminates or truncates resets it, returning its first
    observation with reward 0 and ``terminated = truncated = False``. Truncation comes from
    ``max_episode_steps`` (``make_vec`` passes the registered value unless given one). None or -1 means no time
    limit, None also when passed to ``make_vec`` explicitly (``gymnasium.make`` reads None as the registered limit,
    -1 as none). The state is updated in place, but for the task's episode constants, which get new arrays when
    episodes start. No returned array is ever written again: they are fresh or read-only (the infos' views of the
    episode constants and arrays of constants). With
    ``render_mode="rgb_array"`` each sub-env has the single env's renderer, fed after every step (a snapshot of
    its row: slow, for looking, not for training), and ``render()`` returns their frames.

    With two or more chunks of ``kernel_split.SPLIT_MIN_ROWS`` (4,096) sub-envs and of threads (the CPU cores
    this process may run on, or ``VEGYM_NUM_THREADS``, read when the env is made), a step's kernel runs over chunks
    of rows in the calling thread and daemon helper threads at once, with the same results; the helpers spin for
    about 0.2 ms after each step and then nap, and ``close()`` or dropping the env stops them. Where the calling
    thread alone steps at least 15% faster (tried after half a second of stepping, then less often while the
    split stays), it runs them alone while that lasts.
    ``VEGYM_NUM_THREADS=1`` keeps every vector env to the calling thread.
    """

    task_cls: ClassVar[type[Task]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self, num_envs: int = 1, max_episode_steps: int | None = None, render_mode: str | None = None, **params: Any
    ) -> None:
        num_envs = _count("num_envs", num_envs)
        if max_episode_steps is None or (isinstance(max_episode_steps, numbers.Integral) and max_episode_steps == -1):
            max_episode_steps = None
        else:
            max_episode_steps = _count("max_episode_steps", max_episode_steps, "; None or -1 for no limit")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"render_mode={render_mode!r} is not one of {self.metadata['render_modes']} (a vector env returns its "
                "sub-envs' frames; a window shows a single env: gymnasium.make(id, render_mode='human'))"
            )
        self.task = self.task_cls(self.task_cls.params_cls.of(**params))
        planned = self.task.planned_steps
        if planned is not None and (max_episode_steps is None or max_episode_steps > planned):
            self.task.warn_unplanned_length(f"{type(self).__name__}: max_episode_steps={max_episode_steps}")
        elif planned is not None and max_episode_steps < planned and self.task.plan_changed:
            name = self.task.planned_length_param
            gym.logger.warn(
                f"{type(self).__name__}: max_episode_steps={max_episode_steps} cuts the episodes that {name}={planned} "
                f"plans (make_vec passes the registered time limit unless given one); pass "
                f"max_episode_steps={planned} as well"
            )
        self.params: P = self.task.params  # type: ignore[assignment]
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.render_mode = render_mode
        self.metadata = {**type(self).metadata, "render_fps": self.task.control_rate}
        self.single_observation_space = self.task.observation_space
        self.single_action_space = self.task.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.state: State | None = None
        self._load_actions = ActionLoader(num_envs, self.single_action_space.shape)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._every = np.arange(num_envs)
        self._constant_arrays: dict[str, tuple[Any, np.ndarray]] = {}
        self._renderers: list[Any] = []
        self._split_helpers = _split_helpers(num_envs)
        self._split: SplitKernel | None = None
        self._split_restarts: str | None = None
        """Which restarts the split runs too (:meth:`_restart_call_to_split`)."""
        self._chunk_rows = self._every
        """For each row, its index in its chunk of the split (:func:`_chunk_rows`)."""
        self._info_overlaps = False
        """Whether a split step builds its info while the helpers run their chunks (:meth:`_step_task`)."""
        self._chunk_restarts = False
        """Whether each chunk of a split step restarts its rows of the sub-envs that start an episode
        (:meth:`_split_task`)."""
        self._load_flag = np.zeros(1, np.bool_)
        """``load`` of :func:`_clip_actions` in the steps (whether ``source`` holds the actions)."""
        self._unused_source: np.ndarray | None = None
        """:meth:`_no_source`'s array, once made."""

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, Info]:
        """Reset every sub-env, or with ``options={"reset_mask": mask}`` (bool, (num_envs,)) only the masked ones.

        A masked reset without a seed starts each masked sub-env's next episode, exactly as autoreset (and the
        single env's ``reset()``) would; with a seed, masked sub-env ``i`` gets ``seed + i`` (or ``seed[i]``).
        A reset without a seed or a mask does the former for every sub-env, once there is a state (the first
        draws the keys from the vector env's ``np_random``), so that, as with single envs, only seeds choose the
        episodes. Any other key in ``options`` raises ``ValueError``.
        """
        options = options or {}
        check_reset_options(options, ("reset_mask",))
        mask = options.get("reset_mask")
        if mask is None and seed is None and self.state is not None:
            mask = np.ones(self.num_envs, dtype=bool)
        if mask is not None:
            return self._reset_masked(seed, mask)
        seeded = self._seed_keys(seed) if seed is not None else None  # a bad seed raises before anything changes
        super().reset(seed=int(seed) if _is_integer(seed) else None)
        keys = seeded if seeded is not None else self.np_random.integers(0, 2**64, size=self.num_envs, dtype=np.uint64)
        self.state = owned(
            {**self.task.initial_state(keys), "key": keys, "step": np.zeros(self.num_envs, dtype=np.int64)}
        )
        step_arrays = (*self.state.values(), *self.task.outputs(self.num_envs).values())
        _recycle_step_memory(2 * sum(array.nbytes for array in step_arrays))
        self._autoreset[:] = False
        if self.render_mode is not None:
            self._restart_renderers(self._every)
        return self._observe(), {}

    def _seed_keys(self, seed: int | list[int | None]) -> np.ndarray:
        """Keys of sub-env seeds ``seed + i``, or of a list of one seed per sub-env, where None leaves that sub-env
        unseeded, as SyncVectorEnv does: its next episode, as ``reset()`` would start it (its first drawn from
        ``np_random``)."""
        n = self.num_envs
        if _is_integer(seed):
            seed = int(seed)
            if not 0 <= seed <= 2**64 - n:
                raise ValueError(f"seed={seed} gives sub-env seeds seed + i outside [0, 2**64) for num_envs={n}")
            return rng.seed_keys(np.uint64(seed) + np.arange(n, dtype=np.uint64))
        if isinstance(seed, str) or not isinstance(seed, Sequence | np.ndarray):
            raise TypeError(f"seed={seed!r}: expected an int or a list of num_envs={n} ints or None")
        if len(seed) != n:
            raise ValueError(f"seed has {len(seed)} entries; expected num_envs={n}")
        seeded = np.array([s is not None for s in seed], dtype=bool)
        if seeded.all():
            keys = np.empty(n, np.uint64)
        elif self.state is None:
            keys = self.np_random.integers(0, 2**64, n, np.uint64)
        else:
            keys = rng.next_key(self.state["key"])
        if seeded.any():
            keys[seeded] = rng.seed_keys([s for s in seed if s is not None])
        return keys

    def _reset_masked(self, seed: int | list[int] | None, mask: Any) -> tuple[np.ndarray, Info]:
        """Reset the sub-envs of ``mask``, which SyncVectorEnv's rules hold to: a numpy bool array of shape
        ``(num_envs,)`` with at least one True (TypeError for another type or dtype, ValueError otherwise)."""
        if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
            raise TypeError(f"reset_mask must be a numpy bool array of shape ({self.num_envs},); got {mask!r}")
        if mask.shape != (self.num_envs,) or not mask.any():
            raise ValueError(
                f"reset_mask must have shape ({self.num_envs},) and a True entry; got {mask!r}, shape {mask.shape}"
            )
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() without reset_mask before a masked reset.")
        keys = rng.next_key(self.state["key"][mask]) if seed is None else self._seed_keys(seed)[mask]
        self._start(np.flatnonzero(mask), keys)
        self._autoreset[mask] = False
        if self.render_mode is not None:
            self._restart_renderers(np.flatnonzero(mask))
        return self._observe(), {}

    def _start(self, rows: np.ndarray, keys: np.ndarray) -> None:
        """Start the episodes of ``keys`` in the sub-envs ``rows`` (int indices), in place."""
        self._renew_episode_constants(every_row=len(rows) == self.num_envs)
        state = self.state
        assert state is not None
        if len(rows) == self.num_envs:  # every sub-env: in chunks, on views
            every = self._every
            _in_chunks(self.num_envs, lambda r: self.task.start(rows_of(state, r), keys[r], every[: r.stop - r.start]))
        else:
            self.task.start(state, keys, rows)
        state["key"][rows], state["step"][rows] = keys, 0

    def _observe(self) -> np.ndarray:
        """Observations of every sub-env, in a new array."""
        state = self.state
        assert state is not None
        obs = np.empty((self.num_envs, *self.single_observation_space.shape), np.float32)
        _in_chunks(self.num_envs, lambda r: self.task.observe(rows_of(state, r), obs[r]))
        return obs

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Info]:
        """Step every sub-env; those that ended on the previous step start a new episode instead (NEXT_STEP).

        The task steps the whole batch (its randomness is a pure function of each episode's key, so the
        discarded rows of resetting sub-envs draw nothing that others see), unless every sub-env resets (one-step
        episodes do so every other step): then its outputs are zeros. Resetting rows then start fresh episodes
        and report reward 0, not terminated, not truncated, and masked-out infos: every ``_name`` mask is the
        same read-only array, False for those rows, whose info values are left over from the discarded step
        (SyncVectorEnv fills them with zeros, and returns an empty info where every sub-env resets, where this one
        returns every key masked out, its values zeros; read infos through the masks). Every row's action is
        checked, a resetting row's too (SyncVectorEnv ignores theirs): a NaN or inf anywhere raises ``ValueError``.
        A step interrupted (Ctrl-C) keeps the autoreset flags of the step before, so that the next step starts the
        episodes that had ended; but one whose chunks had restarted them (a split step, :meth:`_split_task`) is done
        but for its info, and keeps its own flags.
        """
        state = self.state
        if state is None:
            raise gym.error.ResetNeeded("Call reset() before step().")
        source = self._checked_source(actions) if self._split_helpers else None
        a = self._load_actions.target if source is not None else self._load_actions(actions)
        n = self.num_envs
        out = self.task.outputs(n)
        resetting = self._autoreset
        restarts = int(np.count_nonzero(resetting))
        every_resets = restarts == n
        active, truncated, autoreset = np.empty(n, np.bool_), np.empty(n, np.bool_), np.empty(n, np.bool_)
        max_steps = self.max_episode_steps if self.max_episode_steps is not None else _NO_LIMIT
        reward, terminated = out["reward"], out["terminated"]
        end = (state["step"], resetting, max_steps, reward, terminated, active, truncated, autoreset)

        def info_of(copies: Mapping[int, np.ndarray]) -> Info:
            active.flags.writeable = False  # the one mask of every info entry
            info = self._vector_info(self.task.info(state, out), active, *self._state_ids(state), copies)
            if restarts:  # after the info took its views of them; the step kernel only reads them
                self._renew_episode_constants(every_row=every_resets)
            return info

        if every_resets:  # the restart below observes every sub-env
            for name, value in out.items():
                if name != "obs":
                    value.fill(0)
            _end_step(*end)
            info, restarted = info_of({}), False
        else:
            info, restarted = self._step_task(state, a, out, source, end, info_of, resetting)
        self._autoreset = autoreset  # only once the step has counted it: an interrupted step keeps the old flags
        if every_resets:
            self._restart_every_row(state, out["obs"])
        elif restarts and not restarted:
            self._restart_rows(state, flagged_rows(resetting), out["obs"])
        if self.render_mode is not None:
            self._record_renderers(flagged_rows(resetting), info)
        return out["obs"], reward, terminated, truncated, info

    def _checked_source(self, actions: Any) -> np.ndarray | None:
        """``actions`` as the rows that a split step's chunks convert themselves (:func:`_clip_actions`), checked
        here: a writeable, aligned, C-contiguous float32 array of the shape of the actions (or ``(num_envs,)`` for
        one-dimensional ones) all of whose numbers pass :func:`_check_actions`. None where this thread loads them
        first (:class:`ActionLoader`, which also raises the errors): actions of another kind, which would not fit
        the split's types. For a split step only; the chunks read the array again, so it must not change during the
        step (as no env's actions may)."""
        target = self._load_actions.target
        if (
            type(actions) is not np.ndarray
            or actions.dtype != _FLOAT32
            or actions.size != target.size
            or actions.shape not in self._load_actions.direct_shapes
            or not (actions.flags.c_contiguous and actions.flags.aligned and actions.flags.writeable)
            or _check_actions(actions, ACTION_TOLERANCE)
        ):
            return None
        return actions.reshape(target.shape)

    def _step_task(
        self,
        state: State,
        actions: np.ndarray,
        out: State,
        source: np.ndarray | None,
        end: tuple[Any, ...],
        info_of: Callable[[Mapping[int, np.ndarray]], Info],
        resetting: np.ndarray,
    ) -> tuple[Info, bool]:
        """The task's step of every sub-env (:meth:`Task.step`) between the conversion of the actions ``source``
        (checked float32 rows, :meth:`_checked_source`) into ``actions``, where given (else ``actions`` holds them),
        and the bookkeeping :func:`_end_step` of ``end``, its arguments. With two or more chunks of
        ``SPLIT_MIN_ROWS`` rows and of threads (:func:`_split_helpers`), the three run over chunks of rows in this
        thread and helper threads at once (:class:`kernel_split.SplitKernel`, which may run them all in this
        thread), where the kernel can be split: its arguments that are the arrays of ``state``, ``out`` and
        ``actions`` themselves are split by rows, the others passed whole; and each chunk copies its rows of the
        state arrays that the info reports (but ``step``, which the bookkeeping counts), for the info (each thread
        copies the rows it wrote), right after the kernel. Each chunk then also restarts its rows of the sub-envs
        ``resetting`` (bool), by the task's restart kernel, where ``self._chunk_restarts`` (:meth:`_split_task`).
        Where they do not, the split's second call is the task's restart kernel (:meth:`_restart_call_to_split`),
        for the restarts after the step (:meth:`_restart_rows`, :meth:`_restart_every_row`). Returns the step's
        info, ``info_of`` those copies by the ids of their state arrays (none where not split), and whether the
        ``resetting`` sub-envs restarted; a split step calls ``info_of`` while the helpers run their chunks where
        it reads none of the rows they write (``self._info_overlaps``: it copies no state array itself), else after
        them."""
        if self._split_helpers < 1:  # then source is None
            self.task.step(state, actions, out)
            _end_step(*end)
            return info_of({}), False
        load = self._load_flag
        load[0] = source is not None
        before = (load, source if source is not None else self._no_source(), actions)
        kernel, args = self.task.step_call(state, actions, out)
        split = self._split
        same = split is not None and split.kernel is kernel and len(args) == split.arity
        copies = tuple(np.empty_like(args[k]) for k in split.copies) if same else ()
        restart = self.task.restart_call(state, resetting, out["obs"]) if same and self._chunk_restarts else None
        call = (*before, *args, *copies, *end, *(restart[1] if restart is not None else ()))
        if not same or not split.fits(kernel, call):
            split, copies, call = self._split_task(state, out, kernel, args, before, end, resetting)
        if split is None:
            _clip_actions(*before)
            kernel(*args)
            _end_step(*end)
            return info_of({}), False
        by_source = {id(args[k]): copy for k, copy in zip(split.copies, copies, strict=True)}
        restarts = self._chunk_restarts
        try:
            if self._info_overlaps:
                return split(call, then=lambda: info_of(by_source)), restarts
            split(call)
            return info_of(by_source), restarts
        except BaseException:
            if restarts and split.done:
                # the chunks restarted the rows the old flags name and wrote the new flags: the step is done but for
                # its info, and the old flags kept would restart those rows again
                self._autoreset = end[7]
            raise

    def _split_task(
        self,
        state: State,
        out: State,
        kernel: Callable[..., Any],
        args: tuple[Any, ...],
        before: tuple[Any, ...],
        end: tuple[Any, ...],
        resetting: np.ndarray,
    ) -> tuple[SplitKernel | None, tuple[np.ndarray, ...], tuple[Any, ...]]:
        """A new split of the step's calls (:meth:`_step_task`), in place of any before, the copies for the info
        and the arguments of its first job; None where the kernel cannot be split (the env steps in one thread from
        now on). Each chunk restarts its own rows (``self._chunk_restarts``) where the task has a restart kernel and
        no episode constants, and the info overlaps the helpers: it then reads the rows that a chunk restarts from
        the copies the chunk made before."""
        if self._split is not None:
            self._split.close()
        rows = {id(array) for array in (*state.values(), *out.values(), before[2])}
        info, updated = self.task.info(state, out), self._state_ids(state)[0]
        reported = updated & {id(value) for value in _leaves(info)}
        reported.discard(id(state["step"]))  # counted after the kernel: copied by _vector_info
        sources = [k for k, arg in enumerate(args) if id(arg) in reported]
        copies = tuple(np.empty_like(args[k]) for k in sources)
        self._info_overlaps = not _copies_state(info, updated, {id(args[k]) for k in sources})
        batch = [id(arg) in rows for arg in args] + [True] * len(copies)
        self._chunk_rows = _chunk_rows(self.num_envs, self._split_helpers + 1)
        clip = (_clip_actions, before, [False, True, True])
        after = [(_end_step, end, [True, True, False, True, True, True, True, True])]
        restart = None
        if self._info_overlaps and not self.task.episode_constants:
            restart = self.task.restart_call(state, resetting, out["obs"])  # the flags in place of the rows
        if restart is not None and sum(arg is resetting for arg in restart[1]) == 1:
            marks = [FLAGGED if arg is resetting else id(arg) in rows for arg in restart[1]]
            restarts = [(*restart, marks)]
        else:  # no restart kernel, or one that does not take the rows as given
            restart, restarts = None, []
        split = None
        for chunk_restarts in [True, False] if restarts else [False]:
            # the second call restarts rows after a step (_restart_rows, _restart_every_row): none where chunks do
            self._split_restarts, second = (
                (None, None) if chunk_restarts else self._restart_call_to_split(state, out["obs"])
            )
            with contextlib.suppress(ValueError):  # one that fails with the restarts is tried without
                split = SplitKernel(
                    kernel, (*args, *copies), batch, self._split_helpers, sources, second, before=clip,
                    after=after + restarts if chunk_restarts else after,
                )  # fmt: skip
                break
        if split is None:  # not splittable: this env steps in one thread from now on
            self._split_helpers, copies = 0, ()
        self._split = split
        self._chunk_restarts = split is not None and chunk_restarts
        return split, copies, (*before, *args, *copies, *end, *(restart[1] if self._chunk_restarts else ()))

    def _no_source(self) -> np.ndarray:
        """The float32 rows that a split step's conversion is given, and skips, where this thread loaded the
        actions: made once."""
        if self._unused_source is None:
            self._unused_source = np.zeros(self._load_actions.target.shape, np.float32)
        return self._unused_source

    def _restart_call_to_split(
        self, state: State, obs: np.ndarray
    ) -> tuple[str | None, tuple[Callable[..., Any], tuple[Any, ...], list[bool]] | None]:
        """Which restarts the split runs, ``"some"`` rows, ``"every"`` row or None, and its second call, for
        :class:`kernel_split.SplitKernel`: the task's restart kernel for some rows, split by halves of the rows'
        indices, the other arguments whole (:meth:`_restart_rows`); or, for a task whose kernel restarts every row
        only, that kernel split by rows as the step is, each chunk's row indices its own from 0
        (:meth:`_restart_every_row`)."""
        some = np.zeros(2, np.intp)  # any rows: the call's types are what the split compiles for
        call = self.task.restart_call(state, some, obs)
        if call is not None:
            return "some", (*call, [arg is some for arg in call[1]])
        call = self.task.restart_call(state, self._chunk_rows, obs)
        if call is None:
            return None, None
        rows = {id(array) for array in (*state.values(), obs, self._chunk_rows)}
        return "every", (*call, [id(arg) in rows for arg in call[1]])

    def _restart_rows(self, state: State, rows: np.ndarray, obs: np.ndarray) -> None:
        """:meth:`Task.restart` of the rows ``rows``: split between this thread and the step's helpers (the second
        call of :class:`kernel_split.SplitKernel`, over halves of ``rows``) where there are ``SPLIT_RESTART_ROWS``
        or more of them and the step is split, else in this thread."""
        if len(rows) < SPLIT_RESTART_ROWS or not self._split_restart("some", state, rows, obs):
            self.task.restart(state, rows, obs)

    def _restart_every_row(self, state: State, obs: np.ndarray) -> None:
        """:meth:`Task.restart` of every row: split between this thread and the step's helpers, by rows, where the
        step is split and the split's second call restarts every row; else in chunks (:func:`_in_chunks`)."""
        if not self._split_restart("every", state, self._chunk_rows, obs):
            every = self._every
            _in_chunks(self.num_envs, lambda r: self.task.restart(rows_of(state, r), every[: r.stop - r.start], obs[r]))

    def _split_restart(self, restarts: str, state: State, rows: np.ndarray, obs: np.ndarray) -> bool:
        """Run the task's restart kernel on ``rows`` as the split's second call, where the split runs ``restarts``
        (:meth:`_restart_call_to_split`) and the call fits it; whether it did."""
        split = self._split
        if split is None or self._split_restarts != restarts:
            return False
        call = self.task.restart_call(state, rows, obs)
        if call is None or not split.fits(*call, job=1):
            return False
        split(call[1], job=1)
        return True

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the step's helper threads, for good: steps after ``close()`` run in the calling thread."""
        if self._split is not None:
            self._split.close()
        self._split, self._split_helpers = None, 0

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_split": None, "_unused_source": None}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.__dict__.setdefault("_load_flag", np.zeros(1, np.bool_))  # pickled before the split loaded actions
        self.__dict__.setdefault("_unused_source", None)
        self.__dict__.setdefault("_info_overlaps", False)
        self.__dict__.setdefault("_chunk_restarts", False)
        if not self.closed:  # this machine's threads, not the original's
            self._split_helpers = _split_helpers(self.num_envs)

    def render(self) -> tuple[np.ndarray, ...] | None:
        """The frame of every sub-env (``render_mode="rgb_array"``): a tuple of uint8 (height, width, 3) arrays, as
        a single env of each would draw it."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to make_vec().")
            return None
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() before render().")
        return tuple(renderer.draw() for renderer in self._renderers)

    def _row_snapshot(self, i: int) -> State:
        """A copy of sub-env ``i``'s state, as a single env holds it (a batch of one)."""
        assert self.state is not None
        return {name: value[i : i + 1].copy() for name, value in self.state.items()}

    def _restart_renderers(self, rows: np.ndarray) -> None:
        """Start the renderers' records of the sub-envs ``rows`` (int indices) from their state (a first one makes
        a renderer per sub-env)."""
        if not self._renderers:
            self._renderers = [load_object(self.task.renderer)(self.params) for _ in range(self.num_envs)]
        for i in rows:
            self._renderers[i].reset(self._row_snapshot(i))

    def _record_renderers(self, resetting: np.ndarray, info: Info) -> None:
        """Give each sub-env's renderer its step (state after it, and its row of ``info``), as a single env's step
        does, or a fresh start for the ``resetting`` rows (int indices)."""
        started, infos = set(resetting.tolist()), split_info(info, self.num_envs)
        for i, renderer in enumerate(self._renderers):
            if i in started:
                renderer.reset(self._row_snapshot(i))
            else:
                renderer.record(self._row_snapshot(i), infos[i])

    def _state_ids(self, state: State) -> tuple[set[int], set[int]]:
        """The ids of the state arrays that later steps update in place, and of the episode constants."""
        constants = self.task.episode_constants
        return (
            {id(value) for name, value in state.items() if name not in constants},
            {id(state[name]) for name in constants},
        )

    def _renew_episode_constants(self, every_row: bool) -> None:
        """New arrays for the task's episode constants, before episodes start: earlier infos hold the old ones.
        Copies, or uninitialised when every row is about to be started. A step makes them right after its info took
        its views of the old ones: in a split step whose info overlaps the helpers' chunks (``_info_overlaps``)
        while they may still run (step kernels only read the constants)."""
        state = self.state
        assert state is not None
        for name in self.task.episode_constants:
            state[name] = np.empty_like(state[name]) if every_row else state[name].copy()

    def _vector_info(
        self,
        info: Mapping[str, Any],
        mask: np.ndarray,
        updated_ids: set[int],
        constant_ids: set[int],
        copies: Mapping[int, np.ndarray],
        prefix: str = "",
    ) -> Info:
        """``info`` with Gymnasium's ``_name`` masks. Arrays of (views of) the state: copied where later steps update
        them in place (``updated_ids``; ``copies`` has those the step made, by the state arrays' ids: entries that
        report one array share its copy), read-only views of the episode constants (``constant_ids``), which the
        next steps read. A constant (not an array): a read-only array, shared by the steps while it stays the same
        object."""
        out: Info = {}
        for name, value in info.items():
            if isinstance(value, np.ndarray):
                if id(value) in copies:
                    value = copies[id(value)]
                elif id(value) in updated_ids or id(value.base) in updated_ids:
                    value = value.copy()
                elif id(value) in constant_ids or id(value.base) in constant_ids:
                    value = value.view()
                    value.flags.writeable = False
                out[name] = value
            elif isinstance(value, Mapping):
                out[name] = self._vector_info(value, mask, updated_ids, constant_ids, copies, f"{prefix}{name}/")
            else:
                out[name] = self._constant_array(prefix + name, value)
            out[f"_{name}"] = mask
        return out

    def _constant_array(self, path: str, value: Any) -> np.ndarray:
        """The read-only ``(num_envs,)`` array of ``value``, info entry ``path``'s: made again when the task
        returns another object there, or in a copy of the env that lost the read-only flag."""
        cached = self._constant_arrays.get(path)
        if cached is None or cached[0] is not value or cached[1].flags.writeable:
            array = np.full(self.num_envs, value)
            array.flags.writeable = False
            self._constant_arrays[path] = cached = (value, array)
        return cached[1]
