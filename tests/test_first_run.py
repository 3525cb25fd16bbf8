"""What a first run meets (issue 63): a listing without simulator work, a closed pipe, an output path that cannot
be written, Ctrl-C in a training."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.commands import FLAT_GROUND_ARGS, run_command

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def test_agile_list_loads_no_config_env_or_kernel():
    code = ("import sys; from agile.cli import main; main(['list']); "
            "heavy = [m for m in ('torch', 'warp', 'newton', 'agile.rl_env', 'agile.rl') if m in sys.modules]; "
            "assert not heavy, heavy")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[:4] == ["task", "kind", "shipped", "policy"] and "Velocity-T1-v0" in result.stdout


def test_a_closed_pipe_ends_the_command_quietly():
    """`agile list | head -0`: the reader is gone before the first write."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    result = subprocess.run([sys.executable, "-m", "agile", "list"], stdout=write_end, stderr=subprocess.PIPE,
                            text=True, env=ENV, timeout=120)
    os.close(write_end)
    assert result.returncode == 0 and result.stderr == "", result.stderr


@pytest.mark.parametrize("command, option", [("export", "--out"), ("eval", "--out"), ("train", "--log_root"),
                                             ("eval", "--video")])
def test_an_output_path_that_cannot_be_written_is_refused_in_one_line_before_the_env_is_built(command, option,
                                                                                             tmp_path):
    (tmp_path / "a_file").write_text("")
    for path, said in ((tmp_path / "a_file" / "out", "is a file, not a folder"), ("/proc/agile_out", "/proc cannot "
                                                                                  "be written")):
        code, out, err = run_command(command, "--task", "Velocity-T1-v0", "--device", "cpu", option, path)
        assert code == 2 and err.count("\n") == 1 and f"error: {option} {path}: " in err and said in err, out + err
        assert "building" not in out and "Traceback" not in err


def interruptible() -> None:
    """In the child before it starts: SIGINT as a terminal delivers it. Under a shell's background job (a CI runner's
    `cmd &`) SIGINT is ignored, and Python keeps an ignored SIGINT ignored: the Ctrl-C would never arrive."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow
def test_ctrl_c_in_a_training_saves_a_checkpoint_and_ends_in_a_line(tmp_path):
    process = subprocess.Popen(
        [sys.executable, "-m", "agile", "train", "--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "2",
         "--max_iterations", "1000", "--log_root", str(tmp_path), *FLAT_GROUND_ARGS],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=tmp_path,
        preexec_fn=interruptible)
    lines = []
    deadline = time.monotonic() + 300
    for line in process.stdout:  # the first env step is timed and said: the training loop runs
        lines.append(line)
        if line.startswith("[agile] the first env step took") or time.monotonic() > deadline:
            break
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=120)
    out = "".join(lines) + out
    assert process.returncode == 130, out + err
    assert "Traceback" not in err and err.strip() == "[agile] interrupted", err
    assert "[agile] the first env step took" in out and "an iteration's 24 steps take up to" in out
    saved = list(tmp_path.glob("velocity_t1/*/model_*.pt"))
    assert len(saved) == 1 and f"its weights saved in {saved[0]}" in out, out


def test_every_commands_help_imports_no_simulator():
    """The reference of the commands is generated from their --help: each is quick, without torch or Warp."""
    from agile.cli import FORWARDED
    from agile.gui.viewer import LOCAL_HOST
    from agile.run import play

    assert play.LOCAL_HOST == LOCAL_HOST
    code = ("import contextlib, io, sys\nfrom agile.cli import FORWARDED, main\nfor name in FORWARDED:\n"
            "    with contextlib.redirect_stdout(io.StringIO()) as out:\n        try:\n            main([name, '--help'])\n"
            "        except SystemExit as end:\n            assert end.code == 0, name\n"
            "    assert out.getvalue().startswith('usage: agile ' + name), name\n"
            "heavy = [m for m in ('torch', 'warp', 'newton') if m in sys.modules]\nassert not heavy, heavy\n"
            "print(len(FORWARDED))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV, timeout=120)
    assert result.returncode == 0 and result.stdout.strip() == str(len(FORWARDED)), result.stderr
