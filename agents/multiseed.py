"""Training one agent on several seeds at once: one process per seed, at most ``jobs`` at a time.

Each seed trains into its own run directory ``<out>/seed_<k>/`` (:func:`agents.training.seed_dir`) exactly as a
single ``vegym train --seed k`` would, and reports its progress to the parent, which shows one progress line per
seed. A seed that fails is reported with its error and the others go on. Ctrl-C reaches every worker (same
process group) or, sent to the parent alone (SIGINT or SIGTERM), is passed on to them: each saves its model at the
next step, as a single run does; no seed that has not started is started afterwards.
"""

from __future__ import annotations

import multiprocessing as mp
import queue
import signal
import time
import traceback
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from multiprocessing import resource_tracker
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

import torch
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from stable_baselines3.common.callbacks import BaseCallback

from agents.config import TrainConfig, with_overrides
from agents.training import (
    REPEAT_WINDOW_S,
    TrainResult,
    check_run_dir,
    interrupts_handled,
    latest_model,
    raise_keyboard_interrupt,
    resume_config,
    seed_dir,
    train,
)

REPORT_EVERY_S = 1.0
"""Seconds between a worker's progress reports."""


@dataclass(frozen=True)
class SeedOutcome:
    """How one seed's training ended: its result, or the error that stopped it."""

    seed: int
    result: TrainResult | None = None
    error: str | None = None

    @property
    def ok(self) -> bool:
        """Trained to the end (not failed, not interrupted)."""
        return self.result is not None and not self.result.interrupted


class _ReportProgress(BaseCallback):
    """Puts ``("started", seed, steps)`` on the parent's queue as the training starts (the steps a resumed model
    holds, else 0), then ``("progress", seed, steps)`` at most every :data:`REPORT_EVERY_S`."""

    def __init__(self, seed: int, channel: Any) -> None:
        super().__init__()
        self.seed = seed
        self.channel = channel
        self._last = 0.0

    def _on_training_start(self) -> None:
        self.channel.put(("started", self.seed, self.num_timesteps))

    def _on_step(self) -> bool:
        now = time.monotonic()
        if now - self._last >= REPORT_EVERY_S:
            self._last = now
            self.channel.put(("progress", self.seed, self.num_timesteps))
        return True


NOT_STARTED = "not started (interrupted)"
"""The error of a seed that an interruption kept from training."""


def _train_seed(
    config: TrainConfig, out: Path, resume: bool, command: str | None, threads: int, channel: Any, stop: Any
) -> None:
    """Worker process: train one seed, then put ``("done", seed, result)`` or ``("failed", seed, error)``; setting
    the event ``stop`` stops it as Ctrl-C does."""
    try:
        _block_sigint(False)  # a Ctrl-C that came while this process started is raised here
        torch.set_num_threads(threads)
        result = train(
            config,
            out,
            resume=resume,
            progress_bar=False,
            command=command,
            callbacks=[_ReportProgress(config.seed, channel)],
            stop=stop,
            verbose=False,  # the parent shows one progress line per seed
            exiting=True,
        )
        channel.put(("done", config.seed, result))
    except KeyboardInterrupt:
        channel.put(("failed", config.seed, NOT_STARTED))
    except Exception as exc:  # reported to the parent, which carries on with the other seeds
        detail = "".join(traceback.format_exception_only(exc)).strip()
        channel.put(("failed", config.seed, f"{detail}\n{traceback.format_exc()}"))


def seed_configs(config: TrainConfig, seeds: Sequence[int]) -> dict[int, TrainConfig]:
    """The config of every seed: ``config`` with its seed replaced."""
    return {s: with_overrides(config, {"seed": s}, f"seed {s}") for s in seeds}


def resumed_configs(
    out: Path, seeds: Sequence[int], env_id: str, algo: str, n_timesteps: int | None = None
) -> dict[int, TrainConfig]:
    """Each seed's saved config, to resume it (with a new total ``n_timesteps`` if given); ValueError if a seed
    holds no run, no model to resume from, or a run of another env or algorithm."""
    configs = {s: resume_config(seed_dir(out, s), n_timesteps) for s in seeds}
    for seed in seeds:  # a worker cut down before its first save left a config and no model: refused before any starts
        check_run_dir(seed_dir(out, seed), resume=True)
    for seed, config in configs.items():
        if (config.env_id, config.algo) != (env_id, algo):
            where = seed_dir(out, seed)
            raise ValueError(f"--resume: {where} is {config.algo} on {config.env_id}, not {algo} on {env_id}")
    return configs


