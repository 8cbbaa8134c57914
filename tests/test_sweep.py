"""`vegym sweep`: Optuna studies shared by worker processes, on SQLite and (in CI) on PostgreSQL."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import optuna
import pytest
import sqlalchemy
import torch
from optuna.storages import RetryHeartbeatStaleTrialCallback
from optuna.storages._heartbeat import HeartbeatThread
from optuna.trial import TrialState

import vegym  # noqa: F401
from agents import sweep as sweep_module
from agents.analytic import controller_for
from agents.basics import EVAL_SEED
from agents.cli import main
from agents.config import CONFIG_DIR, load_config, load_configs, with_overrides
from agents.evaluation import RandomAgent
from agents.sweep import (
    SWEEP_EVAL_SEED,
    ReportAndPrune,
    Scorer,
    SweepSettings,
    check_storage,
    load_study,
    parse_tune_env,
    run_worker,
    sample_hyperparams,
    shown_storage,
)
from agents.training import TrainResult

VEGYM = [sys.executable, "-c", "import sys; from agents.cli import main; sys.exit(main())"]
POSTGRES_URL = os.environ.get("VEGYM_TEST_POSTGRES_URL")
"""A PostgreSQL database for the scale-out test; .ci/run starts a server on loopback and sets it."""


@pytest.fixture(autouse=True)
def _temporary_files_in_tmp_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The sweeps these tests start put their trials' scratch directories in the test's own directory: a worker
    killed mid-trial (the tests below kill some) cannot remove its ``vegym-trial-*`` directory, which was left in
    the system's temporary directory (31 in a day of test runs)."""
    monkeypatch.setenv("TMPDIR", str(tmp_path))


def sweep_args(storage: str, study: str, trials: int, best: Path, *extra: str) -> list[str]:
    """A sweep whose trials take a second or two: TD3 on BouncingBall for 300 steps, 2 evaluation episodes; the
    best config goes to ``best`` (the default is runs/sweeps/ under the working directory)."""
    return [
        *VEGYM,
        "sweep",
        "--env",
        "BouncingBall-v0",
        "--algo",
        "td3",
        "--trials",
        str(trials),
        "--timesteps",
        "300",
        "--eval-episodes",
        "2",
        "--storage",
        storage,
        "--study",
        study,
        "--best",
        str(best),
        *extra,
    ]


def trials_by_state(storage: str, study: str) -> dict[TrialState, list[optuna.trial.FrozenTrial]]:
    trials = optuna.load_study(study_name=study, storage=storage).get_trials()
    return {state: [t for t in trials if t.state == state] for state in TrialState}


def training_trials(database: Path) -> int:
    """Running trials that have sampled their config (so are training) in a SQLite study file, read without
    Optuna (which would race the worker creating the file)."""
    query = (
        "SELECT COUNT(*) FROM trials JOIN trial_user_attributes USING (trial_id) "
        "WHERE trials.state = 'RUNNING' AND trial_user_attributes.key = 'config'"
    )
    try:
        with sqlite3.connect(database) as connection:
            return connection.execute(query).fetchone()[0]
    except sqlite3.OperationalError:  # no file or no table yet
        return 0


def assert_complete_study(storage: str, study: str, trials: int) -> None:
    """Exactly ``trials`` finished trials, none running or waiting, numbers unique, every one scored."""
    by_state = trials_by_state(storage, study)
    finished = by_state[TrialState.COMPLETE] + by_state[TrialState.PRUNED]
    assert len(finished) == trials
    assert not by_state[TrialState.RUNNING] and not by_state[TrialState.WAITING]
    numbers = [t.number for state in by_state.values() for t in state]
    assert sorted(numbers) == list(range(len(numbers)))
    for t in by_state[TrialState.COMPLETE]:
        assert t.value is not None and "config" in t.user_attrs


