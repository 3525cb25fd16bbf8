"""agile gpu_scaling on the CPU (ranks on gloo, the path of a several-GPU host): the training under torchrun timed from
its checkpoints' recorded wall times, the gradients' all-reduce timed alone, the ranks' weights compared; bad input
refused in one line before anything runs."""

import json
import re

import pytest

from commands import FLAT_GROUND_ARGS, run_command

from agile.errors import AgileError
from agile.run.gpu_scaling import gpu_scaling


@pytest.mark.slow
def test_two_cpu_ranks_are_timed_from_their_checkpoints_with_the_allreduce_alone(tmp_path):
    out = tmp_path / "scaling"
    result = gpu_scaling(task="Velocity-T1-v0", gpus=[2], num_envs=2, out=str(out), iterations=3, save_interval=1,
                         device="cpu", allreduce_repeats=3, overrides=("agent.num_steps_per_env=2", *FLAT_GROUND_ARGS))
    assert json.loads(out.with_suffix(".json").read_text()) == result
    (row,) = result["rows"]
    # timed from the first checkpoint past the first third of the run to the last (iterations 0-2, one each)
    assert row["gpus"] == 2 and row["timed_iterations"] == [1, 2] and row["iteration_s"] > 0
    assert row["env_steps_per_s"] == pytest.approx(2 * 2 * 2 / row["iteration_s"])
    # the update all-reduces T1's 358,809 parameters (the normalisers' statistics aside) in 5 epochs x 4 mini-batches
    assert row["gradient_floats"] == 358_809 and row["allreduces_per_iteration"] == 20
    assert 0 < row["allreduce_s"] and 0 < row["allreduce_share"] < 1 and row["same_weights"]
    assert row["speedup"] == 1.0 and row["efficiency"] == 1.0  # the fewest GPUs measured are the base
    assert "all 2 ranks hold the same weights" in (tmp_path / "scaling_gpus2.log").read_text()


@pytest.mark.parametrize("kwargs, message", [
    ({"gpus": [0]}, "gpus: positive GPU counts, got [0]"),
    ({"gpus": [1], "device": "cuda:1"}, "device: cpu (CPU ranks, gloo) or None (the host's GPUs), got 'cuda:1'"),
    ({"gpus": [1], "device": "cpu", "iterations": 20, "save_interval": 10}, "iterations must be at least 30, got 20"),
    ({"gpus": [1], "device": "cpu", "recipe": "fastest"}, "recipe must be one of"),
    ({"gpus": [1], "device": "cpu", "timeout_s": 0}, "timeout_s must be positive, got 0"),
    ({"gpus": [1], "device": "cpu", "overrides": ["agent.algorithm.nope=1"]}, "has no field 'nope'"),
])
def test_bad_input_is_refused_naming_the_field(kwargs, message, tmp_path):
    with pytest.raises(AgileError, match=re.escape(message)):
        gpu_scaling(task="Velocity-T1-v0", num_envs=2, out=str(tmp_path / "s"), **kwargs)
    assert not (tmp_path / "s.json").exists()


def test_the_command_says_what_the_host_lacks_in_one_line(tmp_path):
    import torch

    count = torch.cuda.device_count()
    code, _, err = run_command("gpu_scaling", "--task", "Velocity-T1-v0", "--num_envs", "2", "--gpus", str(count + 1),
                               "--out", str(tmp_path / "s"))
    assert code == 2 and err.strip() == (f"error: gpus: {count + 1} GPUs asked, this host has {count} (--device cpu "
                                         f"runs the counts as CPU ranks)")
