"""``vegym sweep``: an Optuna study over an algorithm's hyperparameters, run by any number of worker processes.

Every trial trains the env's committed config (``configs/<algo>.yml``) with sampled hyperparameters (and, only
if asked, sampled env parameters such as reward weights) and scores the model by its mean normalized score
``(R - R_random) / (R_analytic - R_random)`` on fixed evaluation episodes of the registered env (seeds
:data:`SWEEP_EVAL_SEED` onwards, apart from training seeds and from ``vegym compare``'s). Periodic evaluations
during training are reported to the study, whose median pruner stops weak trials early.

The study lives in an Optuna RDB storage: a local SQLite file by default, or any PostgreSQL URL shared by several
machines. Workers, in one process or in many on many machines, share the study through it:

- a worker creates a trial only while the study has fewer than ``--trials`` finished (complete or pruned) plus
  running trials, under a lock held in the storage's own terms (a lock file beside the SQLite file, a PostgreSQL
  advisory lock), so the study ends with exactly that many finished trials;
- running trials send a heartbeat; a trial whose worker died (killed, machine lost) is failed once its heartbeat
  is older than the grace period (or at once if the worker died before its first heartbeat), and its parameters
  are queued again, so the next worker retries them. Running the same ``vegym sweep`` command again resumes a
  study.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import multiprocessing as mp
import os
import re
import signal
import sys
import tempfile
import time
import warnings
import zlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import optuna
import sqlalchemy
import torch
import yaml
from optuna.storages import RDBStorage, RetryHeartbeatStaleTrialCallback, fail_stale_trials
from optuna.trial import TrialState
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url
from stable_baselines3.common.callbacks import BaseCallback

from agents.config import CONFIG_DIR, TrainConfig, env_params, load_config, make_kwargs, with_overrides, zoo_entry
from agents.evaluation import BASELINES, LearnedAgent, evaluate, load_learned, run_episode
from agents.statistics import normalized
from agents.training import interrupts_handled, raise_keyboard_interrupt, train

SWEEP_EVAL_SEED = 5000
"""First seed of a sweep's evaluation episodes."""
SWEEPS_DIR = Path("runs") / "sweeps"
"""Default home of the SQLite studies and of the best configs."""
FINISHED = (TrialState.COMPLETE, TrialState.PRUNED)
TRIAL_ERRORS = (ValueError, RuntimeError, FloatingPointError)
"""Errors that fail one trial (recorded with its ``error`` attribute) without stopping the worker."""
NET_ARCHS = {"small": [64, 64], "medium": [128, 128], "large": [256, 256]}
"""Network sizes a trial may pick (hidden layers of the policy and value/critic networks)."""


@dataclass(frozen=True)
class SweepSettings:
    """What one ``vegym sweep`` command asks for (stored in the study so every worker agrees)."""

    env_id: str
    """Registered env id."""
    algo: str
    """``ppo``, ``sac`` or ``td3``: the committed config the trials start from."""
    trials: int
    """Finished (complete or pruned) trials the study should hold."""
    storage: str
    """Optuna RDB URL (``sqlite:///...``, ``postgresql://...``)."""
    study: str
    """Study name."""
    timesteps: int | None = None
    """Training steps per trial (None: the config's ``n_timesteps``)."""
    eval_episodes: int = 10
    """Evaluation episodes of each report and of the final score."""
    reports: int = 4
    """Evaluations reported to the pruner during a trial (the last at the end of training)."""
    tune_env: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Env parameters sampled uniformly in ``[low, high]`` (e.g. reward weights); empty: the registered values."""
    heartbeat: int = 60
    """Seconds between a running trial's heartbeats; a trial silent for twice this is failed and retried."""

    def study_attrs(self) -> dict[str, Any]:
        """The settings every worker of the study must share."""
        return {
            "env_id": self.env_id,
            "algo": self.algo,
            "timesteps": self.timesteps,
            "eval_episodes": self.eval_episodes,
            "tune_env": {k: list(v) for k, v in self.tune_env.items()},
            "heartbeat": self.heartbeat,
        }


