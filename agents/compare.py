"""``vegym compare``: every env's analytic controller, random policy, references and learned agents, side by side.

Learned agents are the directories ``<models>/<Env-v0>/<algo>/``: one run (``model.zip`` and its
``config.yml``) or one run per training seed in ``seed_<k>/``; the shipped ones are in ``agents/pretrained/``.
Every training seed is evaluated on the same episodes; the table and ``compare.json`` give the mean, the
interquartile mean and their 95% crossed-bootstrap confidence intervals over seeds and episodes
(:mod:`agents.statistics`). ``retrain`` remakes the agents from the committed configs. Output: ``compare.json``
(one record per env and agent), ``compare.md``, ``normalized_scores.png`` (with the CIs as error bars), per env
``<Env-v0>_trajectory.png`` and one ``<Env-v0>_<agent>.gif`` per agent (a learned agent's first seed).
"""

from __future__ import annotations

import json
import math
import os
import shlex
import shutil
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from agents.basics import EVAL_SEED
from agents.config import ALGOS, CONFIG_DIR, TrainConfig, load_config, make_kwargs, read_yaml, save_resolved
from agents.evaluation import (
    EvalResult,
    SeededFactories,
    agent_factories,
    evaluate_agents,
    load_seeded,
    short_runs,
)
from agents.multiseed import seed_configs, train_seeds
from agents.training import (
    CHECKPOINT_DIR,
    CONFIG_FILE,
    EVAL_DIR,
    resume_config,
    resume_source,
    seed_dir,
    seed_runs,
)
from vegym import env_name

PRETRAINED_DIR = Path(__file__).resolve().parent / "pretrained"
"""The shipped learned agents: ``<Env-v0>/<algo>/``."""
DEFAULT_SEEDS = (0, 1, 2)
"""Training seeds of a retrained agent (as of the shipped core agents)."""
BY_PRODUCTS = (CHECKPOINT_DIR, EVAL_DIR, "tb")
"""Training by-products a retrained shipped agent does not keep."""


def find_models(models_dir: Path, env_id: str, algos: Sequence[str]) -> dict[str, Path]:
    """The agent directories of ``env_id``'s learned agents under ``models_dir`` that hold a trained run, by
    algorithm."""
    base = Path(models_dir) / env_name(env_id)
    return {algo: base / algo for algo in algos if seed_runs(base / algo)}


def configured_algos(env_id: str, algos: Sequence[str]) -> list[str]:
    """The algorithms among ``algos`` whose committed config has an entry for ``env_id``."""
    return [algo for algo in algos if env_id in (read_yaml(CONFIG_DIR / f"{algo}.yml") or {})]


def _display(path: Path) -> str:
    """``path`` relative to the working directory when it lies below it."""
    return os.path.relpath(path) if Path(path).resolve().is_relative_to(Path.cwd()) else str(path)


def train_command(
    env_id: str,
    algo: str,
    out: Path,
    timesteps: int | None = None,
    *,
    seed: int | None = None,
    seeds: Sequence[int] | None = None,
    config: str | None = None,
    progress: bool = True,
) -> str:
    """The ``vegym train`` command that trains ``algo`` on ``env_id`` from the committed config (or ``config``)
    into ``out``: with ``seed``, that seed's run; with ``seeds``, one run per seed in ``out/seed_<k>``."""
    args = ["vegym", "train", "--env", env_name(env_id), "--algo", algo]
    if seed is not None:
        args += ["--seed", str(seed)]
    if seeds is not None:
        args += ["--seeds", ",".join(map(str, seeds))]
    if config is not None:
        args += ["--config", config]
    args += ["--out", _display(out)]
    if timesteps is not None:
        args += ["--timesteps", str(timesteps)]
    return shlex.join(args if progress else [*args, "--no-progress"])


