"""agile time_to_policy --target shippable: a checkpoint judged against the task's ship bar (the training's mean
terrain level, then the falls on the start rows, then the falls over every row, each step only where the one before
passed), and a run resumed from a checkpoint counting its recorded wall time in (a whole run resumed:
test_time_to_policy.py's seeds test)."""

from __future__ import annotations

import re

import pytest
import torch

from agile.errors import AgileError
from agile.run.time_to_policy import time_to_policy, time_to_policy_options
from agile.run.time_to_policy_judge import (ALL_ROWS_OVERRIDE, CLIMB_CHECKPOINTS, CheckpointJudge, climb,
                                            climb_in_words, criteria_of)
from agile.tasks.registration import TaskSpec, TaskSpecError

TASK = "Velocity-T1-v0"


def checkpoint_at_level(path, level: float, wall_s: float | None = 12.5):
    """A checkpoint file holding what the judge reads before any evaluation: the env's terrain levels."""
    infos = {"env_state": {"terrain_levels": torch.full((8,), level)}}
    if wall_s is not None:
        infos["wall_s"] = wall_s
    torch.save({"iter": 0, "infos": infos}, path)
    return path


class RecordingJudge(CheckpointJudge):
    """The judge with its evaluations given, not run: (name, overrides) of each asked for, in order."""

    def __init__(self, results: dict, **kwargs):
        options, _ = time_to_policy_options(task=TASK, budget_s=5.0, device="cpu", target="shippable")
        criteria, minima = criteria_of(TASK, "shippable", None)
        super().__init__(options, criteria, minima, "cpu", start_epoch=0.0, **kwargs)
        self.results, self.asked = results, []

    def evaluate(self, name, path, overrides=()):
        self.asked.append((name, tuple(overrides)))
        return dict(self.results[name])


PASSING = {"fall_rate": 0.01, "lin_vel_error_mps": 0.1, "ang_vel_error_radps": 0.1, "episodes": 512}


def test_the_ship_bar_adds_to_the_tasks_criteria():
    maxima, minima = criteria_of(TASK, "shippable", None)
    assert maxima == {"fall_rate": 0.03, "lin_vel_error_mps": 0.25, "ang_vel_error_radps": 0.3,
                      "all_rows_fall_rate": 0.10}
    assert minima == {"mean_terrain_level": 10.0}
    assert criteria_of(TASK, "criteria", None)[0]["fall_rate"] == 0.05  # the task's own criteria unchanged


def test_below_the_terrain_level_nothing_is_evaluated(tmp_path):
    judge = RecordingJudge({})
    row = judge(300, checkpoint_at_level(tmp_path / "model_300.pt", 4.0))
    assert judge.asked == [] and not row["met"] and row["mean_terrain_level"] == 4.0
    assert row["missed"] == ["mean_terrain_level 4 < 10"]


def test_the_start_rows_first_then_every_row(tmp_path):
    path = checkpoint_at_level(tmp_path / "model_900.pt", 11.0)
    falling = RecordingJudge({"start rows": {**PASSING, "fall_rate": 0.04}})
    row = falling(900, path)
    assert falling.asked == [("start rows", ())] and not row["met"]  # 4% > the bar's 3%: no all-rows evaluation
    assert row["missed"] == ["fall_rate 0.04 > 0.03"]
    judge = RecordingJudge({"start rows": PASSING, "all rows": {**PASSING, "fall_rate": 0.12}})
    row = judge(900, path)
    assert judge.asked == [("start rows", ()), ("all rows", (ALL_ROWS_OVERRIDE,))]
    assert row["missed"] == ["all_rows_fall_rate 0.12 > 0.1"] and row["all_rows_fall_rate"] == 0.12
    shippable = RecordingJudge({"start rows": PASSING, "all rows": {**PASSING, "fall_rate": 0.08}})
    assert shippable(900, path)["met"]


def test_a_resumed_runs_checkpoints_count_the_wall_time_before(tmp_path):
    path = checkpoint_at_level(tmp_path / "model_10.pt", 1.0)
    judge = RecordingJudge({}, wall_s_before=1000.0)
    assert judge(10, path)["wall_s"] == round(1000.0 + path.stat().st_mtime, 1)  # start_epoch 0


@pytest.mark.parametrize("changes, message", [
    ({"target": "best"}, "target must be one of criteria, shippable, got 'best'"),
    ({"target": "shippable", "criteria": {"fall_rate": 0.5}}, "criteria and target shippable: give one"),
    ({"target": "shippable", "task": "Velocity-Go1-v0"},
     "target shippable: Velocity-Go1-v0 has no ship bar (ship_bar in its registration); tasks with one: "
     "Velocity-G1-History-v0, Velocity-T1-v0"),
    ({"resume": "missing.pt"}, "resume: no checkpoint file missing.pt"),
    ({"resume": "model.pt", "seeds": [0, 1]}, "resume and seeds: a resumed run continues one training"),
])
def test_refused_before_anything_runs(tmp_path, monkeypatch, changes, message):
    monkeypatch.chdir(tmp_path)
    checkpoint_at_level(tmp_path / "model.pt", 1.0)
    with pytest.raises(AgileError, match=re.escape(message)):
        time_to_policy(**{"task": TASK, "budget_s": 5.0, "out": str(tmp_path / "out" / "run"), "device": "cpu",
                          **changes})
    assert not (tmp_path / "out").exists()


