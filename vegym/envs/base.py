"""The one dynamics implementation behind every vegym env, and its single and native-vector front ends.

A :class:`Task` is the whole env logic as pure functions over *batches*: ``initial_state(keys)``,
``step(state, action)`` and ``observe(state)``, where a state is a dict of numpy arrays with a leading
batch axis. :class:`VegymEnv` runs a task with a batch of one; :class:`VegymVectorEnv` runs it with
``num_envs`` and Gymnasium's NEXT_STEP autoreset. All randomness is counter-based on per-episode keys
(:mod:`vegym.rng`), so sub-env ``i`` of a vector env reset with ``seed=s`` follows exactly the single env
reset with ``seed=s + i``, step for step, whatever the other sub-envs do.
"""

from __future__ import annotations

import abc
import importlib
import math
from collections.abc import Mapping
from typing import Any, ClassVar, Generic, NamedTuple, TypeVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from vegym import rng
from vegym.params import Params

P = TypeVar("P", bound=Params)
State = dict[str, np.ndarray]
Info = dict[str, Any]

ACTION_TOLERANCE = 1e-6
"""Actions may exceed [-1, 1] by this much (float32 round-off) and are then clipped; more is an error."""


class Transition(NamedTuple):
    """The batched result of one task step."""

    state: State
    reward: np.ndarray
    terminated: np.ndarray
    info: Info


class Task(abc.ABC, Generic[P]):
    """Batched task logic over frozen parameters: observation, action mapping, reward, termination.

    Subclasses set ``params_cls``, build ``observation_space`` and ``action_space`` (single-env spaces) in
    ``__init__``, and implement the three pure methods below. ``state`` dicts always carry ``key`` (uint64
    episode keys) and ``step`` (steps taken in the episode), maintained by the front ends.
    """

    params_cls: ClassVar[type[Params]]
    renderer: ClassVar[str] = ""
    """``"module:Class"`` of the renderer, imported only when a render mode is asked for."""

    observation_space: spaces.Box
    action_space: spaces.Box

    def __init__(self, params: P) -> None:
        self.params = params

    @property
    @abc.abstractmethod
    def control_rate(self) -> float:
        """Steps per simulated second (the render frame rate)."""

    @abc.abstractmethod
    def initial_state(self, keys: np.ndarray) -> State:
        """Fresh episode states for the episode keys ``keys`` (n,), drawing randomness from them only."""

    @abc.abstractmethod
    def step(self, state: State, action: np.ndarray) -> Transition:
        """Advance every episode by one step with actions (n, action_dim) in [-1, 1]; pure."""

    @abc.abstractmethod
    def observe(self, state: State) -> np.ndarray:
        """Observations (n, obs_dim), float32, inside ``observation_space``."""


def first_of_batch(info: Info) -> Info:
    """Row 0 of every array of a batched (nested) info dict: Python scalars for 1-d arrays, copies otherwise."""
    out: Info = {}
    for k, v in info.items():
        if isinstance(v, dict):
            out[k] = first_of_batch(v)
        elif v.ndim == 1:
            out[k] = v.item(0)
        else:
            out[k] = v[0].copy()
    return out


def check_actions(action: Any, space: spaces.Box, batch_shape: tuple[int, ...]) -> np.ndarray:
    """Actions as a new float64 array of shape ``batch_shape + space.shape``; ValueError on NaN/inf or out of range.

    Values beyond [-1, 1] by at most ``ACTION_TOLERANCE`` are clipped to it.
    """
    a = np.array(action, dtype=np.float64)
    expected = batch_shape + space.shape
    if a.shape != expected:
        if a.size != math.prod(expected):
            raise ValueError(f"action has shape {a.shape}; expected {expected}")
        a = a.reshape(expected)
    bound = np.abs(a).max()  # NaN propagates, so one comparison rejects NaN, inf and out-of-range values
    if not bound <= 1.0 + ACTION_TOLERANCE:
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action contains NaN or inf: {np.asarray(action)!r}")
        raise ValueError(f"action {np.asarray(action)!r} is outside the action space [-1, 1]")
    if bound > 1.0:
        np.clip(a, -1.0, 1.0, out=a)
    return a