def parse_tune_env(items: Sequence[str], env_id: str) -> dict[str, tuple[float, float]]:
    """``NAME=LOW:HIGH`` items as ranges of the env's parameters; ValueError naming a bad item."""
    ranges = {}
    for item in items:
        name, _, bounds = item.partition("=")
        low_text, _, high_text = bounds.partition(":")
        try:
            low, high = float(low_text), float(high_text)
        except ValueError:
            raise ValueError(f"--tune-env {item!r}: expected NAME=LOW:HIGH, e.g. bottom_out_penalty=0.5:5") from None
        if not low < high:
            raise ValueError(f"--tune-env {item!r}: LOW={low:g} must be below HIGH={high:g}")
        for value in (low, high):
            try:
                env_params(env_id, {name: value})
            except TypeError:
                raise ValueError(f"--tune-env {item!r}: {env_id} has no parameter {name!r}") from None
            except ValueError as exc:
                raise ValueError(f"--tune-env {item!r}: {exc}") from None
        ranges[name] = (low, high)
    return ranges


def default_storage(study: str) -> str:
    """The SQLite URL of a study in :data:`SWEEPS_DIR`."""
    return f"sqlite:///{SWEEPS_DIR / study}.db"


def shown_storage(url: str) -> str:
    """``url`` as printed: its password, in the user part or as a ``password=`` query parameter, masked as
    ``***``. The user part's password runs to the last ``@`` before the query, or to the last ``@`` of all where
    none comes before a ``?``: SQLAlchemy ends it at the first ``@`` (an unescaped ``@`` in a password would leave
    the rest of it shown as the host) and lets it hold a ``?``."""
    shown = re.sub(r"^([\w+.-]+://[^:/@?]*:)(?:[^?]*|.*)@", r"\1***@", url)
    return re.sub(r"([?&]password=)[^&]*", r"\1***", shown, flags=re.IGNORECASE)


UNOPENABLE = (sqlalchemy.exc.OperationalError, optuna.exceptions.StorageInternalError)
"""What the storage raises for a database it cannot reach or write: SQLAlchemy's, or Optuna's around it."""


def _cannot_open(url: str, error: Exception) -> ValueError:
    """The error of a storage that cannot be opened, with the driver's reason on one line."""
    cause = error.__cause__ if isinstance(error, optuna.exceptions.StorageInternalError) else error
    reason = getattr(cause, "orig", None) or cause or error
    return ValueError(f"--storage {shown_storage(url)!r}: cannot open the database: {' '.join(str(reason).split())}")


def check_storage(url: str) -> None:
    """ValueError unless ``url`` is a SQLite file or a PostgreSQL URL whose driver is installed."""
    shown = repr(shown_storage(url))
    try:
        parsed = make_url(url)
    except sqlalchemy.exc.ArgumentError:
        raise ValueError(f"--storage {shown} is not a database URL (sqlite:///path.db, postgresql://...)") from None
    backend = parsed.get_backend_name()
    if backend == "sqlite" and parsed.database in (None, "", ":memory:"):
        raise ValueError(f"--storage {shown}: a sweep needs a SQLite file, e.g. sqlite:///runs/sweeps/study.db")
    if backend not in ("sqlite", "postgresql"):
        raise ValueError(f"--storage {shown}: vegym sweep runs on sqlite:/// or postgresql:// storages")
    try:
        parsed.get_dialect().import_dbapi()
    except ImportError:
        raise ValueError(f'--storage {shown}: its database driver is missing: pip install -e ".[postgres]"') from None


def open_storage(url: str, heartbeat: int, attempts: int = 3) -> RDBStorage:
    """The study storage with heartbeats and retry of the trials of dead workers; ValueError if the database
    cannot be opened (a server that does not answer, a refused login, a SQLite file that cannot be written)."""
    parsed = make_url(url)
    engine_kwargs: dict[str, Any] = {}
    if parsed.get_backend_name() == "sqlite":
        folder = Path(parsed.database or ".").parent
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ValueError(f"--storage {shown_storage(url)!r}: cannot create {folder} ({exc.strerror})") from None
        engine_kwargs["connect_args"] = {"timeout": 60}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            return RDBStorage(
                url,
                engine_kwargs=engine_kwargs,
                heartbeat_interval=heartbeat,
                grace_period=2 * heartbeat,
                heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(),
            )
    except sqlalchemy.exc.IntegrityError:
        if attempts <= 1:
            raise
        time.sleep(1.0)  # another process was creating the tables of this new storage at the same moment
        return open_storage(url, heartbeat, attempts - 1)
    except UNOPENABLE as exc:
        raise _cannot_open(url, exc) from None


