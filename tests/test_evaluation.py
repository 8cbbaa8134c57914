"""What an evaluation reports: its episodes' seeds, return statistics, success, control metrics and table cells."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import vegym  # noqa: F401  (registers the envs)
from agents import compare, evaluation
from agents.analytic import controller_for
from agents.config import CONFIG_DIR, load_config
from agents.evaluation import (
    TASK_METRICS,
    Episode,
    EvalResult,
    RandomAgent,
    agent_factory,
    evaluate,
    load_seeded,
    run_episode,
)
from agents.training import MODEL_FILE


def test_an_evaluation_plays_seeds_seed_on_and_reports_their_population_statistics() -> None:
    env_id, seed = "vegym/BouncingBall-v0", 1000
    result = evaluate(env_id, "analytic", controller_for, episodes=5, seed=seed)
    env = gym.make(env_id)
    alone = [run_episode(env, controller_for(env), seed + k) for k in range(5)]
    returns = np.array([ep.ret for ep in alone])
    successes = [bool(ep.infos[-1]["is_success"]) for ep in alone]
    assert len(set(returns)) == 5 and 0 < sum(successes) < 5  # the checks below can tell the episodes apart
    record = result.record()
    np.testing.assert_array_equal(result.returns, returns)
    assert record["returns"] == [returns.tolist()]  # one run of five episodes, as compare.json keeps them
    assert record["mean_return"] == pytest.approx(returns.mean(), abs=1e-12)
    assert record["std_return"] == pytest.approx(math.sqrt(np.mean((returns - returns.mean()) ** 2)), abs=1e-12)
    assert record["success_rate"] == np.mean(successes)  # at the episodes' last steps


def _metrics_by_formula(env_id: str, episodes: list[evaluation.Episode]) -> dict[str, float]:
    """The control metrics as the README and TASK_METRICS's docstrings define them, from the infos and actions."""

    def mean(f: Any) -> float:
        return float(np.mean([f(ep) for ep in episodes]))

    def rms(ep: evaluation.Episode, k: int) -> float:
        return math.sqrt(sum(info["errors"][k] ** 2 for info in ep.infos) / len(ep.infos))

    metrics = {"episode_length": mean(lambda ep: len(ep.rewards))}
    if env_id == "vegym/BouncingBall-v0":
        metrics["apex_error_m"] = mean(
            lambda ep: np.mean([abs(i["apex_height"] - i["target_height"]) for i in ep.infos])
        )
    elif env_id == "vegym/Projectile-v0":
        metrics["miss_distance_m"] = mean(lambda ep: ep.infos[-1]["miss_distance"])
    elif env_id == "vegym/SteerableWheel-v0":
        metrics["waypoints_passed"] = mean(lambda ep: ep.infos[-1]["waypoint_index"])
        metrics["time_s"] = mean(lambda ep: len(ep.infos) * ep.infos[0]["dt"])
        metrics["steering_effort"] = mean(lambda ep: np.mean([i["steer_increment"] ** 2 for i in ep.infos]))
    else:  # the aircraft: errors (altitude m, airspeed m/s, heading rad) and the mean squared action's sum
        metrics["altitude_rmse_m"] = mean(lambda ep: rms(ep, 0))
        metrics["airspeed_rmse_mps"] = mean(lambda ep: rms(ep, 1))
        metrics["heading_rmse_deg"] = mean(lambda ep: math.degrees(rms(ep, 2)))
        metrics["effort"] = mean(lambda ep: np.mean([a @ a for a in ep.actions]))
    return metrics


@pytest.mark.parametrize("agent", ["analytic", "random"])
@pytest.mark.parametrize("env_id", list(TASK_METRICS))
def test_control_metrics_are_their_formulas(env_id: str, agent: str) -> None:
    result = evaluate(env_id, agent, agent_factory(agent, env_id)[1], episodes=2)
    expected = _metrics_by_formula(env_id, result.episodes)
    assert result.metrics() == pytest.approx(expected, rel=1e-12, abs=1e-12)
    if env_id == "vegym/SteerableWheel-v0" and agent == "analytic":
        assert expected["waypoints_passed"] == 5  # the last step passes the last waypoint


def test_the_random_agent_draws_from_its_evaluation_seed() -> None:
    env = gym.make("vegym/Projectile-v0")
    obs, _ = env.reset(seed=0)
    seven = agent_factory("random", "vegym/Projectile-v0", seed=7)[1](env)
    np.testing.assert_array_equal(seven.predict(obs)[0], RandomAgent(env.action_space, 7).predict(obs)[0])
    assert not np.array_equal(seven.predict(obs)[0], RandomAgent(env.action_space, 0).predict(obs)[0])