TINY_TOTALS = pytest.mark.filterwarnings("ignore:.*learning_starts=.* is not below n_timesteps")
"""For runs of tiny totals on purpose: an off-policy one then never updates its policy, which its config warns of."""


def run_two_workers(storage: str, study: str, tmp_path: Path) -> None:
    best = tmp_path / "best.yml"
    proc = subprocess.run(
        sweep_args(storage, study, 4, best, "--workers", "2"),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert_complete_study(storage, study, 4)
    assert not trials_by_state(storage, study)[TrialState.FAIL]
    assert {"worker 0", "worker 1"} <= {line.split(":")[0] for line in proc.stdout.splitlines()}
    config = load_config(best, "vegym/BouncingBall-v0", "td3")  # the best trial, as a ready config block
    best_trial = optuna.load_study(study_name=study, storage=storage).best_trial
    assert config.hyperparams["learning_rate"] == pytest.approx(best_trial.params["learning_rate"])
    assert config.n_timesteps == 300


@TINY_TOTALS
def test_two_workers_on_sqlite_record_every_trial_once(tmp_path: Path) -> None:
    run_two_workers(f"sqlite:///{tmp_path / 'study.db'}", "two-workers", tmp_path)


@pytest.mark.skipif(POSTGRES_URL is None, reason="set VEGYM_TEST_POSTGRES_URL (.ci/run does) to test PostgreSQL")
@TINY_TOTALS
def test_two_workers_on_postgresql_record_every_trial_once(tmp_path: Path) -> None:
    run_two_workers(POSTGRES_URL, f"two-workers-{uuid.uuid4().hex[:8]}", tmp_path)


@pytest.mark.filterwarnings("ignore::optuna.exceptions.ExperimentalWarning")  # retried_trial_number
def test_killed_worker_leaves_a_study_that_a_second_run_finishes(tmp_path: Path) -> None:
    storage, study = f"sqlite:///{tmp_path / 'study.db'}", "killed"
    args = sweep_args(storage, study, 3, tmp_path / "best.yml", "--heartbeat", "1")
    worker = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 300
    while not training_trials(tmp_path / "study.db"):
        if time.monotonic() > deadline:
            pytest.fail("the worker never started a trial")
        time.sleep(0.2)
    os.killpg(worker.pid, signal.SIGKILL)  # mid-trial, no chance to clean up
    worker.wait(timeout=30)
    assert trials_by_state(storage, study)[TrialState.RUNNING]

    again = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stdout + again.stderr
    assert_complete_study(storage, study, 3)
    failed = trials_by_state(storage, study)[TrialState.FAIL]
    assert len(failed) == 1
    retried = [
        t
        for t in optuna.load_study(study_name=study, storage=storage).get_trials()
        if RetryHeartbeatStaleTrialCallback.retried_trial_number(t) == failed[0].number
    ]
    assert len(retried) == 1 and retried[0].params == failed[0].params


@pytest.mark.filterwarnings("ignore::optuna.exceptions.ExperimentalWarning")  # retried_trial_number
def test_the_other_worker_finishes_the_study_of_a_killed_worker(tmp_path: Path) -> None:
    """--workers 2, one worker killed mid-trial: the other retries its trial and completes the study."""
    storage, study = f"sqlite:///{tmp_path / 'study.db'}", "one-killed"
    command = subprocess.Popen(
        sweep_args(storage, study, 4, tmp_path / "best.yml", "--workers", "2", "--heartbeat", "1"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 300
        while not training_trials(tmp_path / "study.db"):
            if time.monotonic() > deadline:
                pytest.fail("no worker started a trial")
            time.sleep(0.2)
        children = Path(f"/proc/{command.pid}/task/{command.pid}/children").read_text().split()
        workers = [int(pid) for pid in children if "spawn_main" in Path(f"/proc/{pid}/cmdline").read_text()]
        assert len(workers) == 2
        os.kill(workers[0], signal.SIGKILL)
        stdout, stderr = command.communicate(timeout=600)
    finally:  # a failed or timed-out test leaves no sweep behind
        if command.poll() is None:
            os.killpg(command.pid, signal.SIGKILL)
            command.wait()
    assert command.returncode == 0, stdout + stderr
    assert "stopped, but the others finished the study" in stdout
    assert_complete_study(storage, study, 4)
    trials = optuna.load_study(study_name=study, storage=storage).get_trials()
    for failed in (t for t in trials if t.state == TrialState.FAIL):
        assert any(RetryHeartbeatStaleTrialCallback.retried_trial_number(t) == failed.number for t in trials)


@pytest.mark.filterwarnings("ignore::optuna.exceptions.ExperimentalWarning")  # retried_trial_number
def test_a_trial_left_before_its_first_heartbeat_is_failed_and_retried(tmp_path: Path) -> None:
    """A worker killed between creating its trial and the trial's first heartbeat leaves a running trial that
    Optuna never fails as stale; the next worker must fail and retry it instead of waiting for it forever (this
    hung the killed-worker test under load)."""
    storage, study = f"sqlite:///{tmp_path / 'study.db'}", "orphan"
    first = subprocess.run(
        sweep_args(storage, study, 1, tmp_path / "best.yml"), capture_output=True, text=True, timeout=600
    )
    assert first.returncode == 0, first.stdout + first.stderr
    orphan = optuna.load_study(study_name=study, storage=storage).ask()  # running, no heartbeat, no worker
    again = subprocess.run(
        sweep_args(storage, study, 3, tmp_path / "best.yml"), capture_output=True, text=True, timeout=300
    )
    assert again.returncode == 0, again.stdout + again.stderr
    assert_complete_study(storage, study, 3)
    trials = optuna.load_study(study_name=study, storage=storage).get_trials()
    assert trials[orphan.number].state == TrialState.FAIL
    assert [RetryHeartbeatStaleTrialCallback.retried_trial_number(t) for t in trials].count(orphan.number) == 1


def test_a_worker_stops_before_its_next_trial_once_its_parent_sets_stop(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The ``--workers`` parent sets its stop event beside forwarding Ctrl-C, for a worker whose Ctrl-C was lost
    (a KeyboardInterrupt raised inside a finalizer is): the trial it runs is handed the event, and no trial starts
    after it."""
    stop = threading.Event()
    handed: list[object] = []

    def set_stop(trial: optuna.Trial, settings: SweepSettings, score: object, stop_event: object) -> float:
        handed.append(stop_event)
        stop.set()
        return 0.0

    monkeypatch.setattr(sweep_module, "objective", set_stop)
    settings = SweepSettings("vegym/BouncingBall-v0", "td3", 3, f"sqlite:///{tmp_path / 'study.db'}", "stop")
    with pytest.raises(KeyboardInterrupt):
        run_worker(settings, log=lambda line: None, stop=stop)
    assert handed == [stop]


def test_a_trial_ctrl_c_stops_is_reported_in_one_line_without_optuna_s_traceback(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    calls: list[str] = []

    def interrupted_then_broken(trial: optuna.Trial, settings: SweepSettings, score: object, stop: object) -> float:
        calls.append("trial")
        if len(calls) == 1:
            raise KeyboardInterrupt
        raise ValueError("a broken trial")

    monkeypatch.setattr(sweep_module, "objective", interrupted_then_broken)
    settings = SweepSettings("vegym/BouncingBall-v0", "td3", 3, f"sqlite:///{tmp_path / 'study.db'}", "ctrl-c")
    lines: list[str] = []
    with pytest.raises(KeyboardInterrupt):
        run_worker(settings, "worker 0", log=lines.append)
    assert lines[-1] == "worker 0: trial 0 interrupted (failed: the sweep runs a new one when it goes on)"
    assert "Trial 0" not in caplog.text  # Optuna's warning and traceback of the KeyboardInterrupt
    with pytest.raises(RuntimeError, match="three trials in a row failed"):
        run_worker(settings, "worker 0", log=lines.append)
    assert "Trial 1 failed with parameters" in caplog.text  # other failures keep Optuna's warning


def test_a_trial_s_training_stops_on_the_stop_event(monkeypatch: pytest.MonkeyPatch) -> None:
    handed: list[object] = []

    def interrupted_training(config: object, out: Path, **kwargs: object) -> TrainResult:
        handed.append(kwargs["stop"])
        return TrainResult(out / "model.zip", 0, True, 0.0)

    monkeypatch.setattr(sweep_module, "train", interrupted_training)
    stop = threading.Event()
    settings = SweepSettings("vegym/BouncingBall-v0", "td3", 1, "sqlite:///unused.db", "stop")
    with pytest.raises(KeyboardInterrupt):
        sweep_module.objective(optuna.create_study().ask(), settings, lambda agent: 0.0, stop)
    assert handed == [stop]


def test_a_sweep_in_this_process_leaves_optuna_s_verbosity_and_torch_s_threads_as_they_were(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """sweep() held Optuna's verbosity at WARNING and set this process's torch threads for its one worker, and left
    them so for the caller (a helper's review)."""
    monkeypatch.setattr(sweep_module, "objective", lambda *args: 0.0)
    threads, verbosity = torch.get_num_threads(), optuna.logging.get_verbosity()
    settings = SweepSettings("vegym/BouncingBall-v0", "td3", 1, f"sqlite:///{tmp_path / 'study.db'}", "restored")
    try:
        optuna.logging.set_verbosity(optuna.logging.DEBUG)
        torch.set_num_threads(2)
        sweep_module.sweep(settings, workers=1, threads=1, log=lambda line: None)
        assert optuna.logging.get_verbosity() == optuna.logging.DEBUG and torch.get_num_threads() == 2
    finally:
        optuna.logging.set_verbosity(verbosity)
        torch.set_num_threads(threads)


def test_a_trial_has_a_heartbeat_before_its_objective_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker records its trial's first heartbeat itself (Optuna's heartbeat thread beats whenever it gets to
    run; here it never does), so that a worker killed later leaves a trial that goes stale."""
    database = tmp_path / "study.db"
    monkeypatch.setattr(HeartbeatThread, "start", lambda self: None)
    monkeypatch.setattr(HeartbeatThread, "join", lambda self: None)
    beats: list[int] = []

    def count_beats(trial: optuna.Trial, settings: SweepSettings, score: object, stop: object) -> float:
        with sqlite3.connect(database) as connection:
            query = "SELECT COUNT(*) FROM trial_heartbeats WHERE trial_id = ?"
            beats.append(connection.execute(query, (trial._trial_id,)).fetchone()[0])
        return 0.0

    monkeypatch.setattr(sweep_module, "objective", count_beats)
    settings = SweepSettings("vegym/BouncingBall-v0", "td3", 2, f"sqlite:///{database}", "beats", eval_episodes=1)
    assert run_worker(settings, log=lambda line: None) == 2
    assert beats == [1, 1]


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_sampled_hyperparameters_make_valid_configs(algo: str) -> None:
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    for env_id in load_configs(CONFIG_DIR / f"{algo}.yml"):
        base = load_config(CONFIG_DIR / f"{algo}.yml", env_id, algo)
        for _ in range(5):
            trial = study.ask()
            config = with_overrides(base, sample_hyperparams(trial, base), "test")  # ConfigError if invalid
            if algo == "ppo":
                assert config.hyperparams["batch_size"] <= config.hyperparams["n_steps"] * config.n_envs
            study.tell(trial, 0.0)


def test_tune_env_ranges_are_checked_against_the_env_parameters() -> None:
    ranges = parse_tune_env(["bottom_out_penalty=0.5:5"], "vegym/Suspension-v0")
    assert ranges == {"bottom_out_penalty": (0.5, 5.0)}
    with pytest.raises(ValueError, match="has no parameter 'nope'"):
        parse_tune_env(["nope=0:1"], "vegym/Suspension-v0")
    with pytest.raises(ValueError, match="--tune-env 'bottom_out_penalty=-1:1': bottom_out_penalty"):
        parse_tune_env(["bottom_out_penalty=-1:1"], "vegym/Suspension-v0")
    with pytest.raises(ValueError, match="expected NAME=LOW:HIGH"):
        parse_tune_env(["bottom_out_penalty"], "vegym/Suspension-v0")


def test_bad_storage_urls_are_clear_errors(capsys: pytest.CaptureFixture[str]) -> None:
    base = ["sweep", "--env", "BouncingBall-v0", "--algo", "td3", "--trials", "1"]
    for storage, message in [
        ("foo", "is not a database URL"),
        ("sqlite://", "a sweep needs a SQLite file"),
        ("mysql://u@h/db", "runs on sqlite:/// or postgresql://"),
    ]:
        assert main([*base, "--storage", storage]) == 2
        assert message in capsys.readouterr().out


def test_a_storage_that_cannot_be_opened_is_one_clear_error_that_masks_the_password(
    capsys: pytest.CaptureFixture[str],
) -> None:
    base = ["sweep", "--env", "BouncingBall-v0", "--algo", "td3", "--trials", "1"]
    for storage, shown in [
        ("postgresql://user:secret@127.0.0.1:1/db", "'postgresql://user:***@127.0.0.1:1/db'"),  # nothing listens
        ("postgresql://127.0.0.1:1/db?password=secret", "'postgresql://127.0.0.1:1/db?password=***'"),
        ("sqlite:////proc/study.db", "'sqlite:////proc/study.db'"),
    ]:
        assert main([*base, "--storage", storage]) == 2
        out = capsys.readouterr().out
        assert out.startswith(f"error: --storage {shown}: cannot open the database: ") and out.count("\n") == 1
        assert "secret" not in out and "study " not in out  # nor is the study announced before it opens
    assert main([*base, "--storage", "sqlite:////proc/vegym/study.db"]) == 2
    assert capsys.readouterr().out.startswith("error: --storage 'sqlite:////proc/vegym/study.db': cannot create")


def test_a_printed_storage_url_masks_the_whole_password_even_with_an_unescaped_at_sign() -> None:
    """SQLAlchemy ends the password at its first ``@`` and reads the rest as the host, which it would show; a
    password may hold a ``?`` too."""
    for url, shown in [
        ("postgresql://user:secret@db.example:5432/study", "postgresql://user:***@db.example:5432/study"),
        ("postgresql://user:se@c/r@et@db.example/study", "postgresql://user:***@db.example/study"),
        ("postgresql://user:se?cret@db.example/study", "postgresql://user:***@db.example/study"),
        ("postgresql://user:se?c@ret@db.example/study?x=1", "postgresql://user:***@db.example/study?x=1"),
        ("postgresql://user:secret@db.example/study?x=a@b", "postgresql://user:***@db.example/study?x=a@b"),
        ("postgresql+psycopg2://u:p@h/db?password=secret&x=1", "postgresql+psycopg2://u:***@h/db?password=***&x=1"),
        ("postgresql://user@db.example:5432/study", "postgresql://user@db.example:5432/study"),
        ("sqlite:////tmp/a@b/study.db", "sqlite:////tmp/a@b/study.db"),
    ]:
        assert shown_storage(url) == shown


def test_a_storage_that_opens_but_refuses_the_study_s_first_write_is_one_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A read-only SQLite file opens (reading its tables) and fails at the study's creation, which raised Optuna's
    StorageInternalError with its traceback."""

    def read_only(**kwargs: object) -> optuna.Study:
        refusal = sqlite3.OperationalError("attempt to write a readonly database")
        try:
            raise sqlalchemy.exc.OperationalError("INSERT INTO studies", {}, refusal)
        except sqlalchemy.exc.OperationalError as error:
            raise optuna.exceptions.StorageInternalError("An exception is raised during the commit.") from error

    monkeypatch.setattr(optuna, "create_study", read_only)
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    assert main(["sweep", "--env", "BouncingBall-v0", "--algo", "td3", "--trials", "1", "--storage", storage]) == 2
    expected = f"error: --storage {storage!r}: cannot open the database: attempt to write a readonly database\n"
    assert capsys.readouterr().out == expected


def test_an_env_without_a_config_entry_is_refused_before_the_study_is_created(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    database = tmp_path / "sweep.db"
    args = ["sweep", "--env", "Aircraft-v0", "--algo", "td3", "--trials", "1", "--storage", f"sqlite:///{database}"]
    assert main(args) == 2
    assert "no entry for vegym/Aircraft-v0" in capsys.readouterr().out
    assert not database.exists()


@pytest.mark.parametrize(
    ("signum", "sigint_ignored"),
    [(signal.SIGINT, False), (signal.SIGINT, True), (signal.SIGTERM, False)],
    ids=["sigint", "sigint_to_a_background_job", "sigterm"],
)
def test_an_interrupt_to_the_parent_alone_stops_its_workers(
    tmp_path: Path, signum: signal.Signals, sigint_ignored: bool
) -> None:
    """A script's background job starts with SIGINT ignored, and its workers inherit that: the parent (which
    forwards the interrupt) and the workers handle Ctrl-C anyway. SIGTERM stops them as Ctrl-C does."""
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    args = [*sweep_args(storage, "stopped", 50, tmp_path / "best.yml", "--workers", "2"), "--timesteps", "1000000"]
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if sigint_ignored else None
    parent = subprocess.Popen(
        args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=ignore, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 300
        while training_trials(tmp_path / "study.db") < 2:
            if time.monotonic() > deadline:
                pytest.fail("the workers never started their trials")
            time.sleep(0.2)
        parent.send_signal(signum)  # to the parent's pid only: the workers hear of it from the parent
        assert parent.wait(timeout=60) == 130
    finally:  # a failure leaves no sweep training on: the parent's session holds its workers
        if parent.poll() is None:
            os.killpg(parent.pid, signal.SIGKILL)
            parent.wait()


class _Trial:
    def __init__(self, prune: bool) -> None:
        self.prune, self.reports = prune, []

    def report(self, value: float, step: int) -> None:
        self.reports.append((value, step))

    def should_prune(self) -> bool:
        return self.prune


@pytest.mark.parametrize("prune", [False, True])
def test_a_pruned_trial_stops_its_training_at_the_report(prune: bool) -> None:
    trial = _Trial(prune)
    callback = ReportAndPrune(trial, lambda agent: 0.25, n_timesteps=100, reports=4)
    callback.model = SimpleNamespace(get_vec_normalize_env=lambda: None)
    callback.num_timesteps = 24
    assert callback._on_step() and trial.reports == []  # before the first report at 25 steps
    callback.num_timesteps = 25
    assert callback._on_step() is (not prune) and callback.pruned is prune
    assert trial.reports == [(0.25, 25)]


def test_the_sweep_scores_on_its_own_episodes_from_0_random_to_1_analytic() -> None:
    """Sweep episodes lie apart from compare's (seeds EVAL_SEED..EVAL_SEED+19, README), so that a tuned config is
    not chosen on the episodes it is then reported on."""
    assert SWEEP_EVAL_SEED >= EVAL_SEED + 20
    scorer = Scorer("vegym/BouncingBall-v0", 2, {})
    env = gym.make("vegym/BouncingBall-v0")
    assert scorer(controller_for(env)) == pytest.approx(1.0, abs=1e-12)
    assert scorer(RandomAgent(env.action_space, SWEEP_EVAL_SEED)) == pytest.approx(0.0, abs=1e-12)


def test_an_in_memory_sqlite_storage_is_refused() -> None:
    """Workers share the study through a file; an in-memory database would vanish with each process."""
    with pytest.raises(ValueError, match="a sweep needs a SQLite file"):
        check_storage("sqlite:///:memory:")


def test_a_stale_trial_s_grace_period_is_two_heartbeats(tmp_path: Path) -> None:
    storage = sweep_module.open_storage(f"sqlite:///{tmp_path / 's.db'}", heartbeat=7)
    assert storage.get_heartbeat_interval() == 7
    assert storage.grace_period == 14


def test_a_trial_pruned_during_training_ends_pruned(monkeypatch: pytest.MonkeyPatch) -> None:
    def pruned_training(config: object, out: Path, **kwargs: object) -> TrainResult:
        kwargs["callbacks"][0].pruned = True  # as ReportAndPrune marks it when the pruner says so
        return TrainResult(out / "model.zip", 0, False, 0.0)

    monkeypatch.setattr(sweep_module, "train", pruned_training)
    settings = SweepSettings("vegym/BouncingBall-v0", "td3", 1, "sqlite:///unused.db", "prune")
    with pytest.raises(optuna.TrialPruned):
        sweep_module.objective(optuna.create_study().ask(), settings, lambda agent: 0.0)


def test_a_password_query_parameter_is_masked_in_any_case() -> None:
    assert shown_storage("postgresql://u@h/db?PASSWORD=secret&x=1") == "postgresql://u@h/db?PASSWORD=***&x=1"
    assert shown_storage("postgresql://u@h/db?x=1&Password=secret") == "postgresql://u@h/db?x=1&Password=***"


def test_a_tune_env_range_must_not_be_empty() -> None:
    with pytest.raises(ValueError, match="LOW=1 must be below HIGH=1"):
        parse_tune_env(["bottom_out_penalty=1:1"], "vegym/Suspension-v0")


def test_a_study_created_for_other_settings_is_refused(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 's.db'}"
    load_study(SweepSettings("vegym/BouncingBall-v0", "td3", 1, url, "s"))
    load_study(SweepSettings("vegym/BouncingBall-v0", "td3", 4, url, "s"))  # more trials: the same study
    with pytest.raises(ValueError, match="study 's' in .* was created for .*, not "):
        load_study(SweepSettings("vegym/BouncingBall-v0", "td3", 1, url, "s", eval_episodes=3))


def test_a_worker_gives_up_after_exactly_three_failed_trials_in_a_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[int] = []

    def broken(trial: object, settings: object, score: object, stop: object) -> float:
        calls.append(trial.number)
        raise ValueError("a broken trial")

    monkeypatch.setattr(sweep_module, "objective", broken)
    settings = SweepSettings(
        "vegym/BouncingBall-v0", "td3", 5, f"sqlite:///{tmp_path / 's.db'}", "broken", eval_episodes=1
    )
    with pytest.raises(RuntimeError, match="three trials in a row failed"):
        run_worker(settings, log=lambda line: None)
    assert calls == [0, 1, 2]


def test_a_sampled_ppo_batch_fits_the_rollout_of_a_config_with_one_env() -> None:
    """The committed configs run 8 or more envs, where the largest batch (512) always fits the smallest rollout
    (64 x 8); a config of one env must still get batches no larger than its rollout."""
    base = with_overrides(load_config(CONFIG_DIR / "ppo.yml", "vegym/Projectile-v0", "ppo"), {"n_envs": 1}, "test")
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    for _ in range(20):
        trial = study.ask()
        values = sample_hyperparams(trial, base)
        assert values["batch_size"] <= values["n_steps"]
        study.tell(trial, 0.0)
