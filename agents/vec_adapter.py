"""A stable-baselines3 ``VecEnv`` over a Gymnasium ``VectorEnv`` with NEXT_STEP autoreset.

SB3 vector envs reset a finished sub-env within the same step: the step returns the new episode's first
observation and puts the last one in ``infos[i]["terminal_observation"]``. A NEXT_STEP vector env instead
returns the last observation and resets on the following step, stepping the other sub-envs too, so the adapter
cannot wait for that step: after a step in which some sub-envs finished it resets just those, with
``reset(options={"reset_mask": done})`` (Gymnasium's partial-reset convention, supported by vegym's native vector
envs and by ``SyncVectorEnv``/``AsyncVectorEnv``). The result equals SB3's ``DummyVecEnv`` over the single envs
on the same seeds: observations, rewards, dones and infos, ``TimeLimit.truncated`` included.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

from vegym.envs.base import split_info

_SUB_ENV_SPACES = {"observation_space": "single_observation_space", "action_space": "single_action_space"}
"""The vector env's attributes that ``get_attr`` reads for a sub-env's spaces."""


class VectorEnvAdapter(VecEnv):
    """SB3 ``VecEnv`` semantics over a Gymnasium NEXT_STEP ``VectorEnv`` (see the module docstring).

    The sub-envs of a native vector env share one batched task, so ``get_attr``, ``set_attr`` and ``env_method``
    act on the vector env itself, for all sub-envs at once (ValueError for indices that pick only some; the spaces
    that ``get_attr`` returns are a sub-env's), and no
    sub-env is wrapped (``env_is_wrapped`` is all False). ``get_images`` gives the frames of the vector env's
    ``render()`` (a ``SyncVectorEnv`` of rgb_array envs draws one per sub-env).
    """

    def __init__(self, venv: VectorEnv) -> None:
        mode = venv.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        if mode != AutoresetMode.NEXT_STEP:
            raise ValueError(f"autoreset_mode={mode!r}: VectorEnvAdapter needs AutoresetMode.NEXT_STEP")
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self.metadata = venv.metadata  # render_fps among them (VecVideoRecorder's frame rate), as DummyVecEnv's
        self._actions: np.ndarray | None = None

    def reset(self) -> VecEnvObs:
        seeds = None if all(s is None for s in self._seeds) else self._seeds  # a None entry: that sub-env unseeded
        options = self._options[0]
        if any(o != options for o in self._options):
            raise ValueError("a native vector env takes one options dict for all sub-envs")
        obs, info = self.venv.reset(seed=seeds, options=dict(options) or None)
        self.reset_infos = split_info(info, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return np.array(obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() called before step_async()")
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        obs = np.array(obs)
        dones = np.asarray(terminated | truncated, dtype=bool)
        infos = split_info(info, self.num_envs)
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        if dones.any():
            reset_obs, reset_info = self.venv.reset(options={"reset_mask": dones.copy()})
            reset_infos = split_info(reset_info, self.num_envs)
            for i in np.flatnonzero(dones):
                infos[i]["terminal_observation"] = obs[i].copy()
                obs[i] = reset_obs[i]
                self.reset_infos[i] = reset_infos[i]
        return obs, np.asarray(rewards, dtype=np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def _count(self, indices: VecEnvIndices) -> int:
        return len(list(self._get_indices(indices)))

    def _every_env(self, action: str, indices: VecEnvIndices) -> int:
        """The number of sub-envs, checking that ``indices`` picks them all (ValueError naming ``action``)."""
        if set(self._get_indices(indices)) != set(range(self.num_envs)):
            raise ValueError(f"{action} acts on the whole vector env; indices={indices!r} picks only some sub-envs")
        return self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The vector env's attribute, once per sub-env of ``indices``; a space is a sub-env's, as DummyVecEnv's."""
        attr_name = _SUB_ENV_SPACES.get(attr_name, attr_name)
        return [getattr(self.venv, attr_name)] * self._count(indices)

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        self._every_env(f"set_attr({attr_name!r})", indices)
        setattr(self.venv, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any
    ) -> list[Any]:
        count = self._every_env(f"env_method({method_name!r})", indices)
        return [getattr(self.venv, method_name)(*method_args, **method_kwargs)] * count

    def get_images(self) -> list[np.ndarray | None]:
        frames = self.venv.render()
        return list(frames) if frames is not None else [None] * self.num_envs

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        return [False] * self._count(indices)
