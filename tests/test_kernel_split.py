"""A large vector env's step kernel split over threads: the same results as the kernel in one thread, errors
raised, helper threads stopped, and copies and forked children that step as the original does."""

import copy
import functools
import gc
import math
import multiprocessing
import os
import pickle
import threading
import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest
from numba import njit

import vegym  # noqa: F401  (registers the envs)
from vegym.envs import kernel_split
from vegym.envs.base import _leaves
from vegym.envs.kernel_split import SPLIT_MIN_ROWS, SplitKernel
from vegym.envs.projectile import ProjectileTask
from vegym.envs.projectile_adjust import ProjectileAdjustTask

ENV_IDS = sorted(env_id for env_id in gym.registry if env_id.startswith("vegym/"))
SPLIT_ENVS = 2 * SPLIT_MIN_ROWS + 3
"""Enough sub-envs for two chunks, an odd number so that the chunks differ in size."""
CHUNK_RESTARTS = {"vegym/SteerableWheel-v0", "vegym/BouncingBall-v0", "vegym/ProjectileAdjust-v0"}
"""The envs whose split steps restart the ended episodes in their chunks (a restart kernel, no episode constants);
hundreds end in each chunk in the rollouts below."""


def _helpers() -> list[threading.Thread]:
    return [thread for thread in threading.enumerate() if thread.name.startswith("vegym-helper")]


def _vector_env(env_id: str, helpers: int) -> gym.vector.VectorEnv:
    """A vector env of ``SPLIT_ENVS`` sub-envs whose steps use ``helpers`` helper threads (0: one thread), whatever
    the machine's core count."""
    env = gym.make_vec(env_id, num_envs=SPLIT_ENVS, vectorization_mode="vector_entry_point")
    env.unwrapped._split_helpers = helpers
    return env


def _rollout(env: gym.vector.VectorEnv, steps: int, seed: int = 3) -> list[np.ndarray]:
    """The observations, rewards, ends and every info array of a seeded rollout of random actions, the infos read
    after the last step (earlier infos must stay as they were returned)."""
    obs, _ = env.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1, 1, (steps, *env.action_space.shape)).astype(np.float32)
    outputs, infos = [obs], []
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        outputs += [obs, reward, terminated, truncated]
        infos.append(info)
    return outputs + [np.asarray(value) for info in infos for value in _leaves(info)]


def _assert_same(first: list[np.ndarray], second: list[np.ndarray]) -> None:
    assert len(first) == len(second)
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a, b)


class _Alone(kernel_split.ModeChooser):
    """A chooser that runs every call in the calling thread alone (and never tries the other way, with
    :func:`_run_alone`)."""

    def __init__(self) -> None:
        super().__init__()
        self.solo = True


def _run_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(kernel_split, "ModeChooser", _Alone)
    monkeypatch.setattr(kernel_split, "PROBE_INTERVAL_S", math.inf)


def _posted_jobs(split: SplitKernel) -> int:
    return int(split.control[kernel_split._TICKET]) >> 32


