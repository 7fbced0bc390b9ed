"""Running the `icil-paper` command in the test's own process (pytest puts tests/ on
sys.path, so test files import this as they import fake_suite)."""

from __future__ import annotations

import contextlib
import io

from icil_paper import cli


def run_cli(*argv):
    """(exit status, stderr) of `icil-paper ...` in this process."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            code = cli.main(list(argv))
        except SystemExit as exc:  # argparse's own errors
            code = exc.code
    return code, err.getvalue()
