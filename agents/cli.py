"""The ``vegym`` command: ``list``, ``train``, ``evaluate``, ``compare``, ``sweep`` and ``demo`` (``vegym COMMAND
--help``)."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import tempfile
import textwrap
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
from rich.console import Console
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text

import vegym
from agents.basics import ALGO_NAMES, EVAL_SEED, whole_number
from vegym import env_name

if TYPE_CHECKING:  # the commands import the pipeline (torch, SB3, scipy) when they run
    from agents.config import TrainConfig

console = Console(highlight=False, width=None if sys.stdout.isatty() else 160)
RETRAIN_SEEDS, RETRAIN_JOBS = [0, 1, 2], 2
"""``vegym compare --retrain``'s training seeds and seeds trained at once, unless --seeds and --jobs say."""


def say(message: str, style: str | None = None) -> None:
    """Print a message as plain text (no rich markup: paths and ranges contain brackets)."""
    console.print(Text(message, style=style or ""), soft_wrap=True)


def _integer(text: str) -> int:
    """An integer, also written as a float without a fraction (1e5), as the configs take one."""
    number = whole_number(text)
    if number is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer")
    return number


def _positive(text: str) -> int:
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not a positive integer")
    return value


def _non_negative(text: str) -> int:
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative")
    return value


def _print_table(title: str, columns: Sequence[str], rows: Sequence[Sequence[str]], wrap: int = 1) -> None:
    """A table whose last ``wrap`` columns wrap in a terminal; the others keep their cells on one line. Into a pipe
    or file, at its full width: nothing is cut short."""
    table = Table(title=title)
    for k, column in enumerate(columns):
        table.add_column(column, no_wrap=k < len(columns) - wrap)
    for row in rows:
        table.add_row(*(Text(cell) for cell in row))
    if console.is_terminal:
        console.print(table)
    else:  # print's width cannot exceed its console's
        width = Measurement.get(console, console.options.update_width(sys.maxsize), table).maximum
        Console(highlight=False, width=max(width, console.width)).print(table)


def cmd_list(args: argparse.Namespace) -> int:
    """Print the registered envs."""
    from agents.analytic import REFERENCE_AGENTS, controller_for

    rows = []
    for env_id, spec in vegym.ENVS.items():
        env = gym.make(env_id)
        controller = type(controller_for(env))
        baseline = controller.__name__ + "".join(f" (+{ref})" for ref in REFERENCE_AGENTS.get(env_id, {}))
        rows.append(
            [
                env_id,
                str(env.action_space.shape[0]),
                str(env.observation_space.shape[0]),
                str(spec["max_episode_steps"]),
                baseline,
                str(spec["summary"]),
            ]
        )
        env.close()
    _print_table("vegym envs", ["id", "actions", "observations", "step limit", "analytic baseline", "task"], rows)
    return 0