class StudyLock:
    """A lock across processes and machines for one study: ``fcntl`` on a file beside a SQLite database, a
    PostgreSQL advisory lock otherwise. :meth:`release` may be called more than once."""

    def __init__(self, url: str, study: str) -> None:
        check_storage(url)
        parsed = make_url(url)
        self.backend = parsed.get_backend_name()
        if self.backend == "sqlite":
            digest = zlib.crc32(study.encode())  # study names may hold any character
            self._file = open(f"{parsed.database}.{digest:08x}.lock", "a+")  # noqa: SIM115 (held by the worker)
        else:
            self._engine = create_engine(url)
            self._key = zlib.crc32(f"vegym-sweep:{study}".encode())
        self._connection: Any = None
        self.held = False

    def acquire(self) -> None:
        if self.backend == "sqlite":
            fcntl.flock(self._file, fcntl.LOCK_EX)
        else:
            self._connection = self._engine.connect()
            self._connection.execute(text("SELECT pg_advisory_lock(:key)"), {"key": self._key})
        self.held = True

    def release(self) -> None:
        if not self.held:
            return
        if self.backend == "sqlite":
            fcntl.flock(self._file, fcntl.LOCK_UN)
        else:
            self._connection.execute(text("SELECT pg_advisory_unlock(:key)"), {"key": self._key})
            self._connection.close()
        self.held = False

    def close(self) -> None:
        self.release()
        if self.backend == "sqlite":
            self._file.close()
        else:
            self._engine.dispose()


def sample_hyperparams(trial: optuna.Trial, config: TrainConfig) -> dict[str, Any]:
    """Config overrides for one trial (RL-Zoo-like ranges), starting from the committed ``config``."""
    suggest = trial.suggest_categorical
    arch = NET_ARCHS[suggest("net_arch", list(NET_ARCHS))]
    values: dict[str, Any] = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-5, 3e-3, log=True),
        "gamma": suggest("gamma", [0.95, 0.98, 0.99, 0.995, 0.999]),
        "policy_kwargs": {**config.policy_kwargs, "net_arch": arch},
    }
    if config.algo == "ppo":
        rollout = suggest("n_steps", [64, 128, 256, 512, 1024])
        values |= {
            "n_steps": rollout,
            "batch_size": min(suggest("batch_size", [64, 128, 256, 512]), rollout * config.n_envs),
            "n_epochs": suggest("n_epochs", [5, 10, 20]),
            "gae_lambda": suggest("gae_lambda", [0.8, 0.9, 0.95, 0.98, 1.0]),
            "clip_range": suggest("clip_range", [0.1, 0.2, 0.3]),
            "ent_coef": trial.suggest_float("ent_coef", 1e-8, 1e-2, log=True),
        }
    else:
        every = suggest("train_freq", [1, 4, 16])
        values |= {
            "batch_size": suggest("batch_size", [64, 128, 256, 512]),
            "buffer_size": suggest("buffer_size", [10_000, 100_000, 1_000_000]),
            "learning_starts": suggest("learning_starts", [0, 1_000, 10_000]),
            "train_freq": every,
            "gradient_steps": every,
            "tau": suggest("tau", [0.005, 0.01, 0.02, 0.05]),
        }
        if config.algo == "td3":
            values |= {"noise_type": "normal", "noise_std": suggest("noise_std", [0.05, 0.1, 0.2, 0.3, 0.5])}
    return values


def trial_config(trial: optuna.Trial, settings: SweepSettings) -> TrainConfig:
    """The committed config of the env with the trial's hyperparameters and env parameters."""
    base = load_config(CONFIG_DIR / f"{settings.algo}.yml", settings.env_id, settings.algo)
    overrides = sample_hyperparams(trial, base)
    if settings.timesteps is not None:
        overrides["n_timesteps"] = settings.timesteps
    if settings.tune_env:
        tuned = {name: trial.suggest_float(f"env.{name}", low, high) for name, (low, high) in settings.tune_env.items()}
        overrides["env_kwargs"] = {**base.env_kwargs, **tuned}
    return with_overrides(base, overrides, f"trial {trial.number}")


