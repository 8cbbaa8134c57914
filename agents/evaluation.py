"""One evaluation for every agent: analytic controllers, the random policy, references, trained SB3 models.

Every agent has SB3's ``predict(obs, state, episode_start, deterministic)`` and runs the same loop on the same
single env: episode ``k`` of an evaluation starts from ``reset(seed=seed + k)``. Per env and agent it reports
the mean and std of the return, the success rate (``info["is_success"]`` at the episode's last step), the
normalized score ``(R - R_random) / (R_analytic - R_random)`` (1 matches the analytic controller), the score
against each stronger reference of the env (:data:`agents.analytic.REFERENCE_AGENTS`) and the task's own control
metrics (:data:`TASK_METRICS`), averaged over episodes.
"""

from __future__ import annotations

import contextlib
import math
import os
import random
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

from agents.analytic import REFERENCE_AGENTS, controller_for
from agents.basics import EVAL_SEED
from agents.config import TrainConfig, load_resolved, make_kwargs
from agents.statistics import ScoreSummary, normalized, summarize
from agents.training import CONFIG_FILE, MODEL_FILE, normalize_path, saved_timesteps, seed_runs

Agent = Any
"""Anything with SB3's ``predict(observation, state, episode_start, deterministic) -> (action, state)``."""
AgentFactory = Callable[[gym.Env], Agent]
"""Builds an agent for the single env it will act in (privileged references read that env's state)."""
SeededFactories = Mapping[int, AgentFactory]
"""One agent trained on several seeds: a factory per training seed, each evaluated on the same episodes."""


class RandomAgent:
    """Uniform random actions in the action box, from a seeded generator: the score's lower reference."""

    def __init__(self, action_space: spaces.Box, seed: int = 0) -> None:
        self.space = action_space
        self.rng = np.random.default_rng(seed)

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = False
    ) -> tuple[np.ndarray, Any]:
        batch = np.shape(observation)[:-1]
        action = self.rng.uniform(self.space.low, self.space.high, (*batch, *self.space.shape))
        return action.astype(self.space.dtype), state


class LearnedAgent:
    """A trained SB3 model, with the observation normalisation it was trained with (if any)."""

    def __init__(self, model: BaseAlgorithm, normalizer: VecNormalize | None = None) -> None:
        self.model = model
        self.normalizer = normalizer

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = False
    ) -> tuple[np.ndarray, Any]:
        obs = self.normalizer.normalize_obs(observation) if self.normalizer is not None else observation
        return self.model.predict(obs, state, episode_start, deterministic)


@contextlib.contextmanager
def _global_generators_kept() -> Iterator[None]:
    """Python's, numpy's and torch's global random generators (CUDA's too) as they were on entry, on exit: SB3's
    ``load`` seeds them all from the model's training seed."""
    python, legacy_numpy = random.getstate(), np.random.get_state()  # noqa: NPY002 (the global one)
    try:
        with torch.random.fork_rng():
            yield
    finally:
        random.setstate(python)
        np.random.set_state(legacy_numpy)  # noqa: NPY002


def load_learned(path: Path) -> tuple[LearnedAgent, TrainConfig]:
    """A trained agent from a run directory (its ``model.zip``) or a model zip, with its resolved config.

    The config is ``config.yml`` beside the zip or one level up (checkpoints); VecNormalize statistics, when the
    config normalises, are the ones saved with that zip. The global random generators are left as they were (SB3's
    ``load`` seeds them from the model's training seed).
    """
    path = Path(path)
    model_path = path / MODEL_FILE if path.is_dir() else path
    if not model_path.is_file():
        raise ValueError(f"agent {str(path)!r}: no such model (expected a run directory or a .zip)")
    config = _model_config(model_path)
    with _global_generators_kept():
        model = config.algo_class.load(model_path, device="cpu")
    normalizer = None
    if config.normalize_kwargs() is not None:
        stats = normalize_path(model_path)
        if not stats.is_file():
            raise ValueError(f"agent {str(path)!r}: the config normalises but {stats} is missing")
        dummy = DummyVecEnv([lambda: gym.make(config.env_id, **config.env_kwargs)])
        normalizer = VecNormalize.load(str(stats), dummy)
        normalizer.training = False
    return LearnedAgent(model, normalizer), config


