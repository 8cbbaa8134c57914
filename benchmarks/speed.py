"""Step rates of every vegym env against Gymnasium's CartPole, measured in the same run.

For each env: single-env steps/s through ``gymnasium.make`` (default wrappers), native vector env-steps/s at
several batch sizes, the analytic controller's batched ``predict`` rate (observations/s) and the peak memory
of the process. CartPole-v1 and its native ``CartPoleVectorEnv`` are measured with the same loops right before
each vegym measurement, three times (``--pairs``): a cell shows the env's best rate and the median ratio (vegym /
CartPole) of the back-to-back pairs, each pair taken seconds apart under the same load; the CartPole row is the median
of CartPole's best rates beside every env. More pairs settle a ratio near a target on a host whose speed drifts.

Env-steps/s counts as Gymnasium does: every ``step`` call times ``num_envs``. Under Gymnasium's NEXT_STEP
autoreset the step after an episode's end only starts the next episode (no transition, reward 0), so an env whose
episodes last one step (Projectile, Billiards) spends half its counted steps that way, where CartPole spends about
one in twenty. A second table gives each env's share of transitions among its counted steps (measured on an
untimed run of the same loop) and the ratio counted per transition. The single env's loop counts transitions only
(its resets are timed, not counted). Run:
``python benchmarks/speed.py [--json] [--seconds S] [--pairs N] [--envs ID ...]`` (ids with or without ``vegym/``).
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import vegym
from agents.analytic import controller_for

CARTPOLE = "CartPole-v1"
VECTOR_SIZES = (1, 64, 1024, 8192)


def rate(run: Callable[[int], None], seconds: float) -> float:
    """Calls of ``run(k)`` per second: k doubles until one timing lasts a third of ``seconds``; the best of that
    timing and two more (about 2 ``seconds`` in all). The caller has run every code path of ``run`` untimed first
    (numba compiles a kernel at its first call)."""
    k = 1
    while True:
        start = time.perf_counter()
        run(k)
        elapsed = time.perf_counter() - start
        if elapsed >= seconds / 3 or k >= 1 << 24:
            break
        k *= 2 if elapsed > 0 else 16
    best = elapsed
    for _ in range(2):
        start = time.perf_counter()
        run(k)
        best = min(best, time.perf_counter() - start)
    return k / best


def fixed_actions(space: gym.Space, count: int, seed: int = 0) -> list:
    space.seed(seed)
    return [space.sample() for _ in range(count)]


def single_rate(env_id: str, seconds: float) -> float:
    """Steps per second of one env through ``gymnasium.make``, resetting (timed, not counted) at each episode's
    end, after one untimed episode."""
    env = gym.make(env_id)
    env.reset(seed=0)
    actions = fixed_actions(env.action_space, 256)

    def run(k: int) -> bool:
        ended = False
        for i in range(k):
            _, _, terminated, truncated, _ = env.step(actions[i & 255])
            if terminated or truncated:
                env.reset()
                ended = True
        return ended

    while not run(1):
        pass
    return rate(run, seconds)


def vector_env(env_id: str, num_envs: int) -> tuple[gym.vector.VectorEnv, list]:
    """The native vector env reset with seed 0, and the eight actions its loops cycle through."""
    env = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    return env, fixed_actions(env.action_space, 8)


def vector_rate(env_id: str, num_envs: int, seconds: float) -> float:
    """Env-steps per second (``step`` calls times ``num_envs``) of the native vector env, after untimed steps up to
    and including the first autoreset (so that every kernel has compiled)."""
    env, actions = vector_env(env_id, num_envs)
    i = 0
    while True:
        _, _, terminated, truncated, _ = env.step(actions[i & 7])
        i += 1
        if terminated.any() or truncated.any():
            env.step(actions[i & 7])
            break

    def run(k: int) -> None:
        for i in range(k):
            env.step(actions[i & 7])

    return rate(run, seconds) * num_envs


def transition_share(env_id: str, num_envs: int) -> float:
    """The share of the vector loop's counted env-steps that are transitions (not the autoreset that follows an
    episode's end), over an untimed run of at least 256 steps and 16,384 env-steps."""
    env, actions = vector_env(env_id, num_envs)
    steps = max(256, 16384 // num_envs)
    ended = np.zeros(num_envs, dtype=bool)
    resets = 0
    for i in range(steps):
        resets += np.count_nonzero(ended)
        _, _, terminated, truncated, _ = env.step(actions[i & 7])
        ended = terminated | truncated
    return 1.0 - resets / (steps * num_envs)


def predict_rate(env_id: str, num_envs: int, seconds: float) -> float:
    """Observations per second of the analytic controller's ``predict`` on a batch of the vector env's reset
    observations (ProjectileAdjust's: before any shot, so without the wind estimate of its later shots)."""
    env = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point")
    obs, _ = env.reset(seed=0)
    controller = controller_for(env)

    def run(k: int) -> None:
        for _ in range(k):
            controller.predict(obs)

    return rate(run, seconds) * num_envs


def paired(measure_one: Callable[[str], float], env_id: str, rounds: int = 3) -> tuple[float, float, float]:
    """``rounds`` back-to-back pairs of ``measure_one`` (CartPole, then ``env_id``): the best CartPole rate, the
    best env rate and the median of the pairs' ratios (each pair sees the same load from other processes)."""
    pairs = [(measure_one(CARTPOLE), measure_one(env_id)) for _ in range(rounds)]
    return (
        max(c for c, _ in pairs),
        max(e for _, e in pairs),
        statistics.median(e / c for c, e in pairs),
    )


def measure(env_ids: list[str], seconds: float, pairs: int = 3) -> dict:
    """Rates of every env and of CartPole measured right before each, by column, in ``pairs`` pairs."""
    columns: dict[str, Callable[[str], float]] = {"single": lambda e: single_rate(e, seconds)}
    for n in VECTOR_SIZES:
        columns[f"vector_{n}"] = lambda e, n=n: vector_rate(e, n, seconds)
    results: dict = {"pairs": pairs, "cartpole": {}, "envs": {}}
    for env_id in env_ids:
        row: dict = {"cartpole": {}, "ratio": {}}
        for column, measure_one in columns.items():
            row["cartpole"][column], row[column], row["ratio"][column] = paired(measure_one, env_id, pairs)
        row["predict_8192"] = predict_rate(env_id, 8192, seconds)
        row["transition_share"] = {f"vector_{n}": transition_share(env_id, n) for n in VECTOR_SIZES}
        results["envs"][env_id] = row
    for column in columns:
        results["cartpole"][column] = statistics.median(row["cartpole"][column] for row in results["envs"].values())
    results["cartpole"]["transition_share"] = {f"vector_{n}": transition_share(CARTPOLE, n) for n in VECTOR_SIZES}
    for row in results["envs"].values():
        row["ratio_per_transition"] = {
            column: row["ratio"][column] * share / results["cartpole"]["transition_share"][column]
            for column, share in row["transition_share"].items()
        }
    results["peak_memory_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return results


def table(results: dict) -> str:
    cart = results["cartpole"]
    columns = ["single", *(f"vector_{n}" for n in VECTOR_SIZES)]
    header = "| env | " + " | ".join(columns) + " | predict_8192 (obs/s) |"
    lines = [header, "|" + "---|" * (len(columns) + 2)]
    lines.append(f"| {CARTPOLE} (median) | " + " | ".join(f"{cart[c]:.3g}" for c in columns) + " | - |")
    for env_id, row in results["envs"].items():
        cells = [f"{row[c]:.3g} ({row['ratio'][c]:.2f}x)" for c in columns]
        lines.append(f"| {env_id} | " + " | ".join(cells) + f" | {row['predict_8192']:.3g} |")
    pairs = results["pairs"]
    lines.append(
        f"\nsteps/s, best of {pairs} (median ratio of {pairs} back-to-back pairs with CartPole, same loop); "
        f"peak memory {results['peak_memory_mib']:.0f} MiB\n"
    )
    vector_columns = [f"vector_{n}" for n in VECTOR_SIZES]
    lines.append("| env | " + " | ".join(vector_columns) + " |")
    lines.append("|" + "---|" * (len(vector_columns) + 1))
    shares = cart["transition_share"]
    lines.append(f"| {CARTPOLE} | " + " | ".join(f"{shares[c]:.3f}" for c in vector_columns) + " |")
    for env_id, row in results["envs"].items():
        cells = [f"{row['transition_share'][c]:.3f} ({row['ratio_per_transition'][c]:.2f}x)" for c in vector_columns]
        lines.append(f"| {env_id} | " + " | ".join(cells) + " |")
    lines.append(
        "\nshare of the counted env-steps that are transitions, not autoresets (ratio to CartPole per transition: "
        "the median ratio above times the env's share over CartPole's)"
    )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument(
        "--seconds",
        type=float,
        default=0.5,
        help="a timing lasts 1/3 to 2/3 of it; a measurement, the best of three, about twice it (s, default 0.5)",
    )
    parser.add_argument("--pairs", type=int, default=3, help="back-to-back pairs with CartPole per cell (default: 3)")
    parser.add_argument(
        "--envs", nargs="+", default=list(vegym.ENVS), help="vegym env ids, e.g. Aircraft-v0 (default: all)"
    )
    args = parser.parse_args()
    try:
        env_ids = [vegym.resolve_env_id(name) for name in args.envs]
    except ValueError as exc:
        parser.error(str(exc))
    if args.pairs < 1:
        parser.error(f"--pairs={args.pairs} is outside the allowed range [1, inf)")
    results = measure(env_ids, args.seconds, args.pairs)
    print(json.dumps(results, indent=2) if args.json else table(results))


if __name__ == "__main__":
    main()
