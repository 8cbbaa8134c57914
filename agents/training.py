"""Training with stable-baselines3 from a :class:`~agents.config.TrainConfig`.

A run directory holds ``model.zip``, ``config.yml`` (the resolved config), ``vecnormalize.pkl`` (with
normalisation), ``checkpoints/``, ``eval/evaluations.npz``, ``train_stats.json`` (steps and wall time),
``command.txt`` (when started from the CLI) and ``tb/`` (TensorBoard, only if it is installed). Ctrl-C stops
training at the next env step and saves the model; ``resume=True`` continues from the newest of the
checkpoints and ``model.zip``. Several training seeds of one agent live in ``seed_<k>/`` run directories
below one agent directory (:func:`seed_dir`, :func:`seed_runs`; trained in parallel by
:mod:`agents.multiseed`).
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import pickle
import re
import signal
import threading
import time
import warnings
import zipfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common import callbacks as sb3_callbacks
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback, ProgressBarCallback
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv, VecMonitor, VecNormalize

from agents.config import ConfigError, TrainConfig, load_resolved, make_kwargs, save_resolved, with_overrides
from agents.vec_adapter import VectorEnvAdapter

MODEL_FILE = "model.zip"
CONFIG_FILE = "config.yml"
COMMAND_FILE = "command.txt"
NORMALIZE_FILE = "vecnormalize.pkl"
REPLAY_FILE = "replay_buffer.pkl"
STATS_FILE = "train_stats.json"
CHECKPOINT_DIR = "checkpoints"
EVAL_DIR = "eval"
EVAL_FILE = "evaluations.npz"
CHECKPOINT_PREFIX = "model"
SEED_DIR_PREFIX = "seed_"
EVAL_SEED_OFFSET = 10_000
"""The training-time evaluation env is seeded ``seed + EVAL_SEED_OFFSET`` (apart from the training episodes)."""


def make_env(config: TrainConfig, seed: int, n_envs: int | None = None) -> VecEnv:
    """Monitored SB3 vector env of the config's env: the native vector env (adapted) if ``n_envs > 1``."""
    n = config.n_envs if n_envs is None else n_envs
    kwargs = make_kwargs(config.env_id, config.env_kwargs)
    if n > 1:
        native = gym.make_vec(config.env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
        venv: VecEnv = VectorEnvAdapter(native)
    else:
        venv = DummyVecEnv([lambda: gym.make(config.env_id, **kwargs)])
    venv.seed(seed)
    return VecMonitor(venv)


def build_model(config: TrainConfig, env: VecEnv, tensorboard_log: str | None = None) -> BaseAlgorithm:
    """An untrained model of the config's algorithm on ``env``, logging to TensorBoard in ``tensorboard_log`` or
    nowhere (:func:`log_nowhere_without_tensorboard`)."""
    kwargs = config.algo_kwargs(int(env.action_space.shape[0]))
    algo = config.algo_class
    model = algo(config.policy, env, seed=config.seed, tensorboard_log=tensorboard_log, verbose=0, **kwargs)
    return log_nowhere_without_tensorboard(model, tensorboard_log)


def log_nowhere_without_tensorboard(model: BaseAlgorithm, tensorboard_log: str | None) -> BaseAlgorithm:
    """``model``, given a logger that writes nothing when there is no ``tensorboard_log``: SB3's default one then
    writes nothing either, but makes an empty directory ``SB3-<date-time>`` in the system's temporary directory at
    every ``learn()`` (one per run, resumed run and sweep trial)."""
    if tensorboard_log is None:
        model.set_logger(Logger(folder=None, output_formats=[]))
    return model


def saved_timesteps(path: Path) -> int:
    """The ``num_timesteps`` stored in an SB3 model zip."""
    with zipfile.ZipFile(path) as archive:
        return int(json.loads(archive.read("data"))["num_timesteps"])


def held_timesteps(path: Path) -> int | None:
    """:func:`saved_timesteps`, or None for a file it cannot read (cut short, not a model zip)."""
    try:
        return saved_timesteps(path)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None


def normalize_path(model_path: Path) -> Path:
    """The VecNormalize statistics saved with a model: ``vecnormalize.pkl`` or a checkpoint's own file."""
    match = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", model_path.name)
    if match:
        return model_path.with_name(f"{CHECKPOINT_PREFIX}_vecnormalize_{match.group(1)}_steps.pkl")
    return model_path.with_name(NORMALIZE_FILE)


def seed_dir(out: Path, seed: int) -> Path:
    """The run directory of training seed ``seed`` in a multi-seed run ``out``: ``out/seed_<seed>``."""
    return Path(out) / f"{SEED_DIR_PREFIX}{seed}"


def seed_runs(agent_dir: Path) -> dict[int, Path]:
    """The trained runs of one agent by training seed: ``agent_dir`` itself if it holds a model (one seed, the
    one in its config), else its ``seed_<k>/`` directories holding a model; empty if there is none."""
    agent_dir = Path(agent_dir)
    runs = {}
    for path in agent_dir.glob(f"{SEED_DIR_PREFIX}*"):
        suffix = path.name[len(SEED_DIR_PREFIX) :]
        if suffix.isdigit() and (path / MODEL_FILE).is_file():
            runs[int(suffix)] = path
    if (agent_dir / MODEL_FILE).is_file():
        if runs:
            raise ValueError(f"{agent_dir} holds both a run (model.zip) and seed_<k>/ runs; keep one layout")
        return {load_resolved(agent_dir / CONFIG_FILE).seed: agent_dir}
    return dict(sorted(runs.items()))


def _models(run_dir: Path) -> list[Path]:
    """The models of ``run_dir`` (checkpoints and ``model.zip``), the most training steps first; a file whose step
    count cannot be read comes last."""
    candidates = sorted((run_dir / CHECKPOINT_DIR).glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"))
    if (run_dir / MODEL_FILE).exists():
        candidates.append(run_dir / MODEL_FILE)

    def steps(path: Path) -> int:
        held = held_timesteps(path)
        return -1 if held is None else held

    return sorted(candidates, key=steps, reverse=True)


def latest_model(run_dir: Path) -> Path | None:
    """The model of ``run_dir`` with the most training steps (checkpoints and ``model.zip``), or None."""
    return next(iter(_models(run_dir)), None)


def resume_source(run_dir: Path, config: TrainConfig) -> Path:
    """The model of ``run_dir`` with the most training steps that loads as ``config``'s algorithm, with its
    normalisation statistics if the config normalises: a checkpoint that an abort cut short (SB3 writes them in
    place) is skipped with a warning. ValueError if none loads."""
    skipped = []
    for path in _models(run_dir):
        try:
            config.algo_class.load(path, device="cpu")
            if config.normalize_kwargs() is not None:
                with open(normalize_path(path), "rb") as stats:
                    pickle.load(stats)
        except Exception as error:  # anything a cut-short file raises: zip, torch, pickle, missing files
            skipped.append(f"{path} ({type(error).__name__}: {error})")
            continue
        for line in skipped:
            warnings.warn(f"--resume: skipping {line}; resuming from {path}", stacklevel=2)
        return path
    raise ValueError(f"--resume: no model in {run_dir} loads: {'; '.join(skipped)}")


INTERRUPTS = (signal.SIGINT, signal.SIGTERM)
"""The signals that stop a training run cleanly: Ctrl-C, and a scheduler's or ``kill``'s default."""
REPEAT_WINDOW_S = 2.0
"""A second interrupt this soon after the first is the same one delivered twice (``timeout -s INT`` signals the
process and then its process group), not a request to abort. Measured when the handlers run, which a busy main
thread delays: 0.5 s proved too short on a loaded machine."""


@contextlib.contextmanager
def interrupts_handled(
    handler: Callable[[int, Any], None], leaving: Callable[[Any], Any] | None = None
) -> Iterator[None]:
    """``handler`` for the :data:`INTERRUPTS` until the block ends, the previous handlers after; in the main thread
    only, where Python runs signal handlers (elsewhere nothing changes). ``leaving``, if given, takes a previous
    handler and gives the one that replaces ``handler`` as the block ends, in one change: a signal never meets the
    previous handler in between."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, handler) for signum in INTERRUPTS}
    try:
        yield
    finally:
        for signum, before in previous.items():
            before = signal.SIG_DFL if before is None else before
            signal.signal(signum, before if leaving is None else leaving(before))


def raise_keyboard_interrupt(signum: int, frame: Any) -> None:
    """Signal handler: SIGINT or SIGTERM as Ctrl-C, also where SIGINT came in ignored (a background job of a
    script) and where SIGTERM would end a parent process without its workers."""
    raise KeyboardInterrupt


def _ignoring_repeats_until(deadline: float, before: Any) -> Callable[[int, Any], None]:
    """A handler for the :data:`INTERRUPTS` that ignores those that come before ``deadline`` (``time.monotonic``)
    and hands a later one back to ``before``, the handler it replaces, which then handles it."""

    def ignore_or_hand_back(signum: int, frame: Any) -> None:
        if time.monotonic() <= deadline:
            return
        signal.signal(signum, before)
        signal.raise_signal(signum)

    return ignore_or_hand_back


class StopOnInterrupt(BaseCallback):
    """Turns the first SIGINT (Ctrl-C) or SIGTERM within :meth:`catching` into a clean stop at the next env step; a
    later one aborts (KeyboardInterrupt), but for a repeat within ``REPEAT_WINDOW_S`` of the first, the same
    interrupt. Also stops there once ``stop`` (an event, e.g. a parent process's) is set. With ``exiting`` (the
    process ends after the run), such repeats are ignored after the block too: one that came as the process exited
    was raised in ``threading``'s shutdown or an exit handler, which printed its traceback."""

    def __init__(self, stop: Any = None, exiting: bool = False) -> None:
        super().__init__()
        self.interrupted = False
        self._stop = stop
        self._exiting = exiting
        self._first_at: float | None = None

    @contextlib.contextmanager
    def catching(self) -> Iterator[None]:
        """Catch the interrupts until the block ends: around the training and the saves after it, so that an
        interrupt never cuts a save short unasked. With ``exiting``, after an interrupt, repeats that come after
        the block are ignored until ``REPEAT_WINDOW_S`` after it; later ones go to the handlers from before."""
        with interrupts_handled(self._handle, self._after_block):
            yield

    def _after_block(self, before: Any) -> Any:
        """The handler that replaces :meth:`_handle` as the block ends: ``before``, or with ``exiting`` after an
        interrupt, one that ignores repeats until ``REPEAT_WINDOW_S`` after it, then hands back to ``before``."""
        if self._exiting and self._first_at is not None:
            return _ignoring_repeats_until(self._first_at + REPEAT_WINDOW_S, before)
        return before

    def _handle(self, signum: int, frame: Any) -> None:
        now = time.monotonic()
        if self._first_at is None:
            self._first_at, self.interrupted = now, True
        elif now - self._first_at > REPEAT_WINDOW_S:
            raise KeyboardInterrupt

    def _on_step(self) -> bool:
        if self._stop is not None and self._stop.is_set():
            self.interrupted = True
        return not self.interrupted


@contextlib.contextmanager
def _replacing(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix, which SB3's savers expect) to write, moved onto ``path`` once
    the block ends without error and removed if it raises: ``path`` holds the old file or the new one, never half
    of one (an abort during a save leaves the last complete model)."""
    partial = path.with_name(f".{path.stem}.partial{path.suffix}")
    try:
        yield partial
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)


@dataclass(frozen=True)
class TrainResult:
    """What a training run left behind."""

    model_path: Path
    timesteps: int
    interrupted: bool
    wall_time_s: float
    resumed_at: int = 0
    """Steps the run held when this call began: 0 for a new run, else those of the model it resumed from."""

    @property
    def trained(self) -> int:
        """Steps this call trained: 0 when a resumed run already held ``n_timesteps`` or more."""
        return self.timesteps - self.resumed_at


def _progress_bar_available() -> bool:
    return all(importlib.util.find_spec(m) is not None for m in ("tqdm", "rich"))


class WholeCollectionsProgressBar(ProgressBarCallback):
    """SB3's progress bar, its total the steps that ``learn`` trains (:meth:`TrainConfig.trained_steps`: the ones
    asked for rounded up to whole collections), where SB3's bar read 8,192/5,000."""

    def __init__(self, config: TrainConfig) -> None:
        super().__init__()
        self.config = config

    def _on_training_start(self) -> None:
        asked = self.locals["total_timesteps"] - self.model.num_timesteps
        self.pbar = sb3_callbacks.tqdm(total=self.config.trained_steps(asked))


def check_run_dir(out: Path, resume: bool) -> Path | None:
    """The model a run in ``out`` would start from (None for a fresh run); ValueError if ``out`` does not suit
    the run: a fresh one into a directory holding a run (its own or ``seed_<k>/`` ones), or a resumed one into
    a directory holding no model."""
    source = latest_model(out) if out.exists() else None
    if resume and source is None:
        raise ValueError(f"--resume: {out} holds no model or checkpoint to resume from")
    if not resume and source is not None:
        raise ValueError(f"{out} already holds a training run; pass --resume or choose another --out")
    if not resume and any(out.glob(f"{SEED_DIR_PREFIX}*/{MODEL_FILE}")):
        raise ValueError(f"{out} holds seed_<k>/ runs; train one seed into it with --seeds K, or choose another --out")
    return source


def train(
    config: TrainConfig,
    out: Path,
    *,
    resume: bool = False,
    progress_bar: bool = True,
    command: str | None = None,
    callbacks: Sequence[BaseCallback] = (),
    stop: Any = None,
    verbose: bool = True,
    exiting: bool = False,
) -> TrainResult:
    """Train ``config`` into the run directory ``out`` (see the module docstring); ``resume`` continues it.

    ``callbacks`` run beside the checkpoint, evaluation and Ctrl-C callbacks (progress reports, pruning); setting
    the event ``stop`` stops the training as Ctrl-C does; ``verbose`` prints SB3's report of each evaluation;
    ``command``, the command line that makes the run, goes to ``command.txt`` (a resumed run's replaces the old);
    ``exiting`` says that the process ends after the run (see :class:`StopOnInterrupt`). A resumed run whose
    ``model.zip`` already holds ``n_timesteps`` steps is left as it is.
    """
    out = Path(out)
    start = time.perf_counter()
    source = check_run_dir(out, resume)
    out.mkdir(parents=True, exist_ok=True)
    normalize = config.normalize_kwargs()
    if source is not None:
        source = resume_source(out, config)
    done = 0 if source is None else saved_timesteps(source)
    if source is not None and source.name == MODEL_FILE and done >= config.n_timesteps:
        return _nothing_to_train(out, done)  # the run, its config and its replay buffer stay as they are
    env = make_env(config, config.seed + done)
    eval_env = make_env(config, config.seed + EVAL_SEED_OFFSET, n_envs=1)
    if normalize is not None:
        stats = None if source is None else normalize_path(source)
        env = VecNormalize.load(str(stats), env) if stats is not None else VecNormalize(env, **normalize)
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False)
    tensorboard_log = str(out / "tb") if importlib.util.find_spec("tensorboard") is not None else None
    if source is None:
        try:
            model = build_model(config, env, tensorboard_log)
        except AssertionError as exc:  # SB3 checks some settings by assertion; config.py refuses those it knows
            raise ConfigError(f"{config.algo} refuses the settings of {config.env_id}: {exc}") from None
    else:
        # SB3's load seeds the env and the global generators again from the model's seed: the new segment's
        # seed, or it would replay the first segment's episodes and random draws
        model = config.algo_class.load(source, env=env, tensorboard_log=tensorboard_log, seed=config.seed + done)
        log_nowhere_without_tensorboard(model, tensorboard_log)
        if isinstance(model, OffPolicyAlgorithm):
            _restore_replay_buffer(model, config, out, source)
    if source is None or done < config.n_timesteps:  # a resumed run's too: its new total steps
        with _replacing(out / CONFIG_FILE) as path:
            save_resolved(config, path)
    if command is not None:
        (out / COMMAND_FILE).write_text(command + "\n")
    stopper = StopOnInterrupt(stop, exiting)
    evaluation = EvalCallback(
        eval_env,
        n_eval_episodes=config.n_eval_episodes,
        eval_freq=max(config.eval_freq // config.n_envs, 1),
        log_path=str(out / EVAL_DIR),
        deterministic=True,
        verbose=int(verbose),
    )
    _continue_evaluations(evaluation, out / EVAL_DIR / EVAL_FILE, done)
    checkpoints = CheckpointCallback(
        max(config.save_freq // config.n_envs, 1),
        str(out / CHECKPOINT_DIR),
        name_prefix=CHECKPOINT_PREFIX,
        save_vecnormalize=normalize is not None,
    )
    for periodic in (checkpoints, evaluation):  # a resumed run goes on at the multiples of eval_freq and save_freq
        periodic.n_calls = done // config.n_envs  # they count their calls, one per vector step
    all_callbacks = [checkpoints, evaluation, stopper, *callbacks]
    if progress_bar and _progress_bar_available():
        all_callbacks.append(WholeCollectionsProgressBar(config))
    remaining = config.n_timesteps - done
    with stopper.catching():
        if remaining > 0:
            model.learn(
                remaining,
                callback=all_callbacks,
                reset_num_timesteps=source is None,
                tb_log_name=config.algo,
            )
        with _replacing(out / MODEL_FILE) as path:
            model.save(path)
        if isinstance(env, VecNormalize):
            with _replacing(out / NORMALIZE_FILE) as path:
                env.save(str(path))
        if isinstance(model, OffPolicyAlgorithm):
            if stopper.interrupted:
                with _replacing(out / REPLAY_FILE) as path:
                    model.save_replay_buffer(path)
            else:
                (out / REPLAY_FILE).unlink(missing_ok=True)
        result = _record(out, model.num_timesteps, stopper.interrupted, time.perf_counter() - start, done)
    env.close()
    eval_env.close()
    return result


def _restore_replay_buffer(model: OffPolicyAlgorithm, config: TrainConfig, out: Path, source: Path) -> None:
    """The replay buffer that an interrupted run saved beside ``model.zip``; where there is none (a finished run,
    a checkpoint), the empty buffer refills for the config's ``learning_starts`` steps before updates resume."""
    replay = out / REPLAY_FILE
    if source.name == MODEL_FILE and replay.exists():
        model.load_replay_buffer(replay)
        return
    model.learning_starts = model.num_timesteps + int(config.setting("learning_starts"))


def _continue_evaluations(callback: EvalCallback, path: Path, done: int) -> None:
    """Give ``callback`` the evaluations of the run's earlier segments up to step ``done`` from ``path``: it rewrites
    that file with its own lists after every evaluation, which would drop them."""
    if not path.is_file():
        return
    with np.load(path) as saved:
        keep = saved["timesteps"] <= done
        callback.evaluations_timesteps = saved["timesteps"][keep].tolist()
        callback.evaluations_results = saved["results"][keep].tolist()
        callback.evaluations_length = saved["ep_lengths"][keep].tolist()
        if "successes" in saved:
            callback.evaluations_successes = saved["successes"][keep].tolist()


def _nothing_to_train(out: Path, done: int) -> TrainResult:
    """The result of resuming a run whose ``model.zip`` already holds ``done`` steps, its total or more."""
    stats_path = out / STATS_FILE
    wall_time = float(json.loads(stats_path.read_text())["wall_time_s"]) if stats_path.exists() else 0.0
    return TrainResult(out / MODEL_FILE, done, False, wall_time, resumed_at=done)


def _record(out: Path, timesteps: int, interrupted: bool, seconds: float, resumed_at: int) -> TrainResult:
    """Update ``train_stats.json`` (wall time summed over resumed segments) and return the result."""
    stats_path = out / STATS_FILE
    previous = json.loads(stats_path.read_text()) if stats_path.exists() else {"wall_time_s": 0.0}
    total = float(previous["wall_time_s"]) + seconds
    stats = {"timesteps": timesteps, "wall_time_s": round(total, 2), "interrupted": interrupted}
    with _replacing(stats_path) as path:
        path.write_text(json.dumps(stats, indent=2) + "\n")
    return TrainResult(out / MODEL_FILE, timesteps, interrupted, total, resumed_at)


def resume_config(out: Path, n_timesteps: int | None = None) -> TrainConfig:
    """The saved config of the run in ``out``, with a new total ``n_timesteps`` if given."""
    path = Path(out) / CONFIG_FILE
    if not path.is_file():
        raise ValueError(f"--resume: {out} holds no training run to resume (no {CONFIG_FILE})")
    config = load_resolved(path)
    return config if n_timesteps is None else with_overrides(config, {"n_timesteps": n_timesteps}, str(path))