def _model_config(model_path: Path) -> TrainConfig:
    """The resolved config of a model zip: ``config.yml`` beside it or one level up (checkpoints)."""
    folders = (model_path.parent, model_path.parent.parent)
    config_path = next((d / CONFIG_FILE for d in folders if (d / CONFIG_FILE).is_file()), None)
    if config_path is None:
        raise ValueError(f"agent {str(model_path)!r}: no {CONFIG_FILE} beside the model or one level up")
    return load_resolved(config_path)


def short_runs(path: Path) -> list[str]:
    """A line for each model of the agent at ``path`` (a model zip, a run directory or a directory of
    ``seed_<k>/`` runs) that holds fewer steps than its config's total: an interrupted or checkpointed run."""
    path = Path(path)
    models = [path] if path.is_file() else [run / MODEL_FILE for run in seed_runs(path).values()]
    lines = []
    for model in models:
        steps, total = saved_timesteps(model), _model_config(model).n_timesteps
        if steps < total:
            lines.append(f"{model} holds {steps} of its config's {total} training steps")
    return lines


def load_seeded(agent_dir: Path) -> tuple[dict[int, AgentFactory], TrainConfig]:
    """Factories of an agent's trained runs by training seed (:func:`agents.training.seed_runs`) and the config
    of its first seed; ValueError if there is none or the runs differ in env, algorithm or env kwargs."""
    runs = seed_runs(Path(agent_dir))
    if not runs:
        raise ValueError(f"agent {str(agent_dir)!r}: no model.zip in it or in its seed_<k>/ directories")
    factories: dict[int, AgentFactory] = {}
    configs: dict[int, TrainConfig] = {}
    for seed, path in runs.items():
        agent, configs[seed] = load_learned(path)
        factories[seed] = lambda env, agent=agent: agent
    first = next(iter(configs.values()))
    settings = {k: v for k, v in first.to_entry().items() if k != "seed"}
    for seed, config in configs.items():
        differing = sorted(k for k, v in config.to_entry().items() if k != "seed" and settings.get(k) != v)
        if differing:
            raise ValueError(
                f"agent {str(agent_dir)!r}: seed {seed} was trained with other settings than seed "
                f"{first.seed} ({', '.join(differing)}); the seeds of one agent must share their config"
            )
    return factories, first


BASELINES: dict[str, Callable[[int], AgentFactory]] = {
    "analytic": lambda seed: controller_for,
    "random": lambda seed: lambda env: RandomAgent(env.action_space, seed),
}
"""The two agents that define the normalized score, as factories of the evaluation seed."""


@dataclass
class Episode:
    """One evaluated episode: ``observations`` has one more row than ``actions`` and ``rewards``."""

    observations: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    infos: list[dict[str, Any]]

    @property
    def ret(self) -> float:
        """The undiscounted return."""
        return float(np.sum(self.rewards))

    @property
    def success(self) -> bool | None:
        """``info["is_success"]`` at the last step, or None if the env does not report it."""
        value = self.infos[-1].get("is_success") if self.infos else None
        return None if value is None else bool(value)


def _mean_over_steps(key: str, fn: Callable[[np.ndarray], np.ndarray] = np.abs) -> Callable[[Episode], float]:
    return lambda ep: float(np.mean([fn(np.asarray(info[key])) for info in ep.infos]))


def _rms_error(index: int, scale: float = 1.0) -> Callable[[Episode], float]:
    return lambda ep: scale * float(np.sqrt(np.mean([info["errors"][index] ** 2 for info in ep.infos])))


def _apex_error(ep: Episode) -> float:
    return float(np.mean([abs(info["apex_height"] - info["target_height"]) for info in ep.infos]))


