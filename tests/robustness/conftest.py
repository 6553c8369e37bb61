"""Shared check of the robustness tests: a command line is refused with exit 2 and one line, quickly."""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest

from neurovpr.cli.main import main


@pytest.fixture
def cli_refused(capsys: pytest.CaptureFixture[str]) -> Callable[..., str]:
    """``cli_refused(argv, pattern)``: run ``neurovpr argv``, assert exit 2 with one error line holding ``pattern``.

    Returns the line. The refusal must come within 10 s and without a traceback.
    """

    def check(argv: list[str], pattern: str = "") -> str:
        start = time.perf_counter()
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own refusals (unknown options) exit 2 with a usage line and one error line
            code = exc.code
        out, err = capsys.readouterr()
        assert code == 2, (argv, out, err)
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and "Traceback" not in err, err
        assert pattern in lines[0], lines[0]
        assert time.perf_counter() - start < 10.0
        return lines[0]

    return check
