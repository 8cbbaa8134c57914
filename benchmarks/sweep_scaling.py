"""Wall time of the same ``vegym sweep`` with 1 and with 2 worker processes on this machine.

Run: ``python benchmarks/sweep_scaling.py [--trials 20] [--env Projectile-v0] [--algo td3] [--timesteps 3000]``.
Each run starts a fresh SQLite study in a temporary directory and times the whole command (worker start-up,
the references' evaluation, every trial, writing the best config). Prints a markdown table and, with ``--json``,
the figures for machines. The trials differ between the two runs (each worker's sampler draws its own), so the
ratio carries the spread of trial lengths as well as the parallel speed-up.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import optuna
from optuna.trial import TrialState

VEGYM = [sys.executable, "-c", "import sys; from agents.cli import main; sys.exit(main())"]


def run_sweep(workers: int, args: argparse.Namespace) -> dict[str, float]:
    """Time one sweep of ``args.trials`` trials with ``workers`` processes; count its trials by state."""
    with tempfile.TemporaryDirectory(prefix="vegym-sweep-bench-") as scratch:
        storage = f"sqlite:///{Path(scratch) / 'study.db'}"
        command = [
            *VEGYM,
            "sweep",
            "--env",
            args.env,
            "--algo",
            args.algo,
            "--trials",
            str(args.trials),
            "--timesteps",
            str(args.timesteps),
            "--storage",
            storage,
            "--study",
            "bench",
            "--workers",
            str(workers),
            "--best",
            str(Path(scratch) / "best.yml"),
        ]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"vegym sweep failed (exit status {done.returncode}):\n{done.stdout}{done.stderr}")
        seconds = time.perf_counter() - start
        trials = optuna.load_study(study_name="bench", storage=storage).get_trials()
    return {
        "workers": workers,
        "wall_time_s": seconds,
        "complete": sum(t.state == TrialState.COMPLETE for t in trials),
        "pruned": sum(t.state == TrialState.PRUNED for t in trials),
        "failed": sum(t.state == TrialState.FAIL for t in trials),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--env", default="Projectile-v0")
    parser.add_argument("--algo", default="td3")
    parser.add_argument("--timesteps", type=int, default=3_000)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = parser.parse_args()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    runs = [run_sweep(workers, args) for workers in (1, 2)]
    if args.json:
        print(json.dumps({"settings": vars(args), "runs": runs}, indent=2))
        return
    print(f"`vegym sweep --env {args.env} --algo {args.algo} --trials {args.trials} --timesteps {args.timesteps}`")
    print()
    print("| workers | wall time (s) | complete | pruned | failed | speed-up |")
    print("|---|---|---|---|---|---|")
    for run in runs:
        speedup = runs[0]["wall_time_s"] / run["wall_time_s"]
        print(
            f"| {run['workers']} | {run['wall_time_s']:.0f} | {run['complete']} | {run['pruned']} | "
            f"{run['failed']} | {speedup:.2f}x |"
        )


if __name__ == "__main__":
    main()