@pytest.fixture
def fake_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    """Makes agent directories ``tmp_path/name`` with a run per training seed, whose configs are the committed
    PPO entry of Projectile with the seed's overrides; the models are not read (``load_learned`` is replaced)."""
    overrides: dict[Path, dict[str, Any]] = {}

    def make(name: str, entries: dict[int, dict[str, Any]]) -> Path:
        for seed, entry in entries.items():
            run = tmp_path / name / f"seed_{seed}"
            run.mkdir(parents=True)
            (run / MODEL_FILE).touch()
            overrides[run] = {"seed": seed, **entry}
        return tmp_path / name

    def load_learned(path: Path) -> tuple[object, Any]:
        return object(), load_config(CONFIG_DIR / "ppo.yml", "vegym/Projectile-v0", overrides=overrides[Path(path)])

    monkeypatch.setattr(evaluation, "load_learned", load_learned)
    return make


def test_the_seeds_of_one_agent_must_share_their_settings(fake_runs: Any) -> None:
    assert set(load_seeded(fake_runs("same", {0: {}, 1: {}}))[0]) == {0, 1}
    other = fake_runs("other", {0: {}, 1: {"learning_rate": 1e-5}})
    with pytest.raises(ValueError, match=r"seed 1 was trained with other settings than seed 0 \(learning_rate\)"):
        load_seeded(other)


def test_agents_trained_with_other_env_kwargs_are_not_compared_together(fake_runs: Any) -> None:
    runs = {algo: fake_runs(algo, {0: {"env_kwargs": {"gravity": g}}}) for algo, g in (("ppo", 9.0), ("sac", 10.0))}
    with pytest.raises(ValueError, match="trained with different env_kwargs"):
        compare._learned(runs, "vegym/Projectile-v0")
    assert compare._learned({"ppo": runs["ppo"]}, "vegym/Projectile-v0")[1] == {"gravity": 9.0}


