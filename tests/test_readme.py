"""What the README says of CI and the CLI is so: its test command is what CI runs, its envs and commands exist."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_readme_test_command_is_the_ci_command() -> None:
    ci_lines = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if line.startswith("python -m venv")]
    assert len(ci_lines) == 1
    readme = (ROOT / "README.md").read_text()
    head = readme[: readme.index("## Environments")]
    assert ci_lines[0] in head.splitlines()


def test_readme_lists_every_registered_env() -> None:
    import vegym

    readme = (ROOT / "README.md").read_text()
    for env_id in vegym.ENVS:
        assert f"`{env_id}`" in readme


def test_every_vegym_command_the_readme_names_is_a_cli_command(capsys: pytest.CaptureFixture[str]) -> None:
    from agents.cli import build_parser

    readme = (ROOT / "README.md").read_text()
    named = set(re.findall(r"(?:^|`)vegym ([a-z]+)", readme, flags=re.MULTILINE))
    assert {"compare", "train"} <= named
    for command in sorted(named):
        with pytest.raises(SystemExit) as exit_info:
            build_parser().parse_args([command, "--help"])
        assert exit_info.value.code == 0, f"the README names `vegym {command}`, which is not a command"
    capsys.readouterr()