def retrain(
    env_id: str,
    models_dir: Path,
    algos: Sequence[str],
    seeds: Sequence[int] = DEFAULT_SEEDS,
    jobs: int = 2,
    timesteps: int | None = None,
    progress_bar: bool = True,
    log: Callable[[str], None] = print,
) -> dict[str, Path]:
    """Train every configured algorithm of ``algos`` on ``env_id`` afresh, one run per seed, into
    ``<models_dir>/<Env-v0>/<algo>/seed_<k>``; RuntimeError if a seed fails, KeyboardInterrupt if stopped.

    The runs are trained beside it, in ``<algo>.retraining/``, and replace the agent only when every seed has
    finished: a failed or interrupted retraining leaves the agent as it was and its partial runs there, which the
    next retraining resumes where their config is the one it trains (:func:`partial_runs`)."""
    agents = {}
    for algo in configured_algos(env_id, algos):
        out = Path(models_dir) / env_name(env_id) / algo
        staging = out.with_name(f"{algo}.retraining")
        overrides = {} if timesteps is None else {"n_timesteps": timesteps}
        configs = seed_configs(load_config(CONFIG_DIR / f"{algo}.yml", env_id, algo, overrides), seeds)
        resumed = partial_runs(staging, configs)
        if staging.exists():
            discarded = sorted(set(staging.iterdir()) - {seed_dir(staging, s) for s in resumed})
            if discarded:
                names = ", ".join(path.name for path in discarded)
                log(f"{env_id} {algo}: discarding {names} in {_display(staging)} (other seeds or settings)")
            for path in discarded:
                shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
        if resumed:
            log(f"{env_id} {algo}: resuming the partial runs of seeds {sorted(resumed)} in {_display(staging)}")
        # each run records how the agent it becomes was made: its place after the swap
        commands = {s: train_command(env_id, algo, seed_dir(out, s), timesteps, seed=s) for s in seeds}
        outcomes = train_seeds(
            configs,
            staging,
            jobs=jobs,
            resumed=resumed,
            commands=commands,
            progress_bar=progress_bar,
            log=log,
        )
        kept = f"{_display(out)} is unchanged; the partial runs are in {_display(staging)}, and retraining resumes them"
        if any(o.result is not None and o.result.interrupted for o in outcomes):
            log(f"{env_id} {algo}: retraining interrupted; {kept}")
            raise KeyboardInterrupt
        failed = [o for o in outcomes if o.error is not None]
        if failed:
            raise RuntimeError(f"{env_id} {algo}: seed {failed[0].seed} failed: {failed[0].error} ({kept})")
        for seed in seeds:
            for name in BY_PRODUCTS:
                shutil.rmtree(seed_dir(staging, seed) / name, ignore_errors=True)
            # the retraining's config, total steps included, also for a resumed run that already held them
            save_resolved(configs[seed], seed_dir(staging, seed) / CONFIG_FILE)
        shutil.rmtree(out, ignore_errors=True)
        staging.rename(out)
        agents[algo] = out
    return agents


def partial_runs(staging: Path, configs: Mapping[int, TrainConfig]) -> set[int]:
    """The seeds of ``configs`` whose run in ``staging`` (a retraining's, left by a failure or an interrupt) goes
    on: a run with the seed's config but for the total steps, which the new config sets, and a model that loads."""
    resumable = set()
    for seed, config in configs.items():
        run = seed_dir(staging, seed)
        try:
            if resume_config(run, config.n_timesteps) != config:
                continue
            with warnings.catch_warnings():  # a cut-short checkpoint: the resumed run's own warning names it
                warnings.simplefilter("ignore")
                resume_source(run, config)
        except ValueError:  # no run, a config this version no longer reads, or no model that loads
            continue
        resumable.add(seed)
    return resumable


