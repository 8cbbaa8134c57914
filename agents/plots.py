"""Figures and animations of evaluations: normalized-score bars, trajectory overlays, episode GIFs.

Figures use matplotlib's object API (``Figure``, saved through the Agg canvas), never pyplot, so no display
or global backend is involved. Trajectory plots overlay the first evaluated episode of several agents (the
analytic controller, references and learned agents); :data:`TRAJECTORY_PLOTS` holds the env-specific ones,
and any other env gets :func:`plot_generic` (observations, actions and the running return against the step).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import imageio.v3 as iio
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from agents.config import make_kwargs
from agents.evaluation import AgentFactory, EvalResult
from vegym import env_name
from vegym.envs.projectile import ProjectileTask

MAX_GIF_FRAMES = 100
MAX_GIF_SECONDS = 10.0
MAX_OBS_PANELS = 8


def _grid(count: int, title: str) -> tuple[Figure, list[Axes]]:
    cols = min(count, 3)
    rows = math.ceil(count / cols)
    fig = Figure(figsize=(4.2 * cols, 2.8 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    fig.suptitle(title)
    flat = list(axes.ravel())
    for ax in flat[count:]:
        ax.set_visible(False)
    return fig, flat[:count]


def plot_generic(results: Sequence[EvalResult], params: Any) -> Figure:
    """Each observation entry (the first few), each action entry and the running return, against the step."""
    first = results[0].episodes[0]
    n_obs = min(first.observations.shape[1], MAX_OBS_PANELS)
    n_act = first.actions.shape[1]
    fig, axes = _grid(n_obs + n_act + 1, f"{results[0].env_id}: first evaluation episode")
    for r in results:
        ep = r.episodes[0]
        for i in range(n_obs):
            axes[i].plot(ep.observations[:, i], label=r.agent)
            axes[i].set_title(f"observation[{i}]")
        for j in range(n_act):
            axes[n_obs + j].step(np.arange(1, len(ep.actions) + 1), ep.actions[:, j], label=r.agent)
            axes[n_obs + j].set_title(f"action[{j}]")
        axes[-1].plot(np.arange(len(ep.rewards) + 1), np.concatenate([[0.0], np.cumsum(ep.rewards)]), label=r.agent)
        axes[-1].set_title("return so far")
    for ax in axes:
        ax.set_xlabel("step")
    axes[-1].legend()
    return fig


def plot_bouncing_ball(results: Sequence[EvalResult], params: Any) -> Figure:
    """Apex height of every bounce against its target, first episode."""
    fig = Figure(figsize=(7, 4))
    ax = fig.subplots()
    for r in results:
        infos = r.episodes[0].infos
        ax.plot(range(1, len(infos) + 1), [i["apex_height"] for i in infos], "o-", label=r.agent)
    targets = [i["target_height"] for i in results[0].episodes[0].infos]
    ax.plot(range(1, len(targets) + 1), targets, "kx", markersize=10, label="target")
    ax.set(xlabel="bounce", ylabel="apex height (m)", title=f"{results[0].env_id}: apex heights, first episode")
    ax.legend()
    return fig


def plot_projectile(results: Sequence[EvalResult], params: Any) -> Figure:
    """Landing points of every episode relative to the target, along and across the line of fire."""
    fig = Figure(figsize=(6, 6))
    ax = fig.subplots()
    radius = 0.0
    for r in results:
        shots = {k: np.array([ep.infos[-1][k] for ep in r.episodes]) for k in ("launch_position", "target")}
        miss = np.array([ep.infos[-1]["landing_point"] for ep in r.episodes]) - shots["target"]
        _, _, (along, across) = ProjectileTask.target_frame(shots)
        offsets_arr = np.stack([np.sum(miss * along, axis=1), np.sum(miss * across, axis=1)], axis=-1)
        ax.plot(offsets_arr[:, 0], offsets_arr[:, 1], "o", alpha=0.7, label=r.agent)
        radius = max(radius, float(np.abs(offsets_arr).max()))
    ax.add_patch(Circle((0.0, 0.0), params.hit_radius, fill=False, color="k", label="hit radius"))
    half = 1.1 * max(radius, 2.0 * params.hit_radius)
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal")
    ax.set(xlabel="long (+) / short (-) of the target (m)", ylabel="across the line of fire (m)")
    ax.set_title(f"{results[0].env_id}: landing points of all episodes")
    ax.legend()
    return fig


def plot_steerable_wheel(results: Sequence[EvalResult], params: Any) -> Figure:
    """Top view of the wheel's path, first episode; dots where a waypoint was passed."""
    fig = Figure(figsize=(6, 6))
    ax = fig.subplots()
    for r in results:
        infos = r.episodes[0].infos
        path = np.array([i["position"] for i in infos])
        (line,) = ax.plot(path[:, 0], path[:, 1], label=r.agent)
        passed = np.flatnonzero(np.diff([0] + [i["waypoint_index"] for i in infos]) > 0)
        ax.plot(path[passed, 0], path[passed, 1], "o", color=line.get_color())
    h = params.half_size
    ax.plot([-h, h, h, -h, -h], [-h, -h, h, h, -h], "k-", linewidth=0.8, label="arena")
    ax.set_aspect("equal")
    ax.set(xlabel="x (m)", ylabel="z (m)", title=f"{results[0].env_id}: path, first episode (dots: waypoints)")
    ax.legend()
    return fig