def test_a_checkpoint_without_its_wall_time_cannot_be_continued(tmp_path):
    old = checkpoint_at_level(tmp_path / "old.pt", 1.0, wall_s=None)
    with pytest.raises(AgileError, match=re.escape(f"resume: {old} records no training wall time")):
        time_to_policy_options(task=TASK, budget_s=5.0, device="cpu", resume=str(old))


def test_a_kept_log_root_must_be_new(tmp_path):
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "old.txt").write_text("x")
    with pytest.raises(AgileError, match="log_root: .* is not an empty folder; give a new one"):
        time_to_policy(task=TASK, budget_s=5.0, out=str(tmp_path / "run"), device="cpu",
                       log_root=str(tmp_path / "runs"))


def test_a_ship_bar_names_its_fields():
    with pytest.raises(TaskSpecError, match="ship_bar holds a number for each of mean_terrain_level, fall_rate, "
                                            "all_rows_fall_rate"):
        TaskSpec(task="X-v0", env_cfg_entry_point="m:a", runner_cfg_entry_point="m:b", ship_bar={"fall_rate": 0.1})


def test_the_climbs_pace_and_when_it_would_reach_the_bar():
    """The pace over the newest checkpoints only (the flat start at row 0 left out once enough come after it), and
    the bar's time at that pace; none where the training does not climb or too few checkpoints hold a level."""
    flat = [{"wall_s": 10.0 * i, "mean_terrain_level": 0.0} for i in range(5)]
    climbing = [{"wall_s": 100.0 + 16.0 * i, "mean_terrain_level": 3.0 + 0.1 * i} for i in range(CLIMB_CHECKPOINTS)]
    pace = climb(flat + climbing, 10.0)
    assert pace["rows_per_100s"] == pytest.approx(0.625) and pace["from_wall_s"] == 100.0
    last_s, last_level = climbing[-1]["wall_s"], climbing[-1]["mean_terrain_level"]
    assert pace["bar_at_wall_s"] == pytest.approx(last_s + (10.0 - last_level) / 0.00625, abs=0.1)
    assert "at this pace level 10 at about" in climb_in_words(pace, 10.0)
    assert "bar_at_wall_s" not in climb(climbing, 3.5)  # past the bar already
    assert "bar_at_wall_s" not in climb(flat, 10.0) and climb(flat, 10.0)["rows_per_100s"] == 0.0
    evaluated_only = [{"wall_s": 1.0, "fall_rate": 0.1}, {"wall_s": 2.0, "mean_terrain_level": 1.0}]
    assert climb(evaluated_only, 10.0) is None and climb([], 10.0) is None


def test_while_training_each_new_checkpoints_level_and_the_climb_so_far_are_kept(tmp_path, capsys):
    """Before anything is judged (--evaluate_after_training), each new checkpoint's level is noted as it comes, so
    that the record of a run cut off says how fast it climbed; a file not yet whole is skipped."""
    import os

    judge = RecordingJudge({})
    for i, level in enumerate((3.0, 3.1, 3.2)):
        path = checkpoint_at_level(tmp_path / f"model_{i * 50}.pt", level)
        os.utime(path, (100.0 + 16.0 * i, 100.0 + 16.0 * i))  # written 16 s apart
        judge.note_level(i * 50, path)
    cut_short = tmp_path / "model_150.pt"
    cut_short.write_bytes(path.read_bytes()[:100])
    judge.note_level(150, cut_short)
    assert [row["iteration"] for row in judge.levels] == [0, 50, 100] and judge.rows == []
    assert [row["wall_s"] for row in judge.levels] == [100.0, 116.0, 132.0]  # start_epoch 0
    pace = climb(judge.levels, 10.0)
    assert pace["rows_per_100s"] == pytest.approx(0.625) and pace["bar_at_wall_s"] == pytest.approx(132.0 + 6.8 / 0.00625)
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].endswith("iteration 0: mean terrain level 3.000")
    assert printed[-1].endswith("(0.625 rows per 100 s over the checkpoints from 100 s: at this pace level 10 at "
                                "about 1220 s of training)")


def test_a_level_noted_while_training_is_not_read_again_when_judged(tmp_path):
    """After the training, each checkpoint noted while it ran is judged by the level it had then, its file not
    loaded again; one not noted is read."""
    judge = RecordingJudge({"start rows": PASSING, "all rows": {"fall_rate": 0.05}})
    noted = checkpoint_at_level(tmp_path / "model_50.pt", 3.0)
    judge.note_level(50, noted)
    noted.write_bytes(b"not a checkpoint")  # loading it now would raise
    assert judge(50, noted)["mean_terrain_level"] == 3.0 and judge.asked == []
    not_noted = checkpoint_at_level(tmp_path / "model_100.pt", 10.5)
    row = judge(100, not_noted)
    assert row["mean_terrain_level"] == 10.5 and row["met"]
    assert [name for name, _ in judge.asked] == ["start rows", "all rows"]