def train_seeds(
    configs: dict[int, TrainConfig],
    out: Path,
    *,
    jobs: int,
    resumed: Collection[int] = (),
    commands: dict[int, str] | None = None,
    threads: int = 1,
    progress_bar: bool = True,
    log: Callable[[str], None] = print,
) -> list[SeedOutcome]:
    """Train every seed's config into ``out/seed_<k>`` in worker processes, ``jobs`` at a time; the ``resumed``
    seeds continue their runs there (``train(resume=True)``), the others start afresh."""
    if jobs < 1:
        raise ValueError(f"jobs={jobs!r} must be at least 1")
    if latest_model(Path(out)) is not None:
        raise ValueError(f"{out} holds a single training run (model.zip): choose another --out for seed_<k>/ runs")
    context = mp.get_context("spawn")
    channel, stop = context.Queue(), context.Event()
    pending = list(configs)
    running: dict[int, BaseProcess] = {}
    outcomes: dict[int, SeedOutcome] = {}
    stopping, stopped_at = False, 0.0
    with (
        interrupts_handled(raise_keyboard_interrupt),
        Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            disable=not progress_bar,
        ) as progress,
    ):
        bars = {s: progress.add_task(f"seed {s}", total=configs[s].n_timesteps, start=False) for s in configs}
        while running or (pending and not stopping):
            try:
                while pending and len(running) < jobs and not stopping:
                    seed = pending[0]
                    command = (commands or {}).get(seed)
                    args = (configs[seed], seed_dir(out, seed), seed in resumed, command, threads, channel, stop)
                    process = context.Process(target=_train_seed, args=args, name=f"vegym-train-seed-{seed}")
                    _block_sigint(True)  # inherited: the worker's imports run before it can handle a Ctrl-C
                    try:
                        process.start()
                        running[seed] = process
                        pending.pop(0)
                    finally:
                        _block_sigint(False)  # here a Ctrl-C that came meanwhile is raised, the worker known
                    progress.start_task(bars[seed])
                    start = "resuming the run in" if seed in resumed else "training into"
                    log(f"seed {seed}: {start} {seed_dir(out, seed)}")
                _collect(channel, running, outcomes, progress, bars, log)
            except KeyboardInterrupt:
                if stopping:
                    if time.monotonic() - stopped_at > REPEAT_WINDOW_S:
                        raise
                    continue
                stopping, stopped_at = True, time.monotonic()
                stop.set()  # for workers that the Ctrl-C did not reach (a signal to this process alone)
                log("interrupted: the running seeds save their models; Ctrl-C again to abort")
        for seed in pending:
            outcomes[seed] = SeedOutcome(seed, error=NOT_STARTED)
            progress.update(bars[seed], description=f"seed {seed}: not started")  # its bar, unstarted, pulses
    return [outcomes[s] for s in configs]


def _block_sigint(block: bool) -> None:
    """Block SIGINT in this thread, or unblock it (a pending one is then handled); nothing where signal masks are
    not available. A process started while it is blocked starts with it blocked: its Ctrl-C waits until
    :func:`_train_seed` can report the seed as not started, instead of ending the process in its imports."""
    if not hasattr(signal, "pthread_sigmask"):
        return
    if block:  # multiprocessing starts its resource tracker with the first process, then unblocks SIGINT
        resource_tracker.ensure_running()
    signal.pthread_sigmask(signal.SIG_BLOCK if block else signal.SIG_UNBLOCK, {signal.SIGINT})


def _collect(
    channel: Any,
    running: dict[int, BaseProcess],
    outcomes: dict[int, SeedOutcome],
    progress: Progress,
    bars: dict[int, Any],
    log: Callable[[str], None],
) -> None:
    """Apply the workers' messages for up to 0.2 s; reap the workers that have exited."""
    try:
        kind, seed, payload = channel.get(timeout=0.2)
    except queue.Empty:
        kind = None
    if kind == "progress":
        progress.update(bars[seed], completed=payload)
    elif kind == "started":
        progress.update(bars[seed], completed=payload)
        if payload:
            log(f"seed {seed}: resumed at {payload} steps")
    elif kind == "done":
        outcomes[seed] = SeedOutcome(seed, result=payload)
        if payload.interrupted:  # short of its total, which the bar keeps
            progress.update(bars[seed], completed=payload.timesteps)
        else:  # its total as trained: rounded up to whole collections, or more already held
            progress.update(bars[seed], total=payload.timesteps, completed=payload.timesteps)
        progress.stop_task(bars[seed])
        if payload.interrupted or payload.trained:
            state = "interrupted at" if payload.interrupted else "done after"
            log(f"seed {seed}: {state} {payload.timesteps} steps in {payload.wall_time_s:.0f} s: {payload.model_path}")
        else:
            log(f"seed {seed}: nothing to train: {payload.model_path} already holds {payload.timesteps} steps")
    elif kind == "failed":
        outcomes[seed] = SeedOutcome(seed, error=payload)
        progress.stop_task(bars[seed])
        log(f"seed {seed}: {payload}" if payload == NOT_STARTED else f"seed {seed}: FAILED: {payload.splitlines()[0]}")
    for s, process in list(running.items()):
        if process.exitcode is None:
            continue
        if s not in outcomes and channel.empty():
            outcomes[s] = SeedOutcome(s, error=f"worker exited with code {process.exitcode} without a result")
            log(f"seed {s}: FAILED: {outcomes[s].error}")
        if s in outcomes:
            process.join()
            del running[s]