class Scorer:
    """Mean normalized score of an agent on the sweep's evaluation episodes (the references are run once).

    The episodes run on the env of the committed config (``env_kwargs``), never on tuned reward weights, so
    trials that shape their reward differently are scored on the same task.
    """

    def __init__(self, env_id: str, episodes: int, env_kwargs: Mapping[str, Any]) -> None:
        self.env_id = env_id
        self.episodes = episodes
        self.env_kwargs = dict(env_kwargs)
        means = {
            name: float(
                evaluate(env_id, name, make(SWEEP_EVAL_SEED), episodes, SWEEP_EVAL_SEED, env_kwargs).returns.mean()
            )
            for name, make in BASELINES.items()
        }
        self.low, self.high = means["random"], means["analytic"]
        if normalized(self.high, self.low, self.high) is None:
            raise ValueError(f"{env_id}: the analytic and random agents tie on the sweep episodes")

    def __call__(self, agent: Any) -> float:
        env = gym.make(self.env_id, **make_kwargs(self.env_id, self.env_kwargs))
        try:
            returns = [run_episode(env, agent, SWEEP_EVAL_SEED + k).ret for k in range(self.episodes)]
        finally:
            env.close()
        return (float(sum(returns) / len(returns)) - self.low) / (self.high - self.low)


