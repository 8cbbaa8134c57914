"""Training steps and wall time of every shipped agent and training seed, from the ``train_stats.json`` that
``vegym train`` wrote in each ``seed_<k>/`` run directory.

Run: ``python benchmarks/training_times.py`` (prints a markdown table). Wall times are what the machine that
trained the agent measured (2 cores here, shared by the runs listed in benchmarks/README.md).
"""

from __future__ import annotations

import json
from pathlib import Path

PRETRAINED = Path(__file__).resolve().parent.parent / "agents" / "pretrained"


def main() -> None:
    print("| env | algo | seed | steps | wall time (s) | command |")
    print("|---|---|---|---|---|---|")
    for stats_file in sorted(PRETRAINED.glob("*/*/seed_*/train_stats.json")):
        stats = json.loads(stats_file.read_text())
        run = stats_file.parent
        command = (run / "command.txt").read_text().strip()
        env, algo, seed = run.parent.parent.name, run.parent.name, run.name.removeprefix("seed_")
        steps = f"{stats['timesteps']}{' (interrupted)' if stats['interrupted'] else ''}"
        print(f"| {env} | {algo} | {seed} | {steps} | {stats['wall_time_s']:.0f} | `{command}` |")


if __name__ == "__main__":
    main()