def _missing_note(env_id: str, models_dir: Path, algos: Sequence[str]) -> str:
    """Why an env has no learned row, and how to make one."""
    where = _display(Path(models_dir) / env_name(env_id))
    configured = configured_algos(env_id, algos)
    if configured:
        out = Path(models_dir) / env_name(env_id) / configured[0]
        command = train_command(env_id, configured[0], out, seeds=DEFAULT_SEEDS)
        how = f"train one: `{command}`"
    else:
        how = f"no entry for {env_id} in configs/{{{','.join(algos)}}}.yml yet"
    return f"no learned {'/'.join(algos)} agent in {where}; showing the analytic and random agents only ({how})"


def _learned(agents: dict[str, Path], env_id: str) -> tuple[dict[str, SeededFactories], dict[str, Any]]:
    """Factories of the learned agents (one per training seed) and the env kwargs they share (ValueError if
    they differ)."""
    factories: dict[str, SeededFactories] = {}
    env_kwargs: dict[str, dict[str, Any]] = {}
    for algo, path in agents.items():
        seeded, config = load_seeded(path)
        if config.env_id != env_id:
            raise ValueError(f"{path}: trained on {config.env_id}, not {env_id}")
        factories[algo] = seeded
        env_kwargs[algo] = config.env_kwargs
    distinct = {json.dumps(make_kwargs(env_id, kw), sort_keys=True) for kw in env_kwargs.values()}
    if len(distinct) > 1:
        raise ValueError(f"{env_id}: the learned agents were trained with different env_kwargs: {env_kwargs}")
    return factories, next(iter(env_kwargs.values()), {})


def _fmt(value: float | None, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if abs(value) < 1e-12:
        value = 0.0  # rounding residue, e.g. the random policy's mean normalized score (0 by definition)
    return f"{value:.{digits}g}" if abs(value) >= 1e4 or (value != 0 and abs(value) < 1e-3) else f"{value:.{digits}f}"


TABLE_COLUMNS = (
    "env",
    "agent",
    "seeds",
    "return (mean ± std)",
    "success",
    "normalized [95% CI]",
    "IQM [95% CI]",
    "vs reference",
    "control metrics",
)


def _with_ci(value: float | None, interval: Sequence[float] | None) -> str:
    if value is None:
        return "-"
    return _fmt(value) if interval is None else f"{_fmt(value)} [{_fmt(interval[0])}, {_fmt(interval[1])}]"


def table_rows(records: Sequence[dict[str, Any]]) -> list[list[str]]:
    """The comparison table as text cells (one row per record), in :data:`TABLE_COLUMNS` order."""
    rows = []
    for r in records:
        vs = ", ".join(f"{ref}: {_fmt(v)}" for ref, v in r["normalized_score_vs"].items()) or "-"
        metrics = ", ".join(f"{k}={_fmt(v)}" for k, v in r["metrics"].items())
        rows.append(
            [
                env_name(r["env_id"]),
                r["agent"],
                "-" if r["seeds"] is None else str(len(r["seeds"])),
                f"{_fmt(r['mean_return'])} ± {_fmt(r['std_return'])}",
                "-" if r["success_rate"] is None else f"{100 * r['success_rate']:.0f}%",
                _with_ci(r["normalized_score"], r["ci95_normalized_score"]),
                _with_ci(r["iqm_normalized_score"], r["ci95_iqm_normalized_score"]),
                vs,
                metrics,
            ]
        )
    return rows


def markdown(
    records: Sequence[dict[str, Any]], notes: Sequence[str], images: Sequence[str], episodes: int, seed: int
) -> str:
    """``compare.md``: the table, the notes and the figures."""
    lines = [
        "# vegym compare",
        "",
        f"{episodes} episodes per env and agent (and per training seed of a learned agent; *seeds*: how many), "
        f"episode seeds {seed}..{seed + episodes - 1}, deterministic actions. "
        "normalized = (R - mean R_random) / (mean R_analytic - mean R_random) per episode, the baselines' means "
        "over the same episodes, averaged; IQM: the interquartile mean of the same scores; [95% CI]: bootstrap "
        "resampling the training seeds and, shared by them and by the baselines, the episodes (a resample "
        "normalizes by the baselines' means over its episodes: the analytic controller's interval is [1, 1]); "
        "*vs reference*: the mean against a stronger reference (BouncingBall: `planner`, planning over the shown "
        "targets, and `oracle`, the exact optimum knowing every future target; AircraftGusty: "
        "`draft-compensating`, the autopilot with draft feed-forward; Suspension: `continuous-skyhook`, the clipped "
        "continuous skyhook).",
        "",
        "| " + " | ".join(TABLE_COLUMNS) + " |",
        "|" + "---|" * len(TABLE_COLUMNS),
    ]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(records)]
    if notes:
        lines += ["", *[f"- {note}" for note in notes]]
    lines += ["", *[f"![{Path(image).stem}]({image})" for image in images], ""]
    return "\n".join(lines)


