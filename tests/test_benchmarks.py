"""The benchmark scripts measure vegym, not what they import."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

import vegym

ROOT = Path(__file__).resolve().parent.parent


def test_env_ids_resolve_with_or_without_the_namespace() -> None:
    assert vegym.resolve_env_id("Billiards-v0") == vegym.resolve_env_id("vegym/Billiards-v0") == "vegym/Billiards-v0"
    with pytest.raises(ValueError, match="unknown env 'Billiards'; registered: vegym/BouncingBall-v0"):
        vegym.resolve_env_id("Billiards")


def test_the_speed_benchmark_imports_neither_torch_nor_stable_baselines3() -> None:
    """speed.py reports its process's peak memory as vegym's: torch, imported for the env-id resolver when that
    lived in agents.config, added about 185 MiB to it."""
    code = (
        "import importlib.util, sys\n"
        f"spec = importlib.util.spec_from_file_location('speed', {str(ROOT / 'benchmarks' / 'speed.py')!r})\n"
        "spec.loader.exec_module(importlib.util.module_from_spec(spec))\n"
        "print(sorted(m for m in ('torch', 'stable_baselines3') if m in sys.modules))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert result.stdout.strip() == "[]"


def test_the_speed_benchmark_counts_autoreset_steps_apart_from_transitions() -> None:
    """Under NEXT_STEP autoreset a one-step env spends every other step restarting: half its env-steps."""
    spec = importlib.util.spec_from_file_location("speed", ROOT / "benchmarks" / "speed.py")
    speed = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(speed)
    assert speed.transition_share("vegym/Projectile-v0", 4) == 0.5
    assert 0.9 < speed.transition_share("CartPole-v1", 64) < 1.0
    assert speed.transition_share("vegym/Aircraft-v0", 64) == 1.0  # 256 steps, within one 300-step episode