def test_agents_whose_env_kwargs_make_the_same_env_are_compared_together(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An entry may give the time limit that vegym adds itself (as RL Zoo needs): the agents play the same env."""
    env_kwargs = {"ppo": {"episode_bounces": 20}, "sac": {"episode_bounces": 20, "max_episode_steps": 20}}
    configs = {}
    for algo, kwargs in env_kwargs.items():
        run = tmp_path / algo / "seed_0"
        run.mkdir(parents=True)
        (run / MODEL_FILE).touch()
        overrides = {"seed": 0, "env_kwargs": kwargs}
        configs[run] = load_config(CONFIG_DIR / f"{algo}.yml", "vegym/BouncingBall-v0", overrides=overrides)
    monkeypatch.setattr(evaluation, "load_learned", lambda path: (object(), configs[Path(path)]))
    runs = {algo: tmp_path / algo for algo in env_kwargs}
    assert compare._learned(runs, "vegym/BouncingBall-v0")[1] == env_kwargs["ppo"]


def test_an_agent_directory_without_a_trained_run_is_not_a_model(tmp_path: Path) -> None:
    (tmp_path / "Projectile-v0" / "ppo").mkdir(parents=True)
    assert compare.find_models(tmp_path, "vegym/Projectile-v0", ["ppo"]) == {}
    (tmp_path / "Projectile-v0" / "ppo" / "seed_0").mkdir()
    (tmp_path / "Projectile-v0" / "ppo" / "seed_0" / MODEL_FILE).touch()
    assert compare.find_models(tmp_path, "vegym/Projectile-v0", ["ppo"]) == {"ppo": tmp_path / "Projectile-v0" / "ppo"}


def test_the_table_s_iqm_cell_shows_the_iqm_and_its_interval() -> None:
    record = {
        "env_id": "vegym/Projectile-v0", "agent": "ppo", "seeds": [0, 1, 2], "mean_return": 0.5, "std_return": 0.1,
        "success_rate": 0.5, "normalized_score": 0.6, "ci95_normalized_score": [0.1, 0.9],
        "iqm_normalized_score": 0.61, "ci95_iqm_normalized_score": [0.55, 0.65], "normalized_score_vs": {},
        "metrics": {},
    }  # fmt: skip
    row = dict(zip(compare.TABLE_COLUMNS, compare.table_rows([record])[0], strict=True))
    assert row["normalized [95% CI]"] == "0.600 [0.100, 0.900]"
    assert row["IQM [95% CI]"] == "0.610 [0.550, 0.650]"


def test_scoring_warns_when_the_analytic_controller_returns_less_than_random() -> None:
    env_id = "vegym/BouncingBall-v0"
    random_factory = agent_factory("random", env_id)[1]
    controller = evaluate(env_id, "analytic", controller_for, episodes=3)
    random = evaluate(env_id, "random", random_factory, episodes=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        evaluation.score([controller, random])
    swapped = [evaluate(env_id, "analytic", random_factory, episodes=3), evaluate(env_id, "random", controller_for, 3)]
    with pytest.warns(UserWarning, match="analytic controller's mean return .* is below the random policy's"):
        evaluation.score(swapped)


def test_an_evaluation_asks_the_agent_for_deterministic_actions_and_flags_each_episode_start() -> None:
    """README: every agent on the same episodes with deterministic actions (a learned agent's mean action)."""
    calls: list[tuple[bool, bool]] = []

    class Recording:
        def __init__(self, env: Any) -> None:
            self.controller = controller_for(env)

        def predict(self, obs: Any, state: Any = None, episode_start: Any = None, deterministic: bool = False) -> Any:
            calls.append((deterministic, bool(np.asarray(episode_start).item())))
            return self.controller.predict(obs, state, episode_start, deterministic)

    result = evaluate("vegym/BouncingBall-v0", "recording", Recording, episodes=2)
    assert all(deterministic for deterministic, _ in calls)
    starts = [start for _, start in calls]
    assert len(starts) == sum(len(ep.rewards) for ep in result.episodes)
    first_steps = np.cumsum([0, *[len(ep.rewards) for ep in result.episodes[:-1]]])
    assert [k for k, s in enumerate(starts) if s] == first_steps.tolist()


def test_the_table_s_cells_count_the_seeds_show_success_in_percent_and_zero_residues_as_zero() -> None:
    record = {
        "env_id": "vegym/Projectile-v0", "agent": "ppo", "seeds": [0, 1, 2], "mean_return": 0.5, "std_return": 0.1,
        "success_rate": 0.25, "normalized_score": -1e-17, "ci95_normalized_score": None,
        "iqm_normalized_score": None, "ci95_iqm_normalized_score": None,
        "normalized_score_vs": {"oracle": 0.5}, "metrics": {"episode_length": 10.0},
    }  # fmt: skip
    row = dict(zip(compare.TABLE_COLUMNS, compare.table_rows([record])[0], strict=True))
    assert row["env"] == "Projectile-v0" and row["agent"] == "ppo"
    assert row["seeds"] == "3"
    assert row["return (mean ± std)"] == "0.500 ± 0.100"
    assert row["success"] == "25%"
    assert row["normalized [95% CI]"] == "0.000"  # the rounding residue of the random policy's 0
    assert row["IQM [95% CI]"] == "-"
    assert row["vs reference"] == "oracle: 0.500"
    assert row["control metrics"] == "episode_length=10.000"
    untrained = {**record, "seeds": None, "success_rate": None}
    cells = dict(zip(compare.TABLE_COLUMNS, compare.table_rows([untrained])[0], strict=True))
    assert cells["seeds"] == "-" and cells["success"] == "-"


def test_evaluations_start_from_seed_1000_as_the_readme_says() -> None:
    """README: every agent on the same 20 episodes, seeds 1000-1019."""
    result = evaluate("vegym/BouncingBall-v0", "analytic", controller_for, episodes=2)
    env = gym.make("vegym/BouncingBall-v0")
    alone = [run_episode(env, controller_for(env), seed).ret for seed in (1000, 1001)]
    assert result.seed == 1000 and result.returns.tolist() == alone


def test_random_agents_of_different_seeds_draw_different_actions_and_of_one_seed_the_same() -> None:
    space = gym.make("vegym/Projectile-v0").action_space
    obs = np.zeros(4, dtype=np.float32)
    first = [RandomAgent(space, seed).predict(obs)[0] for seed in (7, 7, 8)]
    np.testing.assert_array_equal(first[0], first[1])
    assert not np.array_equal(first[0], first[2])


def test_the_success_rate_is_unknown_when_an_episode_does_not_report_success() -> None:
    def episode(info: dict) -> Episode:
        return Episode(np.zeros((2, 1)), np.zeros((1, 1)), np.zeros(1), [info])

    reported = EvalResult(
        "vegym/Projectile-v0", "a", 0, [[episode({"is_success": True}), episode({"is_success": False})]]
    )
    assert reported.success_rate == 0.5
    mixed = EvalResult("vegym/Projectile-v0", "a", 0, [[episode({"is_success": True}), episode({})]])
    assert mixed.success_rate is None


def test_an_evaluation_of_no_episodes_is_refused() -> None:
    with pytest.raises(ValueError, match="episodes=0 must be at least 1"):
        evaluate("vegym/BouncingBall-v0", "analytic", controller_for, episodes=0)