def load_object(path: str) -> Any:
    """Import ``"package.module:Name"``."""
    module, name = path.split(":")
    return getattr(importlib.import_module(module), name)


class VegymEnv(gym.Env[np.ndarray, np.ndarray], Generic[P]):
    """A Gymnasium env running a :class:`Task` on a batch of one.

    Subclasses set ``task_cls`` and a docstring; ``__init__(render_mode=None, **params)`` builds the frozen
    parameter dataclass, so every keyword lands in ``spec.kwargs`` and an unknown one raises ``TypeError``.
    """

    task_cls: ClassVar[type[Task]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 1}

    def __init__(self, render_mode: str | None = None, **params: Any) -> None:
        self.task = self.task_cls(self.task_cls.params_cls(**params))
        self.params: P = self.task.params  # type: ignore[assignment]
        self.metadata = {**type(self).metadata, "render_fps": self.task.control_rate}
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode={render_mode!r} is not one of {self.metadata['render_modes']}")
        self.render_mode = render_mode
        self.observation_space = self.task.observation_space
        self.action_space = self.task.action_space
        self.state: State | None = None
        self._renderer: Any = None
        self._window: Any = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, Info]:
        super().reset(seed=seed)
        if seed is not None:
            key = rng.seed_keys(np.array([seed]))
        elif self.state is None:
            key = self.np_random.integers(0, 2**64, size=1, dtype=np.uint64)
        else:
            key = rng.next_key(self.state["key"])
        self.state = {**self.task.initial_state(key), "key": key, "step": np.zeros(1, dtype=np.int64)}
        if self.render_mode is not None:
            self._get_renderer().reset(self.state)
            if self.render_mode == "human":
                self.render()
        return self.task.observe(self.state)[0], {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, Info]:
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() before step().")
        a = check_actions(action, self.action_space, (1,))
        transition = self.task.step(self.state, a)
        self.state = {**transition.state, "key": self.state["key"], "step": self.state["step"] + 1}
        info = first_of_batch(transition.info)
        if self.render_mode is not None:
            self._get_renderer().record(self.state, info)
            if self.render_mode == "human":
                self.render()
        obs = self.task.observe(self.state)[0]
        return obs, float(transition.reward[0]), bool(transition.terminated[0]), False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to make().")
            return None
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() before render().")
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

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_window"] = None
        return state


