"""Training steps and wall time of every shipped agent, from the ``train_stats.json`` that ``vegym train`` wrote.

Run: ``python benchmarks/training_times.py`` (prints a markdown table). Wall times are what the machine that
trained the agent measured (2 cores here, shared by the runs listed in benchmarks/README.md).
"""

from __future__ import annotations

import json
from pathlib import Path

PRETRAINED = Path(__file__).resolve().parent.parent / "agents" / "pretrained"


def main() -> None:
    print("| env | algo | steps | wall time (s) | command |")
    print("|---|---|---|---|---|")
    for stats_file in sorted(PRETRAINED.glob("*/*/train_stats.json")):
        stats = json.loads(stats_file.read_text())
        command = (stats_file.parent / "command.txt").read_text().strip()
        env, algo = stats_file.parent.parent.name, stats_file.parent.name
        print(f"| {env} | {algo} | {stats['timesteps']} | {stats['wall_time_s']:.0f} | `{command}` |")


if __name__ == "__main__":
    main()
