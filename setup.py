"""Build hook (the rest of the build is pyproject.toml): the wheel carries the top-level ``configs/*.yml`` as
``agents/configs/``, where :data:`agents.config.CONFIG_DIR` finds them outside a checkout."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py


class BuildPyWithConfigs(build_py):
    def run(self) -> None:
        super().run()
        target = Path(self.build_lib, "agents", "configs")
        target.mkdir(parents=True, exist_ok=True)
        for path in sorted(Path(__file__).resolve().parent.joinpath("configs").glob("*.yml")):
            shutil.copy2(path, target / path.name)


setup(cmdclass={"build_py": BuildPyWithConfigs})
