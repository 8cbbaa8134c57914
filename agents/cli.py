"""The ``vegym`` command: ``list``, ``train``, ``evaluate``, ``compare`` and ``demo`` (``vegym COMMAND --help``)."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym
from rich.console import Console
from rich.table import Table
from rich.text import Text

import vegym
from agents.config import ALGOS, CONFIG_DIR, ConfigError, env_name, load_config, resolve_env_id
from agents.evaluation import EVAL_SEED, REFERENCE_AGENTS, agent_factory, evaluate_agents, run_episode

console = Console(highlight=False, width=None if sys.stdout.isatty() else 160)


def say(message: str, style: str | None = None) -> None:
    """Print a message as plain text (no rich markup: paths and ranges contain brackets)."""
    console.print(Text(message, style=style or ""), soft_wrap=True)


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not a positive integer")
    return value


def _non_negative(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is negative")
    return value


def _print_table(title: str, columns: Sequence[str], rows: Sequence[Sequence[str]], wrap: int = 1) -> None:
    """A table whose last ``wrap`` columns wrap; the others keep their cells on one line."""
    table = Table(title=title)
    for k, column in enumerate(columns):
        table.add_column(column, no_wrap=k < len(columns) - wrap)
    for row in rows:
        table.add_row(*(Text(cell) for cell in row))
    console.print(table)


def cmd_list(args: argparse.Namespace) -> int:
    """Print the registered envs."""
    from agents.analytic import controller_for

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
    _print_table("vegym envs", ["id", "actions", "observations", "steps", "analytic baseline", "task"], rows)
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    """Train an SB3 agent from a config."""
    import torch

    from agents.training import CONFIG_FILE, resume_config, train

    env_id = resolve_env_id(args.env)
    out = Path(args.out) if args.out else Path("runs") / env_name(env_id) / args.algo
    torch.set_num_threads(args.threads)
    if args.resume:
        if args.config is not None or args.seed is not None:
            raise SystemExit("--resume continues with the run's saved config.yml; drop --config and --seed")
        config = resume_config(out, args.timesteps)
        if (config.env_id, config.algo) != (env_id, args.algo):
            raise SystemExit(f"--resume: {out / CONFIG_FILE} is {config.algo} on {config.env_id}")
    else:
        overrides = {
            key: value for key, value in (("seed", args.seed), ("n_timesteps", args.timesteps)) if value is not None
        }
        config_path = Path(args.config) if args.config else CONFIG_DIR / f"{args.algo}.yml"
        config = load_config(config_path, env_id, args.algo, overrides)
    command = shlex.join(["vegym", *args.argv]) if not args.resume else None
    say(f"training {config.algo} on {config.env_id} for {config.n_timesteps} steps into {out}")
    result = train(config, out, resume=args.resume, progress_bar=not args.no_progress, command=command)
    if result.interrupted:
        say(f"interrupted at {result.timesteps} steps; saved {result.model_path}; continue with --resume")
        return 130
    say(f"saved {result.model_path} after {result.timesteps} steps in {result.wall_time_s:.1f} s")
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Evaluate one agent; print its metrics as a table and JSON."""
    from agents.compare import TABLE_COLUMNS, table_rows

    env_id = resolve_env_id(args.env)
    name, factory, config = agent_factory(args.agent, env_id, args.seed)
    env_kwargs = config.env_kwargs if config is not None else {}
    results = evaluate_agents(env_id, {name: factory}, args.episodes, args.seed, env_kwargs)
    record = next(r.record() for r in results if r.agent == name)
    cells = table_rows([record])[0]
    rows = [[column, cell] for column, cell in zip(TABLE_COLUMNS[:-1], cells, strict=False)]
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
    import torch

    from agents.compare import TABLE_COLUMNS, compare, table_rows

    torch.set_num_threads(args.threads)
    env_ids = [resolve_env_id(e) for e in args.envs] if args.envs else list(vegym.ENVS)
    start = time.perf_counter()
    records, notes = compare(
        env_ids,
        Path(args.out),
        episodes=args.episodes,
        seed=args.seed,
        models_dir=Path(args.models),
        algos=args.algos,
        retrain_agents=args.retrain,
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


def cmd_demo(args: argparse.Namespace) -> int:
    """Show episodes on screen, or save one as a GIF."""
    env_id = resolve_env_id(args.env)
    name, factory, config = agent_factory(args.agent, env_id, args.seed)
    env_kwargs = config.env_kwargs if config is not None else {}
    if args.gif:
        from agents.plots import save_episode_gif

        save_episode_gif(env_id, factory, args.seed, Path(args.gif), env_kwargs)
        say(f"wrote {args.gif}")
        return 0
    env = gym.make(env_id, render_mode="human", **env_kwargs)
    try:
        agent = factory(env)
        for k in range(args.episodes):
            episode = run_episode(env, agent, args.seed + k)
            say(f"{name} episode {k} (seed {args.seed + k}): return {episode.ret:.3f}, success {episode.success}")
            time.sleep(1.0)
    finally:
        env.close()
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vegym`` and its subcommands."""
    parser = argparse.ArgumentParser(
        prog="vegym",
        description="Train, evaluate and compare agents on the vegym envs against the chapter's analytic controllers.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    env_help = "env id, e.g. BouncingBall-v0 or vegym/BouncingBall-v0"
    agent_help = "analytic, random, a reference of the env (oracle for BouncingBall) or a model path (run dir or .zip)"
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
    p.add_argument("--algo", required=True, choices=list(ALGOS), help="algorithm")
    p.add_argument("--config", help="config file (default: configs/<algo>.yml)")
    p.add_argument("--seed", type=_non_negative, help="seed (default: the config's, else 0)")
    p.add_argument("--timesteps", type=_positive, help="total env steps (default: the config's n_timesteps)")
    p.add_argument("--out", help="run directory (default: runs/<Env-v0>/<algo>)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
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
    p.add_argument("--algos", nargs="+", choices=list(ALGOS), default=list(ALGOS), help="learned algorithms to include")
    p.add_argument("--retrain", action="store_true", help="retrain the learned agents from the committed configs first")
    p.add_argument("--timesteps", type=_positive, help="with --retrain: override every config's n_timesteps")
    p.add_argument("--no-progress", action="store_true", help="no progress bar while retraining")
    p.add_argument("--threads", type=_positive, default=1, help=threads_help)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser(
        "demo",
        help="show an agent's episodes on screen or save a GIF",
        description="Render episodes of an agent on screen (render_mode=human), or one episode to a GIF (--gif).",
    )
    p.add_argument("--env", required=True, help=env_help)
    p.add_argument("--agent", default="analytic", help=agent_help)
    p.add_argument("--episodes", type=_positive, default=1, help="episodes to show (default 1)")
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
    except (ConfigError, ValueError) as exc:
        say(f"error: {exc}", "red")
        return 2
    except KeyboardInterrupt:
        say("interrupted")
        return 130


if __name__ == "__main__":
    sys.exit(main())