def plot_aircraft(results: Sequence[EvalResult], params: Any) -> Figure:
    """Altitude and airspeed against their demands and the heading error over time, first episode."""
    fig = Figure(figsize=(8, 7))
    axes = fig.subplots(3, 1, sharex=True)
    for r in results:
        infos = r.episodes[0].infos
        t = np.cumsum([i["dt"] for i in infos])
        axes[0].plot(t, [i["position"][1] for i in infos], label=r.agent)
        axes[1].plot(t, [i["speed"] for i in infos], label=r.agent)
        axes[2].plot(t, [math.degrees(i["errors"][2]) for i in infos], label=r.agent)
    infos = results[0].episodes[0].infos
    t = np.cumsum([i["dt"] for i in infos])
    axes[0].plot(t, [i["demand"][0] for i in infos], "k--", label="demand")
    axes[1].plot(t, [i["demand"][1] for i in infos], "k--", label="demand")
    axes[0].set_ylabel("altitude (m)")
    axes[1].set_ylabel("airspeed (m/s)")
    axes[2].set_ylabel("heading error (deg)")
    axes[2].set_xlabel("time (s)")
    axes[0].set_title(f"{results[0].env_id}: first episode")
    axes[0].legend()
    fig.tight_layout()
    return fig


TRAJECTORY_PLOTS: dict[str, Callable[[Sequence[EvalResult], Any], Figure]] = {
    "vegym/BouncingBall-v0": plot_bouncing_ball,
    "vegym/Projectile-v0": plot_projectile,
    "vegym/SteerableWheel-v0": plot_steerable_wheel,
    "vegym/Aircraft-v0": plot_aircraft,
    "vegym/AircraftGusty-v0": plot_aircraft,
}
"""Env-specific trajectory plots, from the evaluated episodes and the env's parameters; other envs use
:func:`plot_generic`."""


def save_trajectory_plot(
    results: Sequence[EvalResult], path: Path, env_kwargs: Mapping[str, Any] | None = None
) -> None:
    """Overlay the agents of ``results`` (one env, made with ``env_kwargs``) and save a PNG."""
    env_id = results[0].env_id
    env = gym.make(env_id, **dict(env_kwargs or {}))
    params = env.unwrapped.params
    env.close()
    fig = TRAJECTORY_PLOTS.get(env_id, plot_generic)(results, params)
    fig.savefig(path, dpi=100, bbox_inches="tight")


def save_score_chart(records: Sequence[dict], path: Path) -> None:
    """Bars of the mean normalized score per env and agent with its 95% CI as an error bar (random, 0 by
    definition, left out)."""
    envs = list(dict.fromkeys(r["env_id"] for r in records))
    agents = list(dict.fromkeys(r["agent"] for r in records if r["agent"] != "random"))
    colors = {agent: f"C{k}" for k, agent in enumerate(agents)}
    width = 0.8 / max(sum(r["env_id"] == e and r["agent"] != "random" for r in records) for e in envs)
    fig = Figure(figsize=(max(6.0, 1.8 * len(envs)), 4))
    ax = fig.subplots()
    labelled = set()
    for i, env_id in enumerate(envs):
        shown = [r for r in records if r["env_id"] == env_id and r["agent"] != "random"]
        for k, r in enumerate(shown):
            value = r["normalized_score"] if r["normalized_score"] is not None else np.nan
            interval = r["ci95_normalized_score"]
            # clipped at 0: a point interval's bounds and the mean may differ by rounding
            error = None if interval is None else [[max(value - interval[0], 0.0)], [max(interval[1] - value, 0.0)]]
            label = None if r["agent"] in labelled else r["agent"]
            labelled.add(r["agent"])
            x = i + (k - (len(shown) - 1) / 2) * width
            ax.bar(x, value, width, color=colors[r["agent"]], label=label, yerr=error, capsize=2, ecolor="0.3")
    ax.axhline(1.0, color="k", linewidth=0.8)
    ax.axhline(0.9, color="k", linewidth=0.8, linestyle="--")
    ax.set_xticks(np.arange(len(envs)), [env_name(e) for e in envs])
    ax.set_ylabel("normalized score")
    ax.set_title("(R - R_random) / (R_analytic - R_random), 95% CI over seeds and episodes; dashed: 0.9")
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def save_episode_gif(
    env_id: str,
    factory: AgentFactory,
    seed: int,
    path: Path,
    env_kwargs: Mapping[str, Any] | None = None,
    max_frames: int = MAX_GIF_FRAMES,
) -> None:
    """An animated GIF of one deterministic episode from ``reset(seed=seed)``, rendered with ``rgb_array``.

    Long episodes keep every k-th frame (at most ``max_frames``); playback runs at the env's frame rate, sped up
    to last at most ``MAX_GIF_SECONDS``.
    """
    env = gym.make(env_id, render_mode="rgb_array", **make_kwargs(env_id, env_kwargs or {}))
    try:
        limit = env.spec.max_episode_steps if env.spec is not None and env.spec.max_episode_steps else max_frames
        stride = max(1, math.ceil(limit / max_frames))
        agent = factory(env)
        obs, _ = env.reset(seed=seed)
        frames = [env.render()]
        state, steps, done = None, 0, False
        while not done:
            start = np.array([steps == 0])
            action, state = agent.predict(obs, state=state, episode_start=start, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action)
            steps += 1
            done = terminated or truncated
            if done or steps % stride == 0:
                frames.append(env.render())
        fps = float(env.metadata["render_fps"])
    finally:
        env.close()
    duration_ms = max(40.0, min(1000.0 * stride / fps, 1000.0 * MAX_GIF_SECONDS / len(frames)))
    iio.imwrite(path, np.stack(frames), duration=duration_ms, loop=0)