def _elapsed(ep: Episode) -> float:
    return float(sum(info["dt"] for info in ep.infos))


_AIRCRAFT_METRICS: dict[str, Callable[[Episode], float]] = {
    "altitude_rmse_m": _rms_error(0),
    "airspeed_rmse_mps": _rms_error(1),
    "heading_rmse_deg": _rms_error(2, math.degrees(1.0)),
    "effort": lambda ep: float(np.mean(np.sum(ep.actions**2, axis=-1))),
}

TASK_METRICS: dict[str, dict[str, Callable[[Episode], float]]] = {
    "vegym/BouncingBall-v0": {"apex_error_m": _apex_error},
    "vegym/Projectile-v0": {"miss_distance_m": lambda ep: float(ep.infos[-1]["miss_distance"])},
    "vegym/SteerableWheel-v0": {
        "waypoints_passed": lambda ep: float(ep.infos[-1]["waypoint_index"]),
        "time_s": _elapsed,
        "steering_effort": _mean_over_steps("steer_increment", np.square),
    },
    "vegym/Aircraft-v0": _AIRCRAFT_METRICS,
    "vegym/AircraftGusty-v0": _AIRCRAFT_METRICS,
}
"""The control metrics of each env, from an episode's infos and actions (averaged over episodes); every env
also gets ``episode_length``. A new env adds its entry here."""


@dataclass
class EvalResult:
    """An agent's evaluation on one env; :meth:`record` is its JSON form.

    ``runs`` holds one list of episodes per training seed (``training_seeds``, None for agents that are not
    trained), every list over the same evaluation seeds ``seed, seed + 1, ...``.
    """

    env_id: str
    agent: str
    seed: int
    runs: list[list[Episode]]
    training_seeds: list[int] | None = None
    normalized_scores: np.ndarray | None = None
    """Per-episode normalized scores, shape ``(runs, episodes)``; :func:`score` fills them (None if the
    references tie)."""
    normalized_score_vs: dict[str, float | None] = field(default_factory=dict)
    baseline_returns: tuple[np.ndarray, np.ndarray] | None = None
    """The random policy's and the analytic controller's returns on the same episodes (episodes,), which
    normalize the scores; :func:`score` fills them (None if they tie)."""

    @property
    def normalized_score(self) -> float | None:
        """Mean normalized score over every episode of every run (1: the analytic controller)."""
        return None if self.normalized_scores is None else float(self.normalized_scores.mean())

    @cached_property
    def summary(self) -> ScoreSummary | None:
        """Mean, IQM and their 95% crossed-bootstrap CIs (:mod:`agents.statistics`) of :attr:`normalized_scores`,
        paired with the baselines' episodes."""
        return None if self.baseline_returns is None else summarize(self.return_matrix(), *self.baseline_returns)

    @property
    def episodes(self) -> list[Episode]:
        """Every evaluated episode, run after run."""
        return [ep for run in self.runs for ep in run]

    @property
    def returns(self) -> np.ndarray:
        """Returns of every episode, run after run (flat)."""
        return np.array([ep.ret for ep in self.episodes])

    def return_matrix(self) -> np.ndarray:
        """Returns, shape ``(runs, episodes)``."""
        return np.array([[ep.ret for ep in run] for run in self.runs])

    @property
    def success_rate(self) -> float | None:
        flags = [ep.success for ep in self.episodes]
        return None if any(f is None for f in flags) else float(np.mean(flags))

    def metrics(self) -> dict[str, float]:
        """``episode_length`` and the env's :data:`TASK_METRICS`, each averaged over the episodes."""
        table = {"episode_length": lambda ep: float(len(ep.rewards)), **TASK_METRICS.get(self.env_id, {})}
        return {name: float(np.mean([fn(ep) for ep in self.episodes])) for name, fn in table.items()}

    def record(self) -> dict[str, Any]:
        """The JSON record: the returns of every episode of every run (``returns``, runs x episodes, from which
        and the baselines' records the scores and intervals follow), their statistics, normalized-score
        statistics, metrics."""
        returns = self.returns
        summary = self.summary
        mean_ci, iqm_ci = (None, None) if summary is None else (summary.mean_ci95, summary.iqm_ci95)
        return {
            "env_id": self.env_id,
            "agent": self.agent,
            "seeds": self.training_seeds,
            "episodes": len(self.runs[0]),
            "seed": self.seed,
            "returns": self.return_matrix().tolist(),
            "mean_return": float(returns.mean()),
            "std_return": float(returns.std()),
            "success_rate": self.success_rate,
            "normalized_score": self.normalized_score,
            "iqm_normalized_score": None if summary is None else summary.iqm,
            "ci95_normalized_score": None if mean_ci is None else list(mean_ci),
            "ci95_iqm_normalized_score": None if iqm_ci is None else list(iqm_ci),
            "normalized_score_per_seed": self._per_seed_scores(),
            "normalized_score_vs": dict(self.normalized_score_vs),
            "metrics": self.metrics(),
        }

    def _per_seed_scores(self) -> dict[str, float] | None:
        """Mean normalized score of each training seed's run (None for agents that are not trained)."""
        if self.training_seeds is None or self.normalized_scores is None:
            return None
        return {str(s): float(row.mean()) for s, row in zip(self.training_seeds, self.normalized_scores, strict=True)}