def _seed_list(text: str) -> list[int]:
    try:
        seeds = [int(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of seeds, e.g. 0,1,2") from None
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"{text!r}: give distinct non-negative seeds, e.g. 0,1,2")
    return seeds


def cmd_train(args: argparse.Namespace) -> int:
    """Train an SB3 agent from a config, on one seed or on several in parallel."""
    import torch

    from agents.training import CONFIG_FILE, check_run_dir, held_timesteps, resume_config, train

    env_id = vegym.resolve_env_id(args.env)
    out = Path(args.out) if args.out else Path("runs") / env_name(env_id) / args.algo
    torch.set_num_threads(args.threads)
    if args.seeds is not None:
        return _train_seeds(args, env_id, out)
    if args.resume:
        if args.config is not None or args.seed is not None:
            raise ValueError("--resume continues with the run's saved config.yml; drop --config and --seed")
        config = resume_config(out, args.timesteps)
        if (config.env_id, config.algo) != (env_id, args.algo):
            raise ValueError(
                f"--resume: {out / CONFIG_FILE} is {config.algo} on {config.env_id}, not {args.algo} on {env_id}"
            )
    else:
        config = _load_train_config(args, env_id, args.seed)
    command = shlex.join(["vegym", *args.argv]) if not args.resume else None
    planned, trained = f"{config.n_timesteps} steps", config.trained_steps(config.n_timesteps)
    if trained != config.n_timesteps and not args.resume:
        planned += f" ({trained}: SB3 collects {config.collection_steps} steps at a time)"
    source = check_run_dir(out, args.resume)  # before the line below, which would announce a run that does not start
    if source is None:
        say(f"training {config.algo} on {config.env_id} for {planned} into {out}")
    else:
        held = held_timesteps(source)
        start = source.name if held is None else f"{held} steps ({source.name})"
        say(f"resuming {config.algo} on {config.env_id} in {out} from {start}, to {planned} in all")
    result = train(config, out, resume=args.resume, progress_bar=not args.no_progress, command=command, exiting=True)
    if result.interrupted:
        say(f"interrupted at {result.timesteps} steps; saved {result.model_path}; continue with --resume")
        return 130
    if result.trained == 0:
        held = f"{result.timesteps} steps, its total of {config.n_timesteps} or more"
        say(f"nothing to train: {result.model_path} already holds {held}")
        return 0
    say(f"saved {result.model_path} after {result.timesteps} steps in {result.wall_time_s:.1f} s")
    return 0


def _load_train_config(args: argparse.Namespace, env_id: str, seed: int | None) -> TrainConfig:
    """The config entry of ``env_id`` in ``--config`` (default configs/<algo>.yml) with the command's overrides."""
    from agents.config import CONFIG_DIR, load_config

    overrides = {key: value for key, value in (("seed", seed), ("n_timesteps", args.timesteps)) if value is not None}
    config_path = Path(args.config) if args.config else CONFIG_DIR / f"{args.algo}.yml"
    return load_config(config_path, env_id, args.algo, overrides)


def _train_seeds(args: argparse.Namespace, env_id: str, out: Path) -> int:
    """``vegym train --seeds``: one run per seed in ``out/seed_<k>``, ``--jobs`` processes at a time."""
    from agents.compare import train_command
    from agents.multiseed import NOT_STARTED, resumed_configs, seed_configs, train_seeds
    from agents.training import seed_dir

    if args.seed is not None:
        raise ValueError("give either --seed or --seeds")
    if args.resume and args.config is not None:
        raise ValueError("--resume continues with each seed's saved config.yml; drop --config")
    if args.resume:
        configs = resumed_configs(out, args.seeds, env_id, args.algo, args.timesteps)
    else:
        configs = seed_configs(_load_train_config(args, env_id, None), args.seeds)
    commands = {
        seed: train_command(
            env_id, args.algo, seed_dir(out, seed), args.timesteps, seed=seed, config=args.config, progress=False
        )
        for seed in args.seeds
    }
    jobs = min(args.jobs, len(args.seeds))
    say(f"training {args.algo} on {env_id} with seeds {args.seeds}, {jobs} at a time, into {out}/seed_<k>")
    outcomes = train_seeds(
        configs,
        out,
        jobs=jobs,
        resumed=list(configs) if args.resume else (),
        commands=None if args.resume else commands,
        threads=args.threads,
        progress_bar=not args.no_progress,
        log=say,
    )
    failed = [o.seed for o in outcomes if o.error is not None and o.error != NOT_STARTED]
    not_started = [o.seed for o in outcomes if o.error == NOT_STARTED]
    interrupted = [o.seed for o in outcomes if o.result is not None and o.result.interrupted]
    done = [o.seed for o in outcomes if o.ok and o.result is not None and o.result.trained]
    untouched = [o.seed for o in outcomes if o.ok and o.result is not None and not o.result.trained]
    say(
        f"trained seeds {done or 'none'}"
        + (f"; nothing to train for {untouched}" if untouched else "")
        + (f"; failed: {failed}" if failed else "")
    )
    if interrupted or not_started:
        if interrupted:
            say(f"interrupted seeds {interrupted} saved their models")
        if not_started:
            say(f"seeds {not_started} did not start")
        base = ["vegym", "train", "--env", env_name(env_id), "--algo", args.algo, "--out", str(out)]
        to_resume = interrupted + (not_started if args.resume else [])  # resumed runs that did not start still are
        if to_resume:
            say(f"continue with: {shlex.join([*base, '--resume', '--seeds', ','.join(map(str, to_resume))])}")
        if not_started and not args.resume:
            options = [
                *(["--config", args.config] if args.config else []),
                *(["--timesteps", str(args.timesteps)] if args.timesteps else []),
            ]
            say(f"train the others with: {shlex.join([*base, *options, '--seeds', ','.join(map(str, not_started))])}")
        return 130
    return 1 if failed else 0


def _check_output(path: Path, suffix: str | None = None, makes_parents: bool = False) -> None:
    """Refuse an output file that could not be written (or not in the format of ``suffix``), before the work that
    makes it (ValueError); ``makes_parents``: its writer creates missing directories."""
    if suffix is not None and path.suffix.lower() != suffix:
        raise ValueError(f"{path}: the file name must end in {suffix}")
    if path.is_dir():
        raise ValueError(f"{path}: it is a directory")
    folder = next(p for p in path.parents if p.exists()) if makes_parents else path.parent
    if not folder.is_dir():
        raise ValueError(f"{path}: no directory {folder}")
    try:
        if path.exists():
            path.open("a").close()  # appends nothing
        else:
            tempfile.TemporaryFile(dir=folder).close()
    except OSError as exc:
        raise ValueError(f"{path}: cannot be written ({exc.strerror})") from None


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Evaluate one agent; print its metrics as a table and JSON."""
    from agents.compare import TABLE_COLUMNS, table_rows
    from agents.evaluation import agent_factory, evaluate_agents, short_runs

    env_id = vegym.resolve_env_id(args.env)
    if args.json:
        _check_output(Path(args.json))
    name, factory, config = agent_factory(args.agent, env_id, args.seed)
    if config is not None:
        for line in short_runs(Path(args.agent)):
            say(f"note: {line} (an interrupted run; `vegym train --resume` goes on)", "yellow")
    env_kwargs = config.env_kwargs if config is not None else {}
    results = evaluate_agents(env_id, {name: factory}, args.episodes, args.seed, env_kwargs)
    record = next(r.record() for r in results if r.agent == name)
    cells = table_rows([record])[0]
    rows = [[column, cell] for column, cell in zip(TABLE_COLUMNS[:-1], cells, strict=False)]
    if record["seeds"] is not None:  # the seeds themselves, where compare's column counts them
        rows[TABLE_COLUMNS.index("seeds")] = ["training seeds", ", ".join(map(str, record["seeds"]))]
    rows += [[key, f"{value:.4g}"] for key, value in record["metrics"].items()]
    _print_table(f"{name} on {env_id}: {args.episodes} episodes from seed {args.seed}", ["metric", "value"], rows)
    text = json.dumps(record, indent=2)
    if args.json:
        Path(args.json).write_text(text + "\n")
        say(f"wrote {args.json}")
    else:
        print(text)
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    """Compare agents on every env; write the report files."""
    retraining = [f"--{name}" for name in ("seeds", "jobs", "timesteps") if getattr(args, name) is not None]
    if retraining and not args.retrain:
        raise ValueError(f"{', '.join(retraining)} set how --retrain trains; without --retrain nothing is trained")
    if not args.retrain and not Path(args.models).is_dir():
        raise ValueError(f"--models {args.models}: no such directory (--retrain trains agents into a new one)")
    import torch

    from agents.compare import TABLE_COLUMNS, compare, table_rows

    torch.set_num_threads(args.threads)
    env_ids = [vegym.resolve_env_id(e) for e in args.envs] if args.envs else list(vegym.ENVS)
    start = time.perf_counter()
    records, notes = compare(
        env_ids,
        Path(args.out),
        episodes=args.episodes,
        seed=args.seed,
        models_dir=Path(args.models),
        algos=args.algos,
        retrain_agents=args.retrain,
        seeds=args.seeds or RETRAIN_SEEDS,
        jobs=args.jobs or RETRAIN_JOBS,
        timesteps=args.timesteps,
        progress_bar=not args.no_progress,
        log=say,
    )
    _print_table(
        f"vegym compare ({args.episodes} episodes, seeds from {args.seed})", TABLE_COLUMNS, table_rows(records)
    )
    for note in notes:
        say(f"note: {note}", "yellow")
    say(f"wrote {args.out}/compare.json, compare.md and figures in {time.perf_counter() - start:.0f} s")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run (or join, or resume) an Optuna study over the algorithm's hyperparameters."""
    from agents.sweep import (
        FINISHED,
        SWEEPS_DIR,
        SweepSettings,
        default_storage,
        parse_tune_env,
        sweep,
        write_best_config,
    )

    env_id = vegym.resolve_env_id(args.env)
    study_name = args.study or f"{env_name(env_id)}-{args.algo}"
    out = Path(args.best) if args.best else SWEEPS_DIR / f"{study_name}_best.yml"
    _check_output(out, makes_parents=True)
    settings = SweepSettings(
        env_id=env_id,
        algo=args.algo,
        trials=args.trials,
        storage=args.storage or default_storage(study_name),
        study=study_name,
        timesteps=args.timesteps,
        eval_episodes=args.eval_episodes,
        tune_env=parse_tune_env(args.tune_env, env_id),
        heartbeat=args.heartbeat,
    )
    start = time.perf_counter()
    study = sweep(settings, args.workers, args.threads, log=say)
    finished = study.get_trials(deepcopy=False, states=FINISHED)
    say(f"{len(finished)} trials finished in the study ({time.perf_counter() - start:.0f} s in this command)")
    say(write_best_config(study, settings, out).rstrip())
    train_it = shlex.join(["vegym", "train", "--env", env_name(env_id), "--algo", args.algo, "--config", str(out)])
    say(f"wrote {out}: train it with `{train_it}`")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """Show episodes on screen, or save one as a GIF."""
    from agents.config import make_kwargs
    from agents.evaluation import agent_factory, run_episode

    env_id = vegym.resolve_env_id(args.env)
    if args.gif:
        _check_output(Path(args.gif), ".gif")
    name, factory, config = agent_factory(args.agent, env_id, args.seed)
    env_kwargs = config.env_kwargs if config is not None else {}
    if isinstance(factory, Mapping):
        if len(factory) > 1:
            say(f"showing the agent of training seed {next(iter(factory))}")
        factory = next(iter(factory.values()))
    if args.gif:
        from agents.plots import save_episode_gif

        save_episode_gif(env_id, factory, args.seed, Path(args.gif), env_kwargs)
        say(f"wrote {args.gif}")
        return 0
    _check_display()
    env = gym.make(env_id, render_mode="human", **make_kwargs(env_id, env_kwargs))
    try:
        agent = factory(env)
        for k in range(args.episodes):
            episode = run_episode(env, agent, args.seed + k)
            say(f"{name} episode {k} (seed {args.seed + k}): return {episode.ret:.3f}, success {episode.success}")
            time.sleep(1.0)
    finally:
        env.close()
    return 0


def _check_display() -> None:
    """ValueError where SDL finds no display to open a window on (unless ``SDL_VIDEODRIVER`` asks for one that
    shows nothing); the display is started here, as the window would start it."""
    import pygame

    from vegym.render.window import start_display

    fallback = start_display()
    if fallback is not None:
        pygame.display.quit()
        raise ValueError(f"no display to show the episodes on (SDL fell back to {fallback!r}); write a GIF with --gif")


class _HelpFormatter(argparse.HelpFormatter):
    """argparse's help, its lines broken at spaces only (not inside names such as ``draft-compensating``)."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)


class _Parser(argparse.ArgumentParser):
    """An argument parser with :class:`_HelpFormatter`, the subcommands' too."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(formatter_class=_HelpFormatter, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vegym`` and its subcommands."""
    parser = _Parser(
        prog="vegym",
        description="Train, evaluate and compare agents on the vegym envs against the chapter's analytic controllers.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_Parser)
    env_help = "env id, e.g. BouncingBall-v0 or vegym/BouncingBall-v0"
    agent_help = (
        "analytic (the default), random, a reference of the env (planner or oracle for BouncingBall, "
        "draft-compensating for AircraftGusty, continuous-skyhook for Suspension) or a model path (run dir or .zip)"
    )
    threads_help = "torch threads (default 1: small MLPs train fastest on one; more only oversubscribe the CPU)"
    seed_help = f"seed of the first episode; episode k uses seed + k (default {EVAL_SEED})"

    p = sub.add_parser("list", help="list the registered envs", description="List the registered envs.")
    p.set_defaults(func=cmd_list)

    p = sub.add_parser(
        "train",
        help="train an SB3 agent from a config",
        description="Train an SB3 agent from configs/<algo>.yml (or --config): progress bar, periodic evaluation, "
        "checkpoints, TensorBoard logs if tensorboard is installed, the resolved config saved beside the model. "
        "Ctrl-C saves the model and exits (status 130); --resume continues from the newest checkpoint or model.",
    )
    p.add_argument("--env", required=True, help=env_help)
    p.add_argument("--algo", required=True, choices=ALGO_NAMES, help="algorithm")
    p.add_argument("--config", help="config file (default: configs/<algo>.yml)")
    p.add_argument("--seed", type=_non_negative, help="seed (default: the config's, else 0)")
    p.add_argument(
        "--seeds",
        type=_seed_list,
        help="train one model per seed, e.g. 0,1,2, into OUT/seed_<k> (processes in parallel, see --jobs)",
    )
    p.add_argument("--jobs", type=_positive, default=2, help="with --seeds: seeds trained at once (default 2)")
    p.add_argument(
        "--timesteps",
        type=_positive,
        help="total env steps (default: the config's n_timesteps), rounded up to whole rollouts",
    )
    p.add_argument("--out", help="run directory (default: runs/<Env-v0>/<algo>)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out (with --seeds: every seed's)")
    p.add_argument("--threads", type=_positive, default=1, help=threads_help)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_train)

    p = sub.add_parser(
        "evaluate",
        help="evaluate one agent",
        description="Evaluate one agent on fixed seeds: mean and std of return, success rate, normalized score "
        "(R - R_random) / (R_analytic - R_random), the task's control metrics; a table and JSON.",
    )
    p.add_argument("--env", required=True, help=env_help)
    p.add_argument("--agent", default="analytic", help=agent_help)
    p.add_argument("--episodes", type=_positive, default=20, help="episodes (default 20)")
    p.add_argument("--seed", type=_non_negative, default=EVAL_SEED, help=seed_help)
    p.add_argument("--json", help="write the JSON record to this file instead of printing it")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser(
        "compare",
        help="compare analytic, random and learned agents on every env",
        description="For each env: the analytic controller, the random policy, the env's references and the "
        "learned agents (<models>/<Env-v0>/<algo>/), on the same seeds. Prints a table and writes "
        "OUT/compare.json, OUT/compare.md, a bar chart of normalized scores, a trajectory plot per env and a GIF "
        "per env and agent.",
    )
    p.add_argument("--envs", nargs="+", help="env ids (default: every registered env)")
    p.add_argument("--episodes", type=_positive, default=20, help="episodes per env and agent (default 20)")
    p.add_argument("--seed", type=_non_negative, default=EVAL_SEED, help=seed_help)
    p.add_argument("--out", default="compare_out", help="output directory (default compare_out)")
    p.add_argument(
        "--models",
        default=str(Path(__file__).resolve().parent / "pretrained"),
        help="learned agents' directory (default: the shipped agents/pretrained)",
    )
    p.add_argument(
        "--algos",
        nargs="+",
        choices=ALGO_NAMES,
        help="learned algorithms to include (default: every one; with --retrain, those of the shipped agents)",
    )
    p.add_argument(
        "--retrain",
        action="store_true",
        help="retrain the learned agents from the committed configs first: for each env those of --algos, by default "
        "the algorithms shipped for it in agents/pretrained (PPO; also SAC for Billiards)",
    )
    p.add_argument("--seeds", type=_seed_list, help="with --retrain: training seeds (default 0,1,2)")
    p.add_argument("--jobs", type=_positive, help="with --retrain: seeds trained at once (default 2)")
    p.add_argument("--timesteps", type=_positive, help="with --retrain: override every config's n_timesteps")
    p.add_argument("--no-progress", action="store_true", help="no progress bar while retraining")
    p.add_argument("--threads", type=_positive, default=1, help=threads_help)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser(
        "sweep",
        help="tune hyperparameters with an Optuna study (SQLite, or PostgreSQL across machines)",
        description="An Optuna study over the algorithm's hyperparameters: each trial trains the env's committed "
        "config with sampled values and is scored by its mean normalized score on fixed evaluation episodes; weak "
        "trials are pruned from periodic evaluations. The study lives in --storage (default: a SQLite file in "
        "runs/sweeps/); give a PostgreSQL URL and run the same command on several machines to share one study. "
        "Running the command again resumes the study until it holds --trials finished trials; trials of workers "
        "that died are retried. The best trial is written as a configs/<algo>.yml block.",
    )
    p.add_argument("--env", required=True, help=env_help)
    p.add_argument("--algo", required=True, choices=ALGO_NAMES, help="algorithm")
    p.add_argument("--trials", type=_positive, required=True, help="finished trials the study should hold")
    p.add_argument("--timesteps", type=_positive, help="training steps per trial (default: the config's)")
    p.add_argument("--storage", help="Optuna RDB URL, e.g. postgresql://user:pw@host/db (default: SQLite file)")
    p.add_argument("--study", help="study name (default <Env-v0>-<algo>)")
    p.add_argument("--workers", type=_positive, default=1, help="worker processes on this machine (default 1)")
    p.add_argument("--eval-episodes", type=_positive, default=10, help="episodes per evaluation (default 10)")
    p.add_argument(
        "--tune-env",
        action="append",
        default=[],
        metavar="NAME=LOW:HIGH",
        help="also sample this env parameter (e.g. a reward weight) uniformly in [LOW, HIGH]; repeatable",
    )
    p.add_argument(
        "--heartbeat", type=_positive, default=60, help="seconds between heartbeats; 2x silent = dead (default 60)"
    )
    p.add_argument("--best", help="where to write the best config (default runs/sweeps/<study>_best.yml)")
    p.add_argument("--threads", type=_positive, default=1, help=threads_help)
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser(
        "demo",
        help="show an agent's episodes on screen or save a GIF",
        description="Render episodes of an agent on screen (render_mode=human), or one episode to a GIF (--gif).",
    )
    p.add_argument("--env", required=True, help=env_help)
    p.add_argument("--agent", default="analytic", help=agent_help)
    p.add_argument("--episodes", type=_positive, default=1, help="episodes to show (default 1; --gif writes one)")
    p.add_argument("--seed", type=_non_negative, default=0, help="seed of the first episode (default 0)")
    p.add_argument("--gif", help="write one episode to this GIF instead of opening a window")
    p.set_defaults(func=cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vegym`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    args.argv = argv
    try:
        return args.func(args)
    except ValueError as exc:  # agents.config.ConfigError too
        say(f"error: {exc}", "red")
        return 2
    except (RuntimeError, OSError) as exc:
        say(f"error: {exc}", "red")
        return 1
    except KeyboardInterrupt:
        say("interrupted")
        return 130


if __name__ == "__main__":
    sys.exit(main())