def compare(
    env_ids: Sequence[str],
    out: Path,
    episodes: int = 20,
    seed: int = EVAL_SEED,
    models_dir: Path = PRETRAINED_DIR,
    algos: Sequence[str] | None = None,
    retrain_agents: bool = False,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    jobs: int = 2,
    timesteps: int | None = None,
    progress_bar: bool = True,
    log: Callable[[str], None] = print,
) -> tuple[list[dict[str, Any]], list[str]]:
    """Evaluate and draw every env of ``env_ids``; write the files into ``out``, rewritten after each env (a later
    env's failure keeps the earlier ones' results); return the records and notes. The learned agents are those of
    ``algos`` under ``models_dir`` (None: of every algorithm); with ``retrain_agents`` those of ``algos`` are
    trained first, or for None those of the algorithms shipped for the env (``agents/pretrained``: the agents
    that the README's tables show)."""
    from agents.plots import save_episode_gif, save_score_chart, save_trajectory_plot  # matplotlib: only to draw

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    records: list[dict[str, Any]] = []
    notes: list[str] = []
    images = ["normalized_scores.png"]
    learned = tuple(ALGOS) if algos is None else algos
    for env_id in env_ids:
        name = env_name(env_id)
        if retrain_agents:
            # by default those shipped for the env, or where none is, every algorithm with a config entry
            trained = algos if algos is not None else list(find_models(PRETRAINED_DIR, env_id, learned)) or learned
            log(f"{name}: retraining {', '.join(configured_algos(env_id, trained)) or 'nothing (no config entry)'}")
            retrain(env_id, models_dir, trained, seeds, jobs, timesteps, progress_bar, log)
        runs = find_models(models_dir, env_id, learned)
        if not runs:
            notes.append(f"{name}: {_missing_note(env_id, models_dir, learned)}")
            log(notes[-1])
        factories, env_kwargs = _learned(runs, env_id)
        for line in (line for path in runs.values() for line in short_runs(path)):
            notes.append(f"{name}: {line}")
            log(f"note: {notes[-1]}")
        log(f"{name}: evaluating {', '.join(agent_factories(env_id, factories, seed))} on {episodes} episodes")
        results = evaluate_agents(env_id, factories, episodes, seed, env_kwargs)
        records += [r.record() for r in results]
        shown: list[EvalResult] = [r for r in results if r.agent != "random"]
        save_trajectory_plot(shown, out / f"{name}_trajectory.png", env_kwargs)
        images.append(f"{name}_trajectory.png")
        for agent, factory in agent_factories(env_id, factories, seed).items():
            if isinstance(factory, Mapping):
                factory = next(iter(factory.values()))
            save_episode_gif(env_id, factory, seed, out / f"{name}_{agent}.gif", env_kwargs)
            images.append(f"{name}_{agent}.gif")
        # after every env, so that a failure or Ctrl-C in a later one keeps the evaluations done
        (out / "compare.json").write_text(json.dumps(records, indent=2) + "\n")
        save_score_chart(records, out / "normalized_scores.png")
        (out / "compare.md").write_text(markdown(records, notes, images, episodes, seed))
    return records, notes
