"""agile pick_checkpoint on the CPU: the checkpoints it evaluates, the margin it ranks by (consistent with the criteria's
own judgement), the best of a run whose last checkpoint is worse, and clear errors for a bad run or task."""

from __future__ import annotations

import json
import math

import pytest
import torch

from agile.run.pick_checkpoint import main, run_checkpoints
from agile.tasks import pretrained_policy
from agile.tasks.catalogue import missed_criteria, worst_margin


def test_the_checkpoints_at_multiples_and_the_newest(tmp_path):
    for it in (0, 50, 100, 150, 230):
        (tmp_path / f"model_{it}.pt").write_bytes(b"")
    (tmp_path / "model_best.pt").write_bytes(b"")  # not an iteration: ignored
    assert [it for it, _ in run_checkpoints(tmp_path, 100)] == [0, 100, 230]
    assert [it for it, _ in run_checkpoints(tmp_path, 50)] == [0, 50, 100, 150, 230]


CRITERIA = {"fall_rate": 0.05, "height_error_m_by_height_m": 0.05}


def bands(*errors):
    return {"height_error_m_by_height_m": [{"command": [0.2 * i, 0.2 * (i + 1)], "error": e, "steps": 10}
                                           for i, e in enumerate(errors)]}


@pytest.mark.parametrize("metrics, margin", [
    ({"fall_rate": 0.01, "error_by_command": bands(0.02, 0.04)}, 0.8),
    ({"fall_rate": 0.01, "error_by_command": bands(0.02, 0.075)}, 1.5),  # the worst band decides
    ({"fall_rate": 0.1, "error_by_command": bands(0.02, 0.04)}, 2.0),
    ({"error_by_command": bands(0.02)}, math.inf),  # a criterion not measured
    ({"fall_rate": float("nan"), "error_by_command": bands(0.02)}, math.inf),
])
def test_the_worst_margin_agrees_with_the_criteria(metrics, margin):
    assert worst_margin(metrics, CRITERIA) == pytest.approx(margin)
    assert (worst_margin(metrics, CRITERIA) <= 1.0) == (not missed_criteria(metrics, CRITERIA))
    assert worst_margin({"success_rate": 0.5}, {}, {"success_rate": 0.8}) == pytest.approx(1.6)


def test_the_best_checkpoint_of_a_run_whose_last_one_is_worse(tmp_path, capsys):
    trained = torch.load(pretrained_policy("Velocity-T1-v0"), map_location="cpu", weights_only=True)
    run = tmp_path / "run"
    run.mkdir()
    torch.save(trained, run / "model_100.pt")
    broken = {**trained, "actor_state_dict": {k: torch.zeros_like(v) if k.startswith("mlp.") else v
                                              for k, v in trained["actor_state_dict"].items()}}
    torch.save(broken, run / "model_200.pt")  # the newest: a policy that holds the default pose
    out = tmp_path / "picked.json"
    main(["--task", "Velocity-T1-v0", "--run", str(run), "--every", "100", "--device", "cpu", "--num_envs", "4",
          "--episode_length_s", "2", "--out", str(out)])
    result = json.loads(out.read_text())
    assert [row["iteration"] for row in result["rows"]] == [100, 200] and result["best"] == 100
    first, last = result["rows"]
    assert first["score"] < last["score"] and set(first) >= {"fall_rate", "lin_vel_error_mps", "missed", "met"}
    # 4 envs x 2 s on the CPU rank the checkpoints; whether one passes is for the task's own setting on a GPU
    assert result["criteria_judged"] is False and first["met"] is None
    out = capsys.readouterr().out
    assert "best: iteration 100" in out and "not judged" in out


@pytest.mark.parametrize("argv, message", [
    (["--task", "Velocity-T1-v0", "--run", "/no/such/run"], "no such folder"),
    (["--task", "Velocity-T1-v0", "--run", "{empty}"], "no model_<iteration>.pt"),
    (["--task", "Velocity-T1-v0", "--run", "{empty}", "--every", "0"], "--every must be >= 1"),
    (["--task", "Velocity-T9-v0", "--run", "{one}"], "unknown task 'Velocity-T9-v0'"),
    (["--task", "Debug-T1-v0", "--run", "{one}"], "no evaluation criteria"),
])
def test_a_bad_run_or_task_is_named(tmp_path, capsys, argv, message):
    (tmp_path / "empty").mkdir()
    (tmp_path / "one").mkdir()
    (tmp_path / "one" / "model_0.pt").write_bytes(b"")
    argv = [a.format(empty=tmp_path / "empty", one=tmp_path / "one") for a in argv]
    with pytest.raises(SystemExit):
        main(argv)
    assert message in capsys.readouterr().err