@pytest.mark.parametrize("alone", [False, True], ids=["over threads", "alone"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_a_split_step_gives_the_one_thread_step_bit_for_bit(
    env_id: str, alone: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Split over threads, or run by the split in the calling thread alone, as its chooser may choose."""
    if alone:
        _run_alone(monkeypatch)
    split, single = _vector_env(env_id, 1), _vector_env(env_id, 0)
    split_outputs, single_outputs = _rollout(split, 40), _rollout(single, 40)
    assert isinstance(split.unwrapped._split, SplitKernel)
    assert split.unwrapped._info_overlaps  # the info is built while the helper runs its chunk
    assert split.unwrapped._chunk_restarts == (env_id in CHUNK_RESTARTS)
    if env_id in CHUNK_RESTARTS:  # no second job to restart the rows a step leaves: it leaves none
        assert split.unwrapped._split_restarts is None and len(split.unwrapped._split.jobs) == 1
    assert (_posted_jobs(split.unwrapped._split) == 0) == alone
    assert single.unwrapped._split is None
    _assert_same(split_outputs, single_outputs)
    split.close()
    single.close()


def test_a_restart_kernel_the_split_cannot_call_leaves_the_restarts_to_the_calling_thread(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The split is made again without them, not given up for one thread."""
    task_cls = type(_vector_env("vegym/SteerableWheel-v0", 0).unwrapped.task)
    restart_call = task_cls.restart_call

    def through_python(self: object, state: dict, rows: np.ndarray, obs: np.ndarray) -> tuple:
        kernel, args = restart_call(self, state, rows, obs)
        return (lambda *args: kernel(*args)), args  # not a numba kernel: no split can call it

    monkeypatch.setattr(task_cls, "restart_call", through_python)
    split, single = _vector_env("vegym/SteerableWheel-v0", 1), _vector_env("vegym/SteerableWheel-v0", 0)
    split_outputs, single_outputs = _rollout(split, 40), _rollout(single, 40)
    assert isinstance(split.unwrapped._split, SplitKernel) and not split.unwrapped._chunk_restarts
    _assert_same(split_outputs, single_outputs)
    split.close()


@pytest.mark.parametrize("when", ["as the calling thread's chunk returns", "while the info is built"])
@pytest.mark.parametrize("env_id", sorted(CHUNK_RESTARTS))
def test_a_split_step_interrupted_after_its_chunks_is_done_but_for_its_info(env_id: str, when: str) -> None:
    """Its chunks have restarted the episodes that had ended and written the new autoreset flags: later steps go on
    as after the step uninterrupted. The old flags kept would restart those episodes again, a second key advance
    (a review's finding). A Ctrl-C during the compiled call is raised as it returns, before the info."""
    interrupted, reference = _vector_env(env_id, 1), _vector_env(env_id, 1)
    actions = np.random.default_rng(3).uniform(-1, 1, (30, *interrupted.action_space.shape)).astype(np.float32)
    for env in (interrupted, reference):
        env.reset(seed=3)
    env, step = interrupted.unwrapped, 0
    while step < 5 or not env._autoreset.any():
        for vector in (interrupted, reference):
            vector.step(actions[step])
        step += 1
    owner, name = (env.task, "info") if when == "while the info is built" else (env._split.jobs[0], "call")
    original = getattr(owner, name)

    def interrupt(*args: object) -> None:
        setattr(owner, name, original)
        if name == "call":
            original(*args)
        raise KeyboardInterrupt

    setattr(owner, name, interrupt)
    with pytest.raises(KeyboardInterrupt):
        interrupted.step(actions[step])
    assert env._chunk_restarts and env._split.done and getattr(owner, name) == original
    reference.step(actions[step])
    for action in actions[step + 1 : step + 4]:
        _assert_same(list(interrupted.step(action)[:4]), list(reference.step(action)[:4]))
    np.testing.assert_array_equal(env.state["key"], reference.unwrapped.state["key"])
    for vector in (interrupted, reference):
        vector.close()


@pytest.mark.parametrize(
    ("env_id", "intervals"), [("vegym/Aircraft-v0", (2.0, 5.0)), ("vegym/PendulumPump-v0", (0.1, 0.25))]
)
def test_a_split_step_hands_out_the_demand_changes_as_the_one_thread_step_does(
    env_id: str, intervals: tuple[float, float]
) -> None:
    """The step kernel hands them out as its last work, so each chunk does its rows' (every 2 to 5 steps here); the
    info's copies of the state come after them."""
    envs = []
    for helpers in (1, 0):
        env = gym.make_vec(
            env_id, num_envs=SPLIT_ENVS, vectorization_mode="vector_entry_point",
            change_interval_min=intervals[0], change_interval_max=intervals[1],
        )  # fmt: skip
        env.unwrapped._split_helpers = helpers
        envs.append(env)
    split_outputs, single_outputs = _rollout(envs[0], 30), _rollout(envs[1], 30)
    assert isinstance(envs[0].unwrapped._split, SplitKernel)
    assert envs[0].unwrapped.state["changes"].min() >= 4
    _assert_same(split_outputs, single_outputs)
    for env in envs:
        env.close()


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


ACTION_KINDS: dict[str, Callable[[np.ndarray], object]] = {
    "float32": np.ascontiguousarray,
    "float64": lambda action: action.astype(np.float64),
    "list": lambda action: action.tolist(),
    "read-only float32": lambda action: _read_only(action.copy()),
    "strided float32": lambda action: np.repeat(action, 2, axis=0)[::2],
    "flat float32": lambda action: action.reshape(-1) if action.shape[1] == 1 else action,
    "within the tolerance outside": lambda action: np.where(action > 0.5, np.float32(1.0000005), action),
}
"""Kinds of actions: those a split step converts in its chunks (``CONVERTED_IN_CHUNKS``) and others, which the
calling thread loads first."""
CONVERTED_IN_CHUNKS = {"float32", "flat float32", "within the tolerance outside"}
"""C-contiguous, aligned, writeable float32 arrays of the actions' shape (``(num_envs,)`` for one number each),
within ``ACTION_TOLERANCE`` of [-1, 1]."""


@pytest.mark.parametrize("env_id", ["vegym/Aircraft-v0", "vegym/PendulumPump-v0"])
def test_a_split_step_takes_every_kind_of_actions_as_the_one_thread_step_does_and_keeps_its_split(env_id: str) -> None:
    split, single = _vector_env(env_id, 1), _vector_env(env_id, 0)
    rng = np.random.default_rng(1)
    for env in (split, single):
        env.reset(seed=2)
    made = None
    for kind in [*ACTION_KINDS, *reversed(ACTION_KINDS)]:  # each kind after another one
        action = rng.uniform(-1, 1, split.action_space.shape).astype(np.float32)
        _assert_same(split.step(ACTION_KINDS[kind](action))[:4], single.step(ACTION_KINDS[kind](action))[:4])
        made = made or split.unwrapped._split
        assert split.unwrapped._split is made, f"{kind} actions made a new split"
        assert split.unwrapped._load_flag[0] == (kind in CONVERTED_IN_CHUNKS), kind
    split.close()
    single.close()


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1.5])
def test_a_bad_action_in_a_split_step_raises_before_any_row_steps(bad: float) -> None:
    split, single = _vector_env("vegym/Aircraft-v0", 1), _vector_env("vegym/Aircraft-v0", 0)
    action = np.zeros(split.action_space.shape, np.float32)
    for env in (split, single):
        env.reset(seed=2)
        env.step(action)
    before = copy.deepcopy(split.unwrapped.state)
    wrong = action.copy()
    wrong[-1, -1] = bad
    with pytest.raises(ValueError, match="NaN or inf" if bad != 1.5 else "outside the action space"):
        split.step(wrong)
    for name, value in split.unwrapped.state.items():
        np.testing.assert_array_equal(value, before[name], err_msg=name)
    _assert_same(split.step(action)[:4], single.step(action)[:4])
    split.close()
    single.close()


SOME_ROWS_RESTARTS = ["vegym/BouncingBall-v0", "vegym/ProjectileAdjust-v0", "vegym/SteerableWheel-v0"]
"""The envs whose restart kernel takes some rows: a split step's chunks restart their own (``CHUNK_RESTARTS``), or,
for a task with episode constants, the split runs it over parts of them after the step."""
EVERY_ROW_RESTARTS = ["vegym/Billiards-v0", "vegym/Projectile-v0"]
"""The envs whose restart kernel takes every row only, which a split step runs over chunks of rows."""


def _stepped(env_id: str, num_envs: int, helpers: int) -> gym.vector.VectorEnv:
    """The vector env of ``env_id`` (``num_envs`` sub-envs whose steps use ``helpers`` helper threads), one step
    taken."""
    env = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point")
    env.unwrapped._split_helpers = helpers
    env.reset(seed=5)
    env.step(env.action_space.sample())
    return env


def test_the_envs_whose_restarts_a_split_step_runs_are_those_listed() -> None:
    """So that the tests below cover every restart kernel a split step runs."""
    some, every = [], []
    for env_id in ENV_IDS:
        env = _stepped(env_id, 30, 0)
        unwrapped, obs = env.unwrapped, np.empty(env.observation_space.shape, np.float32)
        if unwrapped.task.restart_call(unwrapped.state, np.arange(0, 30, 3), obs) is not None:
            some.append(env_id)
        elif unwrapped.task.restart_call(unwrapped.state, np.arange(30), obs) is not None:
            every.append(env_id)
        env.close()
    assert (some, every) == (SOME_ROWS_RESTARTS, EVERY_ROW_RESTARTS)


@pytest.mark.parametrize("env_id", SOME_ROWS_RESTARTS)
def test_a_restart_kernel_of_some_rows_writes_those_rows_only(env_id: str) -> None:
    """What lets a split step run it over parts of the rows at once (``VegymVectorEnv._restart_rows``)."""
    env = _stepped(env_id, 30, 0)
    rows, others = np.arange(0, 30, 3), np.setdiff1d(np.arange(30), np.arange(0, 30, 3))
    state = env.unwrapped.state
    before = {name: value.copy() for name, value in state.items()}
    obs = np.full(env.observation_space.shape, np.nan, np.float32)
    kernel, args = env.unwrapped.task.restart_call(state, rows, obs)
    kernel(*args)
    assert not np.isnan(obs[rows]).any()
    assert np.isnan(obs[others]).all()
    for name, value in state.items():
        np.testing.assert_array_equal(value[others], before[name][others], err_msg=name)
    env.close()


@pytest.mark.parametrize("alone", [False, True], ids=["over threads", "alone"])
@pytest.mark.parametrize("env_id", ["vegym/ProjectileAdjust-v0", *EVERY_ROW_RESTARTS])
def test_a_split_restart_gives_the_one_thread_restart_bit_for_bit(
    env_id: str, alone: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Of some rows (every third) where the task's restart kernel takes some rows, else of every row; split over
    threads or run by the split in the calling thread alone. The split runs restarts of some rows only where its
    chunks do not restart their own (``CHUNK_RESTARTS``): for a task with episode constants, as ProjectileAdjust is
    made here."""
    if alone:
        _run_alone(monkeypatch)
    monkeypatch.setattr(ProjectileAdjustTask, "episode_constants", ProjectileTask.episode_constants)
    env = _stepped(env_id, SPLIT_ENVS, 1)
    unwrapped, task = env.unwrapped, env.unwrapped.task
    if env_id in SOME_ROWS_RESTARTS:
        assert unwrapped._split_restarts == "some" and not unwrapped._chunk_restarts
        rows, call_rows = np.arange(0, SPLIT_ENVS, 3), np.arange(0, SPLIT_ENVS, 3)
        assert len(rows) >= vegym.envs.base.SPLIT_RESTART_ROWS
        restart = unwrapped._restart_rows
    else:
        assert unwrapped._split_restarts == "every"
        rows, call_rows = np.arange(SPLIT_ENVS), unwrapped._chunk_rows
        restart = lambda state, _, obs: unwrapped._restart_every_row(state, obs)  # noqa: E731
    states = [{name: value.copy() for name, value in unwrapped.state.items()} for _ in range(2)]
    obs = [np.zeros(env.observation_space.shape, np.float32) for _ in range(2)]
    assert unwrapped._split.fits(*task.restart_call(states[0], call_rows, obs[0]), job=1)
    jobs = _posted_jobs(unwrapped._split)
    restart(states[0], rows, obs[0])
    assert _posted_jobs(unwrapped._split) == jobs + (not alone)
    task.restart(states[1], rows, obs[1])
    np.testing.assert_array_equal(obs[0], obs[1])
    for name in states[0]:
        np.testing.assert_array_equal(states[0][name], states[1][name], err_msg=name)
    env.close()


def test_closing_the_env_stops_its_helpers_and_dropping_it_does_too() -> None:
    before = len(_helpers())
    env = _vector_env("vegym/Aircraft-v0", 1)
    _rollout(env, 3)
    assert len(_helpers()) == before + 1
    env.close()
    assert len(_helpers()) == before
    env = _vector_env("vegym/Aircraft-v0", 1)
    _rollout(env, 3)
    assert len(_helpers()) == before + 1
    del env
    gc.collect()
    assert len(_helpers()) == before


def test_a_deep_copy_and_an_unpickled_copy_of_a_split_env_step_as_it_does() -> None:
    env = _vector_env("vegym/SteerableWheel-v0", 1)
    _rollout(env, 5)
    copies = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    actions = np.random.default_rng(1).uniform(-1, 1, (6, *env.action_space.shape)).astype(np.float32)
    results = [[other.step(action)[:4] for action in actions] for other in (env, *copies)]
    for other in results[1:]:
        for steps, reference in zip(other, results[0], strict=True):
            for a, b in zip(steps, reference, strict=True):
                np.testing.assert_array_equal(a, b)
    for other in (env, *copies):
        other.close()


def _child_rollout(env: gym.vector.VectorEnv, queue: multiprocessing.Queue) -> None:
    queue.put(_rollout(env, 8, seed=9))


def test_a_forked_child_steps_a_split_env_with_helpers_of_its_own() -> None:
    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork on this platform")
    env = _vector_env("vegym/Projectile-v0", 1)
    _rollout(env, 3)
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_child_rollout, args=(env, queue))
    child.start()
    outputs = queue.get(timeout=120)
    child.join(timeout=60)
    assert child.exitcode == 0
    _assert_same(outputs, _rollout(env, 8, seed=9))
    env.close()


@njit(cache=True, nogil=True)
def _divide(numerators: np.ndarray, denominators: np.ndarray, scale: float, out: np.ndarray) -> bool:
    """``out = scale * numerators // denominators`` (int64, ZeroDivisionError on a zero); true where any is odd (a
    result that the split does not keep)."""
    odd = False
    for i in range(len(out)):
        out[i] = scale * numerators[i] // denominators[i]
        odd |= out[i] % 2 == 1
    return odd


def _divide_arguments(n: int = 10_001) -> tuple:
    rng = np.random.default_rng(0)
    return rng.integers(0, 1000, n), rng.integers(1, 9, n), 2.0, np.zeros(n)


@pytest.mark.parametrize("helpers", [1, 3])
def test_a_split_kernel_writes_what_the_kernel_does_and_returns_nothing(helpers: int) -> None:
    args, reference = _divide_arguments(), _divide_arguments()
    split = SplitKernel(_divide, args, [True, True, False, True], helpers)
    for seed in range(3):
        numerators = np.random.default_rng(seed).integers(0, 1000, len(args[0]))
        for arrays in (args, reference):
            arrays[0][:] = numerators
        assert split.fits(_divide, args)
        assert split(args) is None
        _divide(*reference)
        np.testing.assert_array_equal(args[3], reference[3])
    split.close()
    args[3][:] = 0.0
    assert split(args) is None  # closed: every chunk in the calling thread
    np.testing.assert_array_equal(args[3], reference[3])


@njit(cache=True, nogil=True)
def _add(values: np.ndarray, amount: float, out: np.ndarray) -> None:
    """``out = values + amount``, row by row."""
    for i in range(len(out)):
        out[i] = values[i] + amount


@pytest.mark.parametrize("alone", [False, True], ids=["over threads", "alone"])
def test_each_chunk_makes_the_before_call_then_the_kernel_then_the_after_call(
    alone: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each call reads what the one before wrote: ``numerators = source + 1``, the kernel, ``last = out + 0.5``."""
    if alone:
        _run_alone(monkeypatch)
    args = _divide_arguments()
    source, last = args[0] - 1, np.zeros(len(args[0]))
    before, after = (
        (_add, (source, 1.0, args[0]), [True, False, True]),
        (_add, (args[3], 0.5, last), [True, False, True]),
    )
    split = SplitKernel(_divide, args, [True, True, False, True], 1, before=before, after=[after])
    call = (*before[1], *args, *after[1])
    assert split.fits(_divide, call) and not split.fits(_divide, args)
    args[0][:] = -1
    split(call)
    expected = _divide_arguments()
    _divide(*expected)
    np.testing.assert_array_equal(last, expected[3] + 0.5)
    assert (_posted_jobs(split) == 0) == alone
    split.close()


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 23, 4096, 8195])
@pytest.mark.parametrize("share", [0.0, 0.004, 0.3, 1.0])
@pytest.mark.parametrize("offset", [0, 3])
def test_flagged_rows_are_the_set_flags_in_ascending_order(n: int, share: float, offset: int) -> None:
    """Read a word of eight flags at a time, from the first word boundary: a row set in a word's first or last place,
    before the first boundary and past the last whole word, masks of every row or none, and a chunk's part of the
    flags that starts off a boundary (``offset``)."""
    flags = (np.random.default_rng(n).random(n + offset) < share)[offset:]
    flags[[k for k in (0, 7, 8, n - 1) if 0 <= k < n and share > 0.0]] = True
    rows = kernel_split.flagged_rows(flags)
    assert rows.dtype == np.intp
    np.testing.assert_array_equal(rows, np.flatnonzero(flags))


