"""agile time_to_policy on the CPU: the training runs as its own process (the point of the tool), checkpoints are
evaluated as they appear, and the run stops at the first one that meets the criteria."""

import json

from agile.run.time_to_policy import main


def test_the_run_stops_at_the_first_checkpoint_that_meets_the_criteria(tmp_path, capsys):
    out = tmp_path / "t1"
    code = main(["--task", "Velocity-T1-v0", "--budget_s", "300", "--num_envs", "2", "--device", "cpu",
                 "--save_interval", "1", "--eval_num_envs", "2", "--eval_episode_length_s", "0.4",
                 "--criterion", "fall_rate=1.0", "--out", str(out), "agent.num_steps_per_env=4"])
    result = json.loads(out.with_suffix(".json").read_text())
    assert code == 0, capsys.readouterr()
    # met at the first checkpoint evaluated (the newest when the evaluator looks: with iterations this short the
    # training may be past iteration 0 by then), and the training stopped: nothing more evaluated
    (first,) = result["evaluations"]
    assert result["criteria"] == {"fall_rate": 1.0} and result["iteration_at_criteria"] == first["iteration"]
    assert first["met"] and 0 < result["time_to_policy_s"] < 300 and result["first_iteration_s"] is not None
    assert "Learning iteration 0" in (tmp_path / "t1.log").read_text()  # the training's own log beside it
