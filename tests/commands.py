"""Running an `agile` command in the test's own process, as `python -m agile <command> ...` would (no fresh
interpreter, no Warp start per call)."""

from __future__ import annotations

import contextlib
import gc
import importlib
import io
import os
import sys

FLAT_GROUND = ("scene.terrain=null", "curriculum.terrain_levels=null")
"""Env overrides (`gym.make(..., overrides=...)`) for a test of something other than the terrain: a registered
rough terrain costs about 8 s of CPU per env build (Newton builds a search tree over its 13 million triangles)."""
FLAT_GROUND_ARGS = tuple(f"env.{override}" for override in FLAT_GROUND)
"""The same as a command's overrides."""
SMALL_TERRAIN = ("scene.terrain.num_rows=2", "scene.terrain.num_cols=2", "scene.terrain.size_m=2.0",
                 "scene.terrain.border_width_m=0.5")
"""Env overrides for a test that needs a terrain but not the registered one: 2 x 2 cells of 2 m, built in well
under a second."""
SMALL_TERRAIN_ARGS = tuple(f"env.{override}" for override in SMALL_TERRAIN)


def run_command(command: str, *args, cwd=None) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of `agile.run.<command>.main(args)`."""
    return run_main(importlib.import_module(f"agile.run.{command}").main, *args, cwd=cwd)


def run_main(main, *args, cwd=None) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of a command line's `main(args)` (a command's, or `agile.tasks.main`); the
    environment, the working folder, `sys.argv[0]` and the commands' verbosity are put back afterwards (a --verbose
    run sets AGILE_VERBOSE)."""
    from agile.run import task_setup as common

    environ, verbose, folder, argv0 = dict(os.environ), common.VERBOSE, os.getcwd(), sys.argv[0]
    out, err = io.StringIO(), io.StringIO()
    code = 0
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args]) or 0
            except SystemExit as exit_info:
                code = exit_info.code if isinstance(exit_info.code, int) else int(exit_info.code is not None)
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
        sys.argv[0] = argv0
    return code, out.getvalue(), err.getvalue()
