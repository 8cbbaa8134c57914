"""The README's test command is what CI runs."""

from pathlib import Path

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
