"""PPO training throughput on every vegym env against Gymnasium's Pendulum-v1, measured in the same run.

For each env with a PPO entry in ``configs/ppo.yml``: ``model.learn`` for a few rollouts with that entry's
settings on the env as ``vegym train`` builds it (the native vector env through the SB3 adapter when
``n_envs > 1``), and the same PPO settings on Pendulum-v1 (continuous actions, like vegym's) as SB3 users
build it (``make_vec_env``: ``n_envs`` copies in a ``DummyVecEnv``); both monitored, and normalized where the
entry says. Environment steps per second of training, rollout collection and updates together, best of the
back-to-back pairs, and the median ratio (vegym / Pendulum) of the pairs. It shows what an env's speed is worth
once a learner runs: PPO's updates and per-step policy calls dominate. Run:
``python benchmarks/learning.py [--json] [--rollouts R] [--pairs P] [--envs ID ...]`` (ids with or without
``vegym/``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import time

import torch
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

import vegym
from agents.config import CONFIG_DIR, TrainConfig, load_configs
from agents.training import build_model, make_env

REFERENCE = "Pendulum-v1"


def steps_per_second(config: TrainConfig, env: VecEnv, rollouts: int) -> float:
    """Environment steps per second of ``rollouts`` PPO rollouts and their updates on ``env`` (closed after)."""
    normalize = config.normalize_kwargs()
    env = VecNormalize(env, **normalize) if normalize is not None else env
    try:
        model = build_model(config, env)
        steps = rollouts * config.n_envs * config.hyperparams.get("n_steps", 2048)
        start = time.perf_counter()
        model.learn(total_timesteps=steps)
        return model.num_timesteps / (time.perf_counter() - start)
    finally:
        env.close()


def measure(env_ids: list[str], rollouts: int, pairs: int) -> dict:
    configs = load_configs(CONFIG_DIR / "ppo.yml")
    results: dict = {"reference": REFERENCE, "rollouts": rollouts, "torch_threads": torch.get_num_threads(), "envs": {}}
    for env_id in env_ids:
        config = configs[env_id]
        reference = dataclasses.replace(config, env_id=REFERENCE, env_kwargs={})
        warm = make_env(config, seed=0)  # compiles (or loads) the env's kernels before any timing
        warm.reset()
        warm.close()
        rates, reference_rates = [], []
        for _ in range(pairs):
            rates.append(steps_per_second(config, make_env(config, seed=0), rollouts))
            pendulum = make_vec_env(REFERENCE, n_envs=config.n_envs, seed=0)  # each copy in a Monitor
            reference_rates.append(steps_per_second(reference, pendulum, rollouts))
        results["envs"][env_id] = {
            "n_envs": config.n_envs,
            "steps": rollouts * config.n_envs * config.hyperparams.get("n_steps", 2048),
            "vegym": max(rates),
            "reference": max(reference_rates),
            "ratio": statistics.median(r / p for r, p in zip(rates, reference_rates, strict=True)),
        }
    return results


def table(results: dict) -> str:
    reference = results["reference"]
    lines = [
        f"| env | n_envs | steps | vegym (steps/s) | {reference}, same PPO settings (steps/s) | ratio |",
        "|---|---|---|---|---|---|",
    ]
    for env_id, row in results["envs"].items():
        lines.append(
            f"| {env_id} | {row['n_envs']} | {row['steps']} | {row['vegym']:.3g} | {row['reference']:.3g} | "
            f"{row['ratio']:.2f}x |"
        )
    lines.append(
        f"\nPPO, {results['rollouts']} rollouts and their updates per measurement, {results['torch_threads']} torch "
        "threads; best of the pairs (median ratio of the back-to-back pairs)"
    )
    return "\n".join(lines)


def main() -> None:
    configs = load_configs(CONFIG_DIR / "ppo.yml")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--rollouts", type=int, default=2, help="PPO rollouts (and updates) per measurement")
    parser.add_argument("--pairs", type=int, default=3, help="back-to-back vegym / Pendulum measurements per env")
    parser.add_argument(
        "--envs", nargs="+", default=list(configs), help="vegym env ids, e.g. Aircraft-v0 (default: every PPO entry)"
    )
    args = parser.parse_args()
    if args.rollouts < 1 or args.pairs < 1:
        parser.error(f"--rollouts and --pairs must be at least 1; got {args.rollouts} and {args.pairs}")
    try:
        env_ids = [vegym.resolve_env_id(name) for name in args.envs]
    except ValueError as exc:
        parser.error(str(exc))
    unknown = [env_id for env_id in env_ids if env_id not in configs]
    if unknown:
        parser.error(f"no PPO entry for: {', '.join(unknown)} (entries: {', '.join(configs)})")
    results = measure(env_ids, args.rollouts, args.pairs)
    print(json.dumps(results, indent=2) if args.json else table(results))


if __name__ == "__main__":
    main()