class VegymVectorEnv(VectorEnv, Generic[P]):
    """A native Gymnasium vector env running a :class:`Task` on ``num_envs`` episodes at once.

    NEXT_STEP autoreset: the step after a sub-env terminates or truncates resets it, returning its first
    observation with reward 0 and ``terminated = truncated = False``. Truncation comes from
    ``max_episode_steps`` (``make_vec`` passes the registered value).
    """

    task_cls: ClassVar[type[Task]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self, num_envs: int = 1, max_episode_steps: int | None = None, render_mode: str | None = None, **params: Any
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs={num_envs!r} is outside the allowed range [1, inf)")
        if max_episode_steps is not None and max_episode_steps < 1:
            raise ValueError(f"max_episode_steps={max_episode_steps!r} is outside the allowed range [1, inf)")
        if render_mode is not None:
            raise ValueError(f"render_mode={render_mode!r}: the vector env does not render; render a single env")
        self.task = self.task_cls(self.task_cls.params_cls(**params))
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
        self._autoreset = np.zeros(num_envs, dtype=bool)

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, Info]:
        """Reset every sub-env, or with ``options={"reset_mask": mask}`` (bool, (num_envs,)) only the masked ones.

        A masked reset without a seed starts each masked sub-env's next episode, exactly as autoreset (and the
        single env's ``reset()``) would; with a seed, masked sub-env ``i`` gets ``seed + i`` (or ``seed[i]``).
        """
        mask = (options or {}).get("reset_mask")
        if mask is not None:
            return self._reset_masked(seed, mask)
        super().reset(seed=seed if isinstance(seed, int) else None)
        if seed is None:
            keys = self.np_random.integers(0, 2**64, size=self.num_envs, dtype=np.uint64)
        else:
            keys = self._seed_keys(seed)
        self.state = self._fresh(keys)
        self._autoreset[:] = False
        return self.task.observe(self.state), {}

    def _seed_keys(self, seed: int | list[int]) -> np.ndarray:
        if isinstance(seed, int):
            return rng.seed_keys(seed + np.arange(self.num_envs))
        if len(seed) != self.num_envs:
            raise ValueError(f"seed has {len(seed)} entries; expected num_envs={self.num_envs}")
        return rng.seed_keys(np.asarray(seed))

    def _reset_masked(self, seed: int | list[int] | None, mask: Any) -> tuple[np.ndarray, Info]:
        mask = np.asarray(mask)
        if mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
            raise ValueError(f"reset_mask must be a bool array of shape ({self.num_envs},); got {mask!r}")
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() without reset_mask before a masked reset.")
        keys = rng.next_key(self.state["key"][mask]) if seed is None else self._seed_keys(seed)[mask]
        self.state = self._with_fresh_episodes(self.state, mask, keys)
        self._autoreset[mask] = False
        return self.task.observe(self.state), {}

    def _fresh(self, keys: np.ndarray) -> State:
        return {**self.task.initial_state(keys), "key": keys, "step": np.zeros(len(keys), dtype=np.int64)}

    def _with_fresh_episodes(self, state: State, mask: np.ndarray, keys: np.ndarray) -> State:
        """``state`` with the masked sub-envs starting the episodes of ``keys``; arrays are copied, never
        written in place, since earlier states and returned infos may share them."""
        fresh = self._fresh(keys)
        out = dict(state)
        if len(keys) == self.num_envs:  # every sub-env restarts: take the fresh arrays, nothing to merge
            for k, v in fresh.items():
                out[k] = v.astype(state[k].dtype, copy=False)
            return out
        rows = np.flatnonzero(mask)
        for k, v in fresh.items():
            merged = state[k].copy()
            merged[rows] = v
            out[k] = merged
        return out

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Info]:
        """Step every sub-env; those that ended on the previous step start a new episode instead (NEXT_STEP).

        The task steps the whole batch (its randomness is a pure function of each episode's key, so the
        discarded rows of resetting sub-envs draw nothing that others see); resetting rows are then replaced
        by fresh episodes and report reward 0, not terminated, not truncated, and masked-out infos.
        """
        if self.state is None:
            raise gym.error.ResetNeeded("Call reset() before step().")
        a = check_actions(actions, self.single_action_space, (self.num_envs,))
        transition = self.task.step(self.state, a)
        state = {**transition.state, "key": self.state["key"], "step": self.state["step"] + 1}
        reward, terminated = transition.reward, transition.terminated
        resetting = self._autoreset
        if resetting.any():
            state = self._with_fresh_episodes(state, resetting, rng.next_key(self.state["key"][resetting]))
            reward = np.where(resetting, 0.0, reward)
            terminated = terminated & ~resetting
        self.state = state
        truncated = np.zeros(self.num_envs, dtype=bool)
        if self.max_episode_steps is not None:
            truncated = (state["step"] >= self.max_episode_steps) & ~resetting
        self._autoreset = terminated | truncated
        obs = self.task.observe(state)
        return obs, reward.astype(np.float64), terminated, truncated, self._vector_info(transition.info, ~resetting)

    def _vector_info(self, info: Info, mask: np.ndarray) -> Info:
        out: Info = {}
        for k, v in info.items():
            out[k] = self._vector_info(v, mask) if isinstance(v, Mapping) else v
            out[f"_{k}"] = mask
        return out
