"""The wheel: what an install outside the checkout needs (configs, shipped agents, licence)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LEFT_OUT = (".git", ".venv", "build", "dist", "runs", "compare_out", "*.egg-info", "__pycache__", ".pytest_cache")


def test_the_wheel_carries_the_configs_the_shipped_agents_and_the_licence(tmp_path: Path) -> None:
    """Built from a copy of the checkout (a build writes into its source tree), without network or isolation (the
    venv has setuptools >= 77, which torch requires).
    ``vegym train`` read ``configs/<algo>.yml`` beside site-packages before: a wheel install could not train."""
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(*LEFT_OUT))
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(tmp_path), "."],
        cwd=source,
        check=True,
        timeout=300,
    )
    names = set(zipfile.ZipFile(next(tmp_path.glob("vegym-*.whl"))).namelist())
    configs = {f"agents/configs/{path.name}" for path in (ROOT / "configs").glob("*.yml")}
    assert len(configs) == 3 and configs <= names
    agents = {f"agents/{p.relative_to(ROOT / 'agents')}" for p in (ROOT / "agents/pretrained").rglob("*.zip")}
    assert agents and agents <= names
    assert any(name.endswith(".dist-info/licenses/LICENSE") for name in names)