@njit(cache=True, nogil=True)
def _copy_rows(rows: np.ndarray, values: np.ndarray, out: np.ndarray) -> None:
    """``out[rows] = values[rows]``."""
    for r in rows:
        out[r] = values[r]


@pytest.mark.parametrize("alone", [False, True], ids=["over threads", "alone"])
@pytest.mark.parametrize("helpers", [1, 3])
def test_a_flagged_argument_reaches_the_kernel_as_the_indices_of_its_chunks_set_rows(
    helpers: int, alone: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each chunk passes the rows set in its part of the flags, as indices into its parts of the other batch
    arrays: every flagged row (in each chunk, the first and last rows of the batch among them) and only those is
    written, from its own row."""
    if alone:
        _run_alone(monkeypatch)
    args = _divide_arguments()
    n = len(args[0])
    flags = np.random.default_rng(1).random(n) < 0.01
    flags[[0, n // 2, n - 1]] = True
    rows, out = np.arange(n, dtype=np.float64), np.full(n, -1.0)
    after = (_copy_rows, (flags, rows, out), [kernel_split.FLAGGED, True, True])
    split = SplitKernel(_divide, args, [True, True, False, True], helpers, after=[after])
    split((*args, *after[1]))
    np.testing.assert_array_equal(out, np.where(flags, rows, -1.0))
    assert (_posted_jobs(split) == 0) == alone
    split.close()


def test_an_interrupt_raised_as_the_calling_threads_chunk_returns_waits_for_the_helpers_chunks() -> None:
    """Python raises a Ctrl-C that came during the compiled call as the call returns, before ``then``: the helpers'
    chunks were not waited for, and a step made after it (in a notebook, say) could count a helper's late chunk of
    the interrupted job as one of its own and return before its rows were written. The calling thread's chunk is
    made small here, so that the helper's is still running as the call returns (a split's first call runs split)."""
    args = _divide_arguments(4_000_001)
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    split.cut = 1
    job = split.jobs[0]
    call = job.call

    def interrupted_as_it_returns(*call_args: object) -> object:
        call(*call_args)
        raise KeyboardInterrupt

    job.call = interrupted_as_it_returns
    with pytest.raises(KeyboardInterrupt):
        split(args, then=lambda: None)
    assert _posted_jobs(split) == 1 and split.control[kernel_split._FINISHED] == split.chunks
    split.close()


def test_then_runs_after_the_calling_threads_chunk_and_its_result_is_returned() -> None:
    args, reference = _divide_arguments(), _divide_arguments()
    _divide(*reference)
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    seen = []
    for _ in range(20):
        args[3][:] = -1.0
        assert split(args, then=lambda: seen.append(split.control[kernel_split._FINISHED]) or "info") == "info"
        np.testing.assert_array_equal(args[3], reference[3])
    assert len(seen) == 20 and all(0 < finished <= split.chunks for finished in seen)  # its own chunk done at least
    split.close()


def test_an_error_in_then_is_raised_after_the_helpers_chunks_and_the_split_goes_on() -> None:
    args, reference = _divide_arguments(), _divide_arguments()
    _divide(*reference)
    split = SplitKernel(_divide, args, [True, True, False, True], 1)

    def failing() -> None:
        raise KeyboardInterrupt

    args[3][:] = -1.0
    with pytest.raises(KeyboardInterrupt):
        split(args, then=failing)
    assert split.control[kernel_split._FINISHED] == split.chunks  # waited for: no helper writes on after it
    np.testing.assert_array_equal(args[3], reference[3])
    args[3][:] = -1.0
    split(args)
    np.testing.assert_array_equal(args[3], reference[3])
    split.close()


def test_the_first_chunk_shrinks_while_then_makes_the_calling_thread_the_slower_within_its_bounds() -> None:
    """A slow ``then`` (2 ms, far longer than a helper's chunk): the helpers are done first (but for a helper held up
    by a loaded host), so the first chunk loses rows call by call down to its fewest; calls without ``then`` leave
    it."""
    args = _divide_arguments()
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    even = split.cut
    for _ in range(5):
        split(args)
    assert split.cut == even == len(args[0]) // 2
    fewest, _, step = split._cuts
    cuts = []
    for _ in range(2 * (even - fewest) // step):
        split(args, then=lambda: time.sleep(2e-3))
        cuts.append(split.cut)
    assert min(cuts) >= fewest and cuts[-1] == fewest
    split.close()


@pytest.mark.parametrize("helpers", [1, 3])
def test_each_chunk_copies_its_rows_of_the_arrays_named_in_copies_after_its_kernel(helpers: int) -> None:
    args, reference = _divide_arguments(), _divide_arguments()
    _divide(*reference)
    numerators, out = np.empty_like(args[0]), np.full_like(args[3], np.nan)
    split = SplitKernel(_divide, (*args, out, numerators), [True, True, False, True, True, True], helpers, (3, 0))
    split((*args, out, numerators))
    np.testing.assert_array_equal(out, reference[3])  # the kernel's output, every row
    np.testing.assert_array_equal(numerators, reference[0])
    split.close()


@pytest.mark.parametrize(
    ("copies", "destinations", "message"),
    [
        ((2,), (np.zeros(10_001),), "argument 2 is not a batch argument"),
        ((4,), (np.zeros(10_001),), "argument 4 is not a batch argument"),
        ((3,), (np.zeros(10_001, np.float32),), "argument 4, argument 3's copy, is not a writeable batch array"),
        ((3,), (_read_only(np.zeros(10_001)),), "argument 4, argument 3's copy, is not a writeable batch array"),
    ],
)
def test_copies_of_non_batch_arguments_or_into_mismatched_or_read_only_arrays_are_refused(
    copies: tuple[int, ...], destinations: tuple[np.ndarray, ...], message: str
) -> None:
    with pytest.raises(TypeError, match=message):
        SplitKernel(_divide, (*_divide_arguments(), *destinations), [True, True, False, True, True], 1, copies)


def test_a_split_steps_info_reports_the_step_count_after_the_step_as_one_thread_does() -> None:
    """``step`` is counted after the kernel, so the chunks do not copy it for the info, which the calling thread then
    builds after the helpers' chunks (it copies ``step`` itself)."""
    counts = []
    for helpers in (1, 0):
        env = _vector_env("vegym/Aircraft-v0", helpers)
        task = env.unwrapped.task
        task.info = lambda state, out, info=task.info: {**info(state, out), "elapsed": state["step"]}
        env.reset(seed=0)
        action = np.zeros(env.action_space.shape, np.float32)
        counts.append([env.step(action)[4]["elapsed"][:3].tolist() for _ in range(3)])
        assert (env.unwrapped._split is not None) == (helpers == 1)
        assert not env.unwrapped._info_overlaps
        env.close()
    assert counts[0] == counts[1] == [[1, 1, 1], [2, 2, 2], [3, 3, 3]]


