"""Running an `agile` command in the test's own process, as `python -m agile <command> ...` would (no fresh
interpreter, no Warp start per call)."""

from __future__ import annotations

import contextlib
import gc
import importlib
import io
import os
import sys


def run_command(command: str, *args, cwd=None) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of `agile.run.<command>.main(args)`; the environment, the working folder and
    the commands' verbosity are put back afterwards (a --verbose run sets AGILE_VERBOSE)."""
    from agile.run import common

    module = importlib.import_module(f"agile.run.{command}")
    environ, verbose, folder = dict(os.environ), common.VERBOSE, os.getcwd()
    out, err = io.StringIO(), io.StringIO()
    code = 0
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = module.main([str(a) for a in args]) or 0
            except SystemExit as exit_info:
                code = exit_info.code if isinstance(exit_info.code, int) else 1
                if not isinstance(exit_info.code, (int, type(None))):
                    print(exit_info.code, file=sys.stderr)
    finally:
        # the command's env and runner hold the simulation's buffers in reference cycles, which the garbage collector
        # frees only when it next runs: without this a worker grew by about 0.9 GiB per command, to an OOM kill
        gc.collect()
        os.chdir(folder)
        os.environ.clear()
        os.environ.update(environ)
        common.VERBOSE = verbose
    return code, out.getvalue(), err.getvalue()
