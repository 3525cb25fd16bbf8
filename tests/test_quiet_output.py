"""What a newcomer's run prints: the commands and the library say nothing from Warp, torch or rsl-rl underneath
unless --verbose (AGILE_VERBOSE=1). Fresh interpreters: what those libraries print outside Python is the point."""

import subprocess
import sys
from pathlib import Path

import pytest
from commands import FLAT_GROUND_ARGS

ROOT = Path(__file__).resolve().parents[1]


def run_process(*args, timeout=600):
    """(exit code, stdout and stderr) of a fresh interpreter: for what Warp and torch print outside Python."""
    result = subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    return result.returncode, result.stdout + result.stderr


NOISE = ("load on device", "Actor Model", "Critic Model", "Could not find git repository", "FutureWarning",
         "DeprecationWarning", "Traceback", "torchvision is not installed", "Warp CUDA warning")
"""What a newcomer's run must not print unless --verbose."""


@pytest.mark.slow
def test_a_quiet_run_prints_no_library_noise(tmp_path):
    code, out = run_process("scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--max_iterations", "1",
                            "--device", "cpu", "--log_root", str(tmp_path), "agent.num_steps_per_env=4",
                            *FLAT_GROUND_ARGS)
    assert code == 0, out
    assert not [n for n in NOISE if n in out], out
    assert "Learning iteration" in out and "\x1b[" not in out, out  # rsl-rl's block, without bold codes in a log
    assert "[agile] building Velocity-T1-v0" in out  # a word of progress before the long first build
    code, out = run_process("scripts/play.py", "--task", "Velocity-T1-v0", "--num_envs", "1", "--num_steps", "2",
                            "--device", "cpu", "--verbose", *FLAT_GROUND_ARGS)
    assert code == 0 and "load on device" in out, out  # --verbose shows Warp's module loads again


@pytest.mark.slow
def test_the_library_is_quiet_by_default():
    """The README's gym.make snippet in a fresh interpreter (the process's output is the point): nothing from Warp,
    its banner, kernel loads and CUDA-driver warning included."""
    import os

    program = ("import gymnasium as gym, torch, agile.tasks\n"  # on the task's terrain (the quiet run is on flat ground)
               "env = gym.make('Velocity-T1-v0', num_envs=1, device='cpu')\n"
               "env.reset(); env.step(torch.zeros(1, 12)); print('stepped')\n")
    result = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=600,
                            env={k: v for k, v in os.environ.items() if k != "AGILE_VERBOSE"})
    assert result.returncode == 0, result.stderr
    assert (result.stdout + result.stderr).strip() == "stepped", result.stdout + result.stderr


def test_agile_verbose_is_the_switch_for_warps_output(monkeypatch):
    import warp as wp

    from agile.utils.output import configure_warp_output

    monkeypatch.setenv("AGILE_VERBOSE", "1")
    configure_warp_output()
    assert not wp.config.quiet and wp.config.log_level == wp.LOG_INFO
    monkeypatch.delenv("AGILE_VERBOSE")
    configure_warp_output()
    assert wp.config.quiet and wp.config.log_level == wp.LOG_WARNING
