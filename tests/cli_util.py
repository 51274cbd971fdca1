"""What the command-line tests share: a command run in-process, and the shape of a clean error."""

from __future__ import annotations

from click.testing import CliRunner, Result

from moli.app import cli


def run(*args: str) -> Result:
    return CliRunner().invoke(cli.cli, list(args), prog_name="moli")


def assert_clean_error(result: Result, message: str) -> None:
    """Exit code 2 and one line on stderr naming the problem: no traceback, no progress bar."""
    assert result.exit_code == 2, result.output + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("moli: error: "), result.stderr
    assert message in lines[0], lines[0]