class ReportAndPrune(BaseCallback):
    """Evaluates the model every ``n_timesteps / reports`` steps, reports to the trial, stops a pruned one."""

    def __init__(self, trial: optuna.Trial, score: Scorer, n_timesteps: int, reports: int) -> None:
        super().__init__()
        self.trial = trial
        self.score = score
        self.every = max(n_timesteps // max(reports, 1), 1)
        self.next = self.every
        self.pruned = False

    def _on_step(self) -> bool:
        if self.num_timesteps < self.next:
            return True
        self.next += self.every
        value = self.score(LearnedAgent(self.model, self.model.get_vec_normalize_env()))
        self.trial.report(value, self.num_timesteps)
        self.pruned = self.trial.should_prune()
        return not self.pruned


NEVER = 2**62
"""An ``eval_freq``/``save_freq`` (env steps) that no training reaches."""


def objective(trial: optuna.Trial, settings: SweepSettings, score: Scorer, stop: Any = None) -> float:
    """Train one trial's config in a scratch directory and return its final mean normalized score; setting the
    event ``stop`` stops the training as Ctrl-C does."""
    config = trial_config(trial, settings)
    trial.set_user_attr("config", {k: v for k, v in config.to_entry().items() if k not in ("env_id", "algo")})
    pruning = ReportAndPrune(trial, score, config.n_timesteps, settings.reports)
    # the trial's own evaluations are the pruning reports, and its run is thrown away: none of the config's
    # training-time evaluations and checkpoints
    scratch_config = with_overrides(config, {"eval_freq": NEVER, "save_freq": NEVER}, f"trial {trial.number}")
    with tempfile.TemporaryDirectory(prefix="vegym-trial-") as scratch:
        try:
            result = train(scratch_config, Path(scratch) / "run", progress_bar=False, callbacks=[pruning], stop=stop)
            if result.interrupted:
                raise KeyboardInterrupt
            if pruning.pruned:
                raise optuna.TrialPruned()
            agent, _ = load_learned(Path(scratch) / "run")
            return score(agent)
        except TRIAL_ERRORS as exc:
            trial.set_user_attr("error", f"{type(exc).__name__}: {exc}")
            raise


def load_study(settings: SweepSettings) -> optuna.Study:
    """Create the study or load it; ValueError if it was created for other settings."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = open_storage(settings.storage, settings.heartbeat)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        sampler = optuna.samplers.TPESampler(constant_liar=True)  # running trials steer parallel workers apart
    wanted = settings.study_attrs()
    try:  # the first writes: a database that opens may still refuse them (a read-only file)
        study = optuna.create_study(
            study_name=settings.study,
            storage=storage,
            direction="maximize",
            load_if_exists=True,
            sampler=sampler,
            pruner=optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=0),
        )
        stored = study.user_attrs.get("vegym")
        if stored is None:
            study.set_user_attr("vegym", wanted)
    except UNOPENABLE as exc:
        raise _cannot_open(settings.storage, exc) from None
    if stored is not None and stored != wanted:
        raise ValueError(
            f"study {settings.study!r} in {shown_storage(settings.storage)} was created for {stored}, not {wanted}"
        )
    return study


def _counts(study: optuna.Study) -> dict[TrialState, int]:
    counts = dict.fromkeys(TrialState, 0)
    for t in study.get_trials(deepcopy=False):
        counts[t.state] += 1
    return counts


STARTED = "started"
"""User attribute a worker gives the trial it runs, holding the study lock, after the trial's first heartbeat: the
trial's number (a retried trial inherits its original's attributes; the number tells them apart)."""


def fail_orphaned_trials(study: optuna.Study) -> None:
    """Fail the running trials whose worker died before it marked them (``STARTED``), and queue them again as
    stale trials are. A worker creates a trial, records its first heartbeat and marks it while holding the study
    lock, so a running trial seen unmarked under the lock has no live worker, and Optuna never fails it as stale
    (a trial without a heartbeat never goes stale). Call it holding the lock."""
    storage = study._storage
    retry = storage.get_heartbeat_stale_trial_callback()
    for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        if trial.user_attrs.get(STARTED) == trial.number:
            continue
        if storage.set_trial_state_values(trial._trial_id, state=TrialState.FAIL) and retry is not None:
            retry(study, storage.get_trial(trial._trial_id))


def run_worker(
    settings: SweepSettings, name: str = "worker", log: Callable[[str], None] = print, stop: Any = None
) -> int:
    """Run trials until the study holds ``settings.trials`` finished ones; return how many this worker ran.

    RuntimeError after three failed trials in a row (a config that cannot train should not loop forever).
    Setting the event ``stop`` (the ``--workers`` parent's) stops it as Ctrl-C does: its training at the next env
    step, the worker before its next trial (KeyboardInterrupt).
    """
    study = load_study(settings)
    base = load_config(CONFIG_DIR / f"{settings.algo}.yml", settings.env_id, settings.algo)
    score = Scorer(settings.env_id, settings.eval_episodes, base.env_kwargs)
    lock = StudyLock(settings.storage, settings.study)
    ran = failures = 0
    running = -1

    def unlocked_objective(trial: optuna.Trial) -> float:
        nonlocal running
        running = trial.number
        study._storage.record_heartbeat(trial._trial_id)  # Optuna's heartbeat thread beats whenever it gets to run
        trial.set_user_attr(STARTED, trial.number)
        lock.release()  # the trial exists now, marked: other workers count it and may go on
        log(f"{name}: trial {trial.number} started")
        return objective(trial, settings, score, stop)

    def report(study: optuna.Study, trial: optuna.trial.FrozenTrial) -> None:
        nonlocal failures
        failures = failures + 1 if trial.state == TrialState.FAIL else 0
        outcome = f"{trial.value:.4f}" if trial.state == TrialState.COMPLETE else trial.user_attrs.get("error", "")
        log(f"{name}: trial {trial.number} {trial.state.name.lower()} {outcome}".rstrip())

    try:
        while True:
            if stop is not None and stop.is_set():
                raise KeyboardInterrupt
            lock.acquire()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
                    fail_stale_trials(study)
                fail_orphaned_trials(study)
                counts = _counts(study)
                finished = sum(counts[s] for s in FINISHED)
                if finished >= settings.trials:
                    return ran
                if counts[TrialState.WAITING] == 0 and finished + counts[TrialState.RUNNING] >= settings.trials:
                    lock.release()  # the last trials run elsewhere: wait for them to finish or to go stale
                    time.sleep(min(settings.heartbeat, 5))
                    continue
                running = -1
                try:
                    with _interrupted_trial_unlogged():
                        study.optimize(unlocked_objective, n_trials=1, catch=TRIAL_ERRORS, callbacks=[report])
                except KeyboardInterrupt:
                    if running >= 0:
                        log(f"{name}: trial {running} interrupted (failed: the sweep runs a new one when it goes on)")
                    raise
                except ValueError as exc:
                    if "Cannot tell a FAIL trial" not in str(exc):  # Optuna has no class of its own for it
                        raise
                    failures = 0
                    log(f"{name}: its trial was failed as stale by another worker (missed heartbeats) and is retried")
            finally:
                lock.release()
            ran += 1
            if failures >= 3:
                raise RuntimeError(f"{name}: three trials in a row failed; see the study's failed trials")
    finally:
        lock.close()


class _AfterInterruptFilter(logging.Filter):
    """Drops a logger's records from the first one that carries a KeyboardInterrupt on."""

    interrupted = False

    def filter(self, record: logging.LogRecord) -> bool:
        self.interrupted |= record.exc_info is not None and isinstance(record.exc_info[1], KeyboardInterrupt)
        return not self.interrupted


@contextlib.contextmanager
def _interrupted_trial_unlogged() -> Iterator[None]:
    """Optuna's warnings about a trial that Ctrl-C stopped left out (the KeyboardInterrupt's traceback, then
    "failed with value None"): the worker reports it in one line. Other trials' warnings stay."""
    logger, quiet = logging.getLogger(optuna.study._optimize.__name__), _AfterInterruptFilter()
    logger.addFilter(quiet)
    try:
        yield
    finally:
        logger.removeFilter(quiet)


def _worker_process(settings: SweepSettings, name: str, threads: int, stop: Any) -> None:
    """Entry point of a ``--workers`` process (spawned: imports afresh, so torch's thread count is set again). A
    SIGINT ignored by the parent (a background job of a script) would be ignored here too: Ctrl-C's handler again.
    The parent's event ``stop`` stops it as well, should a Ctrl-C be lost (one raised inside a finalizer is)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    torch.set_num_threads(threads)
    try:
        run_worker(settings, name, log=lambda line: print(line, flush=True), stop=stop)
    except KeyboardInterrupt:
        sys.exit(130)


def sweep(
    settings: SweepSettings, workers: int = 1, threads: int = 1, log: Callable[[str], None] = print
) -> optuna.Study:
    """Run ``workers`` worker processes on the study (in this process if 1) until it is complete; each trains
    with ``threads`` torch threads. Logs where the study is once it is open. Optuna's log verbosity (held at
    WARNING while it runs) and this process's torch threads are as they were when it returns."""
    verbosity, torch_threads = optuna.logging.get_verbosity(), torch.get_num_threads()
    try:
        return _sweep(settings, workers, threads, log)
    finally:
        optuna.logging.set_verbosity(verbosity)
        torch.set_num_threads(torch_threads)