def run_episode(env: gym.Env, agent: Agent, seed: int) -> Episode:
    """One deterministic episode of ``agent`` from ``env.reset(seed=seed)``."""
    obs, _ = env.reset(seed=seed)
    observations, actions, rewards, infos = [obs], [], [], []
    state, start = None, True
    while True:
        action, state = agent.predict(obs, state=state, episode_start=np.array([start]), deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        start = False
        observations.append(obs)
        actions.append(np.asarray(action, dtype=np.float64).reshape(env.action_space.shape))
        rewards.append(float(reward))
        infos.append(info)
        if terminated or truncated:
            return Episode(np.array(observations), np.array(actions), np.array(rewards), infos)


def evaluate(
    env_id: str,
    agent: str,
    factory: AgentFactory,
    episodes: int = 20,
    seed: int = EVAL_SEED,
    env_kwargs: Mapping[str, Any] | None = None,
) -> EvalResult:
    """Run ``episodes`` episodes (seeds ``seed``, ``seed + 1``, ...) of the agent ``factory`` builds."""
    if episodes < 1:
        raise ValueError(f"episodes={episodes!r} must be at least 1")
    env = gym.make(env_id, **make_kwargs(env_id, env_kwargs or {}))
    try:
        actor = factory(env)
        return EvalResult(env_id, agent, seed, [[run_episode(env, actor, seed + k) for k in range(episodes)]])
    finally:
        env.close()


def score(results: list[EvalResult]) -> None:
    """Fill the normalized scores of one env's results (they must include ``analytic`` and ``random``).

    Every episode's return R is normalized by the mean returns of the random policy and the analytic
    controller over the same episodes, ``(R - R_random) / (R_analytic - R_random)``; its mean over the episodes is
    the normalized mean return. Warns when the analytic controller scores below the random policy (the scale
    then runs backwards).
    """
    by_agent = {r.agent: r for r in results}
    for name in ("analytic", "random"):
        if name not in by_agent:
            raise ValueError(f"normalized scores need the {name!r} agent's result")
    means = {r.agent: float(r.returns.mean()) for r in results}
    low, high = means["random"], means["analytic"]
    tie = normalized(high, low, high) is None
    if high < low and not tie:
        warnings.warn(
            f"{results[0].env_id}: the analytic controller's mean return ({high:.6g}) is below the random policy's "
            f"({low:.6g}), so a normalized score above 0 is worse than random",
            stacklevel=2,
        )
    baselines = None if tie else (by_agent["random"].returns, by_agent["analytic"].returns)
    references = [r.agent for r in results if r.agent in REFERENCE_AGENTS.get(results[0].env_id, {})]
    for r in results:
        r.baseline_returns = baselines
        r.normalized_scores = None if tie else (r.return_matrix() - low) / (high - low)
        r.normalized_score_vs = {ref: normalized(means[r.agent], means["random"], means[ref]) for ref in references}


def agent_factories(
    env_id: str, extra: Mapping[str, AgentFactory | SeededFactories], seed: int = EVAL_SEED
) -> dict[str, AgentFactory | SeededFactories]:
    """``analytic``, ``random`` and the env's references, then ``extra``: the agents an env is evaluated with."""
    agents: dict[str, AgentFactory | SeededFactories] = {name: make(seed) for name, make in BASELINES.items()}
    agents.update(REFERENCE_AGENTS.get(env_id, {}))
    agents.update(extra)
    return agents


def evaluate_seeds(
    env_id: str,
    agent: str,
    factories: SeededFactories,
    episodes: int = 20,
    seed: int = EVAL_SEED,
    env_kwargs: Mapping[str, Any] | None = None,
) -> EvalResult:
    """:func:`evaluate` for each training seed's agent on the same episodes: one run per training seed."""
    runs = [evaluate(env_id, agent, f, episodes, seed, env_kwargs).runs[0] for f in factories.values()]
    return EvalResult(env_id, agent, seed, runs, training_seeds=list(factories))


def evaluate_agents(
    env_id: str,
    factories: Mapping[str, AgentFactory | SeededFactories],
    episodes: int = 20,
    seed: int = EVAL_SEED,
    env_kwargs: Mapping[str, Any] | None = None,
) -> list[EvalResult]:
    """The baselines, the env's references and ``factories`` on the same seeds, with normalized scores.

    A factory given as a mapping of training seeds to factories is evaluated once per training seed.
    """
    results = []
    for name, f in agent_factories(env_id, factories, seed).items():
        if isinstance(f, Mapping):
            results.append(evaluate_seeds(env_id, name, f, episodes, seed, env_kwargs))
        else:
            results.append(evaluate(env_id, name, f, episodes, seed, env_kwargs))
    score(results)
    return results


def agent_factory(
    spec: str, env_id: str, seed: int = EVAL_SEED
) -> tuple[str, AgentFactory | SeededFactories, TrainConfig | None]:
    """Name, factory and (for a trained model) config of an agent named on the command line.

    ``spec`` is ``analytic``, ``random``, a reference of the env (e.g. ``oracle`` for BouncingBall) or the path
    of a trained model for the same env: a run directory or zip, or a directory of ``seed_<k>/`` runs. A model's
    factory is one per training seed (the single seed of a run or zip, from its config).
    """
    if spec in BASELINES:
        return spec, BASELINES[spec](seed), None
    references = REFERENCE_AGENTS.get(env_id, {})
    if spec in references:
        return spec, references[spec], None
    if not Path(spec).exists():
        names = ", ".join([*BASELINES, *references])
        if "/" in spec or os.sep in spec or spec.endswith(".zip"):
            raise ValueError(f"agent {spec!r}: no such model file or directory (or an agent of {env_id}: {names})")
        elsewhere = [other for other, agents in REFERENCE_AGENTS.items() if spec in agents]
        hint = f" ({spec} is a reference agent of {', '.join(elsewhere)})" if elsewhere else ""
        raise ValueError(f"agent {spec!r} is no agent of {env_id} ({names}) nor a model path{hint}")
    path = Path(spec)
    factory: SeededFactories
    if path.is_dir():
        factory, config = load_seeded(path)
    else:
        learned, config = load_learned(path)
        factory = {config.seed: lambda env: learned}
    if config.env_id != env_id:
        raise ValueError(f"agent {spec!r} was trained on {config.env_id}, not {env_id}")
    return config.algo, factory, config
