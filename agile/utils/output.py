"""How much Warp prints. Quiet by default, from Python as from the commands: its banner, a line per kernel module it
loads and, on a machine without a GPU, its CUDA-driver warning are for whoever debugs Warp. The one switch:
AGILE_VERBOSE=1 in the environment (the commands' --verbose sets it) shows them all."""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile

VERBOSE_ENV = "AGILE_VERBOSE"
WARP_NO_DRIVER_MESSAGE = "Warp CUDA warning: Could not find or load the NVIDIA CUDA driver"


def verbose() -> bool:
    """Whether AGILE_VERBOSE asks for the libraries' own output (any value but empty or 0)."""
    return os.environ.get(VERBOSE_ENV, "") not in ("", "0")


def configure_warp_output() -> None:
    """Warp quiet unless `verbose()`; Warp initialised here (once) so that its banner and driver warning are
    governed too. Called by the envs before they build their simulation."""
    import warp as wp

    loud = verbose()
    wp.config.quiet = not loud
    wp.config.log_level = wp.LOG_INFO if loud else wp.LOG_WARNING
    if loud:
        wp.init()
    else:
        init_warp_without_driver_warning()


def init_warp_without_driver_warning() -> None:
    """Initialise Warp with its C library's stderr captured: on a machine without a GPU it prints that the CUDA
    driver is missing (the commands say "no GPU found" in their own words). Any other line is passed on."""
    import warp as wp

    sys.stderr.flush()
    saved_fd = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as captured:
        os.dup2(captured.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved_fd, 2)
            os.close(saved_fd)
        captured.seek(0)
        text = captured.read().decode(errors="replace")
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith(WARP_NO_DRIVER_MESSAGE)]
    if lines:
        print("\n".join(lines), file=sys.stderr)


@contextlib.contextmanager
def quiet_python_output():
    """What libraries print from Python while inside (leapp's export log and its console handler, which binds to
    the stderr of the moment it is made; onnx's optimiser notes), swallowed unless `verbose()`. On an error the
    swallowed text is printed to stderr, so that nothing that explains a failure is lost."""
    if verbose():
        yield
        return
    captured = io.StringIO()
    try:
        with contextlib.redirect_stdout(captured), contextlib.redirect_stderr(captured):
            yield
    except BaseException:
        print(captured.getvalue(), file=sys.stderr, end="")
        raise