def _sweep(settings: SweepSettings, workers: int, threads: int, log: Callable[[str], None]) -> optuna.Study:
    if workers < 1:
        raise ValueError(f"workers={workers!r} must be at least 1")
    if settings.trials < 1:
        raise ValueError(f"trials={settings.trials!r} must be at least 1")
    load_config(CONFIG_DIR / f"{settings.algo}.yml", settings.env_id, settings.algo)  # its errors before the study's
    check_storage(settings.storage)
    study = load_study(settings)  # create it once, before the workers race to
    log(
        f"study {settings.study!r} in {shown_storage(settings.storage)}: {settings.trials} trials of {settings.algo} "
        f"on {settings.env_id}, {workers} worker(s) here; run the same command elsewhere with this --storage to add "
        "workers"
    )
    if workers == 1:
        torch.set_num_threads(threads)
        run_worker(settings, "worker 0", log)
        return study
    context = mp.get_context("spawn")
    stop = context.Event()
    processes = [
        context.Process(target=_worker_process, args=(settings, f"worker {k}", threads, stop), name=f"vegym-sweep-{k}")
        for k in range(workers)
    ]
    with interrupts_handled(raise_keyboard_interrupt):  # also where SIGINT came in ignored, and for SIGTERM
        try:
            for process in processes:
                process.start()
            for process in processes:
                process.join()
        except KeyboardInterrupt:
            stop.set()
            started = [process for process in processes if process.pid is not None]
            for process in started:  # a signal to this process alone (not its group) stops the workers too
                if process.is_alive():
                    os.kill(process.pid, signal.SIGINT)
            for process in started:
                process.join()
            raise
    failed = [f"{p.name} (exit code {p.exitcode})" for p in processes if p.exitcode not in (0, None)]
    finished = len(study.get_trials(deepcopy=False, states=FINISHED))
    if failed and finished < settings.trials:
        raise RuntimeError(
            f"sweep workers {', '.join(failed)} stopped with {finished} of {settings.trials} trials finished; "
            "run the same command again to finish the study"
        )
    if failed:
        log(f"warning: workers {', '.join(failed)} stopped, but the others finished the study")
    return study


def best_config(study: optuna.Study, settings: SweepSettings) -> dict[str, Any]:
    """The best trial's config as a ``configs/<algo>.yml`` block, ``{env_id: entry}``, in the committed entries'
    form (:func:`~agents.config.zoo_entry`), which RL Zoo reads as well."""
    return {settings.env_id: zoo_entry(study.best_trial.user_attrs["config"])}


def write_best_config(study: optuna.Study, settings: SweepSettings, path: Path) -> str:
    """Write :func:`best_config` as YAML (with a comment naming the trial and its score); return the text."""
    best = study.best_trial
    header = (
        f"# vegym sweep: best of {len(study.get_trials(states=FINISHED))} trials of study {settings.study!r} "
        f"(trial {best.number}, mean normalized score {best.value:.4f} on {settings.eval_episodes} episodes "
        f"from seed {SWEEP_EVAL_SEED})\n"
    )
    body = yaml.safe_dump(best_config(study, settings), sort_keys=False)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(header + body)
    return header + body