@pytest.mark.parametrize("declared", [True, False], ids=["episode constants", "plain state"])
@pytest.mark.parametrize("helpers", [1, 0], ids=["split", "one thread"])
def test_a_steps_info_shows_the_episode_constants_it_stepped_with_though_rows_restart_after_it(
    helpers: int, declared: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Declared as episode constants, the step renews them right after its info took views of them (a split step
    while the helper runs its chunk), the restarts then write into the new arrays and the info keeps the old ones;
    as plain state (ProjectileAdjust's, registered), the info takes copies of them that each chunk makes right
    after its step, before it restarts its rows. Either way the info keeps the values stepped with, the restarted
    rows' too."""
    names = ProjectileTask.episode_constants
    monkeypatch.setattr(ProjectileAdjustTask, "episode_constants", names if declared else ())
    env = _vector_env("vegym/ProjectileAdjust-v0", helpers)
    env.reset(seed=1)
    actions = np.random.default_rng(1).uniform(-1, 1, (6, *env.action_space.shape)).astype(np.float32)
    restarts = 0
    for action in actions:
        before = {name: env.unwrapped.state[name].copy() for name in names}
        info = env.step(action)[4]
        restarted = ~info["_target"]  # the rows that ended on the step before start a new episode now
        restarts += restarted.sum()
        for name in names:
            np.testing.assert_array_equal(info[name], before[name])
        assert np.all(np.any(env.unwrapped.state["target"][restarted] != before["target"][restarted], axis=1))
    assert restarts > SPLIT_ENVS  # every episode ends within max_shots = 3 steps
    assert env.unwrapped._info_overlaps == (helpers == 1)
    assert env.unwrapped._chunk_restarts == (helpers == 1 and not declared)
    env.close()


@pytest.mark.parametrize("zero_at", [0, -1])
def test_a_kernel_error_in_any_chunk_is_raised_and_stops_the_helpers(zero_at: int) -> None:
    before = len(_helpers())
    args = _divide_arguments()
    args[1][zero_at] = 0
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    assert len(_helpers()) == before + 1
    with pytest.raises(ZeroDivisionError):
        split(args)
    assert len(_helpers()) == before


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="a helper runs beside the calling thread on two cores only")
def test_a_helpers_kernel_error_is_raised_by_the_calling_thread() -> None:
    """Which thread takes the last chunk is a race; calls right after a warm-up, while the helper spins, on a
    million rows (the calling thread's chunk takes about a millisecond, even on a loaded machine a helper has that
    long to take the other), let it take that chunk often enough for a few tries to see one."""
    for _ in range(40):
        good, bad = _divide_arguments(1_000_001), _divide_arguments(1_000_001)
        bad[1][-1] = 0
        split = SplitKernel(_divide, good, [True, True, False, True], 1)
        split(good)
        with pytest.raises(ZeroDivisionError) as raised:
            split(bad)
        if split.errors:
            assert raised.value is split.errors[0]
            return
    pytest.fail("no helper took the last chunk in 40 tries")


def test_closing_during_calls_from_another_thread_lets_them_finish_right() -> None:
    before = len(_helpers())
    args, reference = _divide_arguments(), _divide_arguments()
    _divide(*reference)
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    results: list[bool] = []

    def calls() -> None:
        for _ in range(300):
            args[3][:] = -1.0
            split(args)
            results.append(np.array_equal(args[3], reference[3]))

    caller = threading.Thread(target=calls)
    caller.start()
    time.sleep(0.01)
    split.close()
    caller.join(timeout=60)
    assert not caller.is_alive()
    assert len(results) == 300 and all(results)
    assert len(_helpers()) == before


def test_a_helper_thread_that_cannot_start_leaves_no_thread_behind(monkeypatch: pytest.MonkeyPatch) -> None:
    before = len(_helpers())
    started = []
    start = threading.Thread.start

    def start_once(thread: threading.Thread) -> None:
        if started:
            raise RuntimeError("can't start new thread")
        started.append(thread)
        start(thread)

    monkeypatch.setattr(threading.Thread, "start", start_once)
    with pytest.raises(ValueError, match="can't start new thread"):
        SplitKernel(_divide, _divide_arguments(), [True, True, False, True], 2)
    monkeypatch.undo()
    assert len(_helpers()) == before


def test_an_env_steps_in_one_thread_after_close_and_an_unpickled_copy_counts_its_own_threads(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    before = len(_helpers())
    env = _vector_env("vegym/Aircraft-v0", 1)
    _rollout(env, 2)
    env.close()
    env.step(env.action_space.sample())
    assert env.unwrapped._split is None and len(_helpers()) == before
    fresh = _vector_env("vegym/Aircraft-v0", 1)
    monkeypatch.setenv("VEGYM_NUM_THREADS", "1")
    assert pickle.loads(pickle.dumps(fresh)).unwrapped._split_helpers == 0
    monkeypatch.setenv("VEGYM_NUM_THREADS", "2")
    assert pickle.loads(pickle.dumps(fresh)).unwrapped._split_helpers == 1


def test_vegym_num_threads_sets_the_helpers_and_a_bad_value_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    make = functools.partial(gym.make_vec, "vegym/Aircraft-v0", vectorization_mode="vector_entry_point")
    monkeypatch.setenv("VEGYM_NUM_THREADS", "1")
    assert make(num_envs=4 * SPLIT_MIN_ROWS).unwrapped._split_helpers == 0
    monkeypatch.setenv("VEGYM_NUM_THREADS", "3")
    assert make(num_envs=4 * SPLIT_MIN_ROWS).unwrapped._split_helpers == 2
    assert make(num_envs=2 * SPLIT_MIN_ROWS - 1).unwrapped._split_helpers == 0
    for bad in ("0", "two", "-1", ""):
        monkeypatch.setenv("VEGYM_NUM_THREADS", bad)
        with pytest.raises(ValueError, match="VEGYM_NUM_THREADS"):
            make(num_envs=4)


def test_calls_of_other_types_or_scalars_do_not_fit_the_split() -> None:
    args = _divide_arguments()
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    assert split.control.ctypes.data % 64 == 0  # the counters' cache lines are their own
    assert split.fits(_divide, args)
    assert not split.fits(_divide, (args[0].astype(np.int32), *args[1:]))
    assert not split.fits(_divide, (*args[:2], 3.0, args[3]))
    assert not split.fits(_divide, (args[0][::2], *args[1:]))
    zero = SplitKernel(_divide, (*args[:2], 0.0, args[3]), [True, True, False, True], 1)
    assert not zero.fits(_divide, (*args[:2], -0.0, args[3]))  # equal, but not the same number
    split.close()
    zero.close()


def test_a_row_array_passed_whole_cannot_be_split() -> None:
    """Every chunk would write all of it at once: an argument as long as the split ones must be split too."""
    with pytest.raises(ValueError, match="as many rows"):
        SplitKernel(_divide, _divide_arguments(), [True, False, False, True], 1)


def test_a_second_call_without_one_length_of_split_arguments_is_left_out() -> None:
    args = _divide_arguments()
    for marks in ([False, False, False, False], [True, True, False, False]):  # none; rows of two lengths
        second_args = (args[0], args[1][:-1], args[2], args[3]) if any(marks) else args
        split = SplitKernel(_divide, args, [True, True, False, True], 1, second=(_divide, second_args, marks))
        assert split.fits(_divide, args)
        assert not split.fits(_divide, second_args, job=1)
        split.close()


def test_a_kernel_that_is_not_cached_on_disk_cannot_be_split() -> None:
    @njit
    def local(values: np.ndarray) -> None:
        values += 1.0

    with pytest.raises(ValueError, match="cannot be split"):
        SplitKernel(local, (np.zeros(10),), [True], 1)


def test_job_numbers_wrap_around_without_stopping_the_helpers() -> None:
    args, reference = _divide_arguments(), _divide_arguments()
    split = SplitKernel(_divide, args, [True, True, False, True], 1)
    split.control[kernel_split._TICKET] = kernel_split._JOB_MASK << 32 | split.chunks  # the last job number, done
    _divide(*reference)
    for _ in range(3):
        args[3][:] = -1.0
        split(args)
        np.testing.assert_array_equal(args[3], reference[3])
        assert split.control[kernel_split._TICKET] >= 0
    assert len(_helpers()) >= 1
    split.close()


def _idle_sleeps(job: int, state: tuple[int, int, int], rounds: int) -> tuple[list[int], tuple[int, int, int]]:
    """The sleeps (us, 0 for a spin round) of ``rounds`` idle rounds of a helper with 3 spin rounds and naps of
    50 to 400 us, from ``state`` (seen, idle, nap) while job ``job`` is current; and the state after them."""
    sleeps = []
    for _ in range(rounds):
        *state, sleep = kernel_split._idle_round(job, *state, 3, (0, 50, 400))
        sleeps.append(sleep)
    return sleeps, tuple(state)


def test_an_idle_helper_spins_then_naps_ever_longer_and_spins_again_once_a_job_is_posted() -> None:
    sleeps, state = _idle_sleeps(7, (7, 0, 50), 8)
    assert sleeps == [0, 0, 0, 50, 100, 200, 400, 400]
    # job 8 was posted while the helper napped, and the calling thread took its chunks: the next job likely
    # comes as soon, so the helper spins again rather than nap 400 us
    sleeps, state = _idle_sleeps(8, state, 5)
    assert sleeps == [0, 0, 0, 50, 100]
    assert _idle_sleeps(0, state, 1)[0] == [0]  # a job number that wrapped around is a new job too


def test_the_spin_lasts_spin_s_at_the_fastest_of_the_timed_rates(monkeypatch: pytest.MonkeyPatch) -> None:
    """Five timed runs of 4,096 rounds, the fastest counted: 4,096 rounds in 40 us spin ``SPIN_S`` (0.2 ms) in
    20,480 rounds; a slower run (the host took the core) does not shorten the spin."""
    run_times = [60e-6, 40e-6, 90e-6, 41e-6, 45e-6]
    readings = iter([t for k, run in enumerate(run_times) for t in (float(k), k + run)])  # each run's start, end
    monkeypatch.setattr(kernel_split.time, "perf_counter", lambda: next(readings))
    kernel_split.spin_rounds.cache_clear()
    try:
        assert kernel_split.spin_rounds() == math.ceil(kernel_split.SPIN_S * 4096 / 40e-6) == 20_480
    finally:
        monkeypatch.undo()
        kernel_split.spin_rounds.cache_clear()
    rounds = kernel_split.spin_rounds()
    assert rounds == kernel_split.spin_rounds() >= 1  # timed once per process


def _run(
    chooser: kernel_split.ModeChooser, cost: Callable[[bool, float], float], seconds: float, start: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Calls for ``seconds`` from ``start``, each taking ``cost(alone, now)`` seconds to the next call's start, run
    the way ``chooser`` chooses: the start times and whether each ran alone."""
    now, starts, ways = start, [], []
    while now < start + seconds:
        starts.append(now)
        ways.append(chooser.choose(now))
        now += cost(ways[-1], now)
    return np.array(starts), np.array(ways)


def _trials(ways: np.ndarray) -> list[tuple[int, int]]:
    """The (first, last + 1) calls of each run of calls the way the first call did not go."""
    changes = np.flatnonzero(np.diff(ways.astype(int))) + 1
    bounds = [*changes, len(ways)] if len(changes) % 2 else list(changes)
    return list(zip(bounds[::2], bounds[1::2], strict=True))


def test_the_chooser_keeps_splitting_while_a_trial_alone_is_not_faster_by_its_margin_and_tries_less_often() -> None:
    """Alone 5% faster (the margin is 15%): trials after ``PROBE_INTERVAL_S`` of stepping, then twice as long after
    each (up to ``MAX_PROBE_INTERVAL_S``), each of the calls while the helpers settle (``SOLO_SETTLE_S``) and
    ``PROBE_CALLS`` timed ones, and each followed by a return to the split (whose first ``SPLIT_SETTLE_S`` are not
    timed, nor counted as stepping)."""
    starts, ways = _run(kernel_split.ModeChooser(), lambda alone, _: 190e-6 if alone else 200e-6, 20.0)
    assert not ways[0]
    trials = _trials(ways)
    settling = math.ceil(kernel_split.SOLO_SETTLE_S / 190e-6)
    assert [stop - first for first, stop in trials] == [settling + kernel_split.PROBE_CALLS] * len(trials)
    ends = [0.0] + [starts[stop] + kernel_split.SPLIT_SETTLE_S for _, stop in trials[:-1]]
    waits = [starts[first] - end for (first, _), end in zip(trials, ends, strict=True)]
    intervals = [min(0.5 * 2**k, kernel_split.MAX_PROBE_INTERVAL_S) for k in range(len(trials))]
    assert intervals[:5] == [0.5, 1.0, 2.0, 4.0, 4.0] and len(trials) == 7  # 0.5 + 1 + 2 + 4 * 4 = 19.5 s
    # a trial starts at the first fresh set of PROBE_CALLS timed calls once the interval is stepped
    assert all(
        0.0 <= wait - interval <= (kernel_split.PROBE_CALLS + 2) * 200e-6
        for wait, interval in zip(waits, intervals, strict=True)
    )


def test_the_chooser_runs_alone_where_that_is_faster_and_splits_again_once_a_split_trial_is() -> None:
    chooser = kernel_split.ModeChooser()
    starts, ways = _run(chooser, lambda alone, _: 350e-6 if alone else 500e-6, 3.0)  # a slow phase of the split
    moved = starts[np.argmax(ways)]
    assert kernel_split.PROBE_INTERVAL_S <= moved < kernel_split.PROBE_INTERVAL_S + 0.01
    assert ways[starts > moved + 0.01].mean() > 0.95  # alone but for the split's trials
    starts, ways = _run(chooser, lambda alone, _: 350e-6 if alone else 220e-6, 10.0, start=3.0)  # alone as before
    back = starts[np.argmin(ways)]  # alone, the split is tried after every PROBE_INTERVAL_S of stepping
    assert back < 3.0 + kernel_split.PROBE_INTERVAL_S + kernel_split.SOLO_SETTLE_S + 0.05
    assert (~ways[starts > back + kernel_split.SPLIT_SETTLE_S + 0.01]).mean() > 0.99


def test_the_chooser_takes_the_split_back_where_it_is_faster_at_all_but_leaves_it_only_by_the_margin() -> None:
    chooser = kernel_split.ModeChooser()
    assert _run(chooser, lambda alone, _: 350e-6 if alone else 500e-6, 3.0)[1][-1]
    starts, ways = _run(chooser, lambda alone, _: 350e-6 if alone else 330e-6, 10.0, start=3.0)  # split 6% faster
    back = starts[np.argmin(ways)]
    assert back < 3.0 + kernel_split.PROBE_INTERVAL_S + kernel_split.SOLO_SETTLE_S + 0.05
    assert (~ways[starts > back + kernel_split.SPLIT_SETTLE_S + 0.01]).mean() > 0.99


def test_pauses_between_bursts_of_calls_do_not_count_as_stepping() -> None:
    """Bursts of 32 calls 1 s apart: the one trial comes after ``PROBE_INTERVAL_S`` of stepping (31 intervals of
    200 us a burst: in the 81st), not at the first burst after the first pause."""
    chooser, now, ways = kernel_split.ModeChooser(), 0.0, []
    for _ in range(100):
        for _ in range(32):
            ways.append(chooser.choose(now))
            now += 190e-6 if ways[-1] else 200e-6
        now += 1.0
    trials = _trials(np.array(ways))
    assert len(trials) == 1 and 80 * 32 <= trials[0][0] < 82 * 32
    assert not chooser.solo


def test_a_trials_calls_before_the_helpers_settle_into_it_are_not_counted() -> None:
    """A split trial's first calls may find the helpers napping (up to ``MAX_NAP_US``), slower than alone: only the
    later ones count."""
    chooser = kernel_split.ModeChooser()
    _run(chooser, lambda alone, _: 350e-6 if alone else 500e-6, 3.0)
    assert chooser.solo
    trial_start: list[float] = []

    def cost(alone: bool, now: float) -> float:
        if alone:
            trial_start.clear()
            return 350e-6
        trial_start[:] = trial_start or [now]
        return 400e-6 if now < trial_start[0] + 1e-6 * kernel_split.MAX_NAP_US else 200e-6  # napping, then not

    _, ways = _run(chooser, cost, 10.0, start=3.0)
    assert not ways[-1]
