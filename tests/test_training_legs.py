"""agile time_to_policy --batch_schedule: the training in legs of batch shapes, each leg a process resuming the newest
checkpoint of the one before, timed as one run."""

import json
from pathlib import Path

import pytest

from commands import FLAT_GROUND_ARGS, run_command

from agile.errors import AgileError
from agile.run.time_to_policy import main
from agile.run.time_to_policy_run import TimeToPolicyOptions
from agile.run.training_legs import Leg, check_batch_schedule, leg_arguments, parse_batch_schedule, plan_legs


def test_from_scratch_the_first_leg_ends_at_the_switch_and_the_last_takes_the_rest():
    legs = plan_legs(((1000, 1024, 96),), num_envs=4096, max_iterations=100_000, resumed_iteration=None)
    # iterations 0-1,000 as given (model_1000.pt its last checkpoint), then 1,001 on with 1,024 x 96
    assert legs == [Leg(after_iteration=-1, iterations=1001, num_envs=4096, num_steps_per_env=None),
                    Leg(after_iteration=1000, iterations=100_000 - 1001, num_envs=1024, num_steps_per_env=96)]


def test_a_resumed_run_starts_with_the_shape_in_force_at_its_checkpoint():
    schedule = ((1000, 1024, 96), (3000, 512, 192))
    before = plan_legs(schedule, num_envs=None, max_iterations=5000, resumed_iteration=500)
    assert [(leg.after_iteration, leg.iterations, leg.num_envs) for leg in before] == \
        [(500, 500, None), (1000, 2000, 1024), (3000, 2500, 512)]
    at_switch = plan_legs(schedule, num_envs=None, max_iterations=5000, resumed_iteration=1000)
    assert [(leg.after_iteration, leg.iterations, leg.num_envs) for leg in at_switch] == \
        [(1000, 2000, 1024), (3000, 3000, 512)]
    after_all = plan_legs(schedule, num_envs=None, max_iterations=300, resumed_iteration=2300)
    assert after_all == [Leg(after_iteration=2300, iterations=300, num_envs=1024, num_steps_per_env=96)]


def test_legs_past_the_runs_iterations_are_not_started():
    legs = plan_legs(((1000, 1024, 96),), num_envs=None, max_iterations=600, resumed_iteration=None)
    assert legs == [Leg(after_iteration=-1, iterations=600, num_envs=None, num_steps_per_env=None)]
    assert plan_legs((), num_envs=8, max_iterations=7, resumed_iteration=None) == \
        [Leg(after_iteration=-1, iterations=7, num_envs=8, num_steps_per_env=None)]


def test_a_legs_steps_come_after_the_runs_overrides():
    class Options:
        overrides = ("agent.algorithm.desired_kl=0.02", "agent.num_steps_per_env=24")
        num_envs = 4096

    later = leg_arguments(Options, Leg(after_iteration=1000, iterations=5, num_envs=1024, num_steps_per_env=96),
                          resume="run/model_1000.pt")
    assert later == {"num_envs": 1024, "max_iterations": 5, "resume": "run/model_1000.pt",
                     "overrides": (*Options.overrides, "agent.num_steps_per_env=96")}
    first = leg_arguments(Options, Leg(after_iteration=-1, iterations=1001, num_envs=None, num_steps_per_env=None),
                          resume=None)
    assert first["num_envs"] == 4096 and first["overrides"] == Options.overrides


@pytest.mark.parametrize("items, message", [
    (["1000-1024x96"], "--batch_schedule takes ITERATION:ENVSxSTEPS"),
    (["1000:1024"], "got '1000:1024'"),
    (["1000:0x96"], "num_envs >= 1"),
    (["2000:1024x96", "1000:512x192"], "the iterations must rise, got 1000 after 2000"),
])
def test_a_bad_schedule_is_refused_in_one_line(items, message):
    with pytest.raises(AgileError, match=message):
        check_batch_schedule(parse_batch_schedule(items))


def test_the_command_refuses_a_bad_schedule_before_anything_runs(tmp_path):
    code, _, err = run_command("time_to_policy", "--task", "Velocity-T1-v0", "--budget_s", "10", "--device", "cpu",
                               "--out", str(tmp_path / "x"), "--batch_schedule", "1000:1024by96")
    assert code == 2 and not (tmp_path / "x.json").exists()
    assert err.strip().splitlines() == ["error: --batch_schedule takes ITERATION:ENVSxSTEPS, e.g. 1000:1024x96 "
                                        "(after iteration 1,000: 1,024 envs x 96 steps per env); got '1000:1024by96'"]


@pytest.mark.slow
def test_a_run_in_two_legs_goes_on_from_the_switch_with_the_new_shape_timed_as_one(tmp_path, capsys):
    out = tmp_path / "legs"
    code = main(["--task", "Velocity-T1-v0", "--budget_s", "400", "--num_envs", "2", "--device", "cpu",
                 "--max_iterations", "4", "--save_interval", "1", "--eval_num_envs", "2", "--eval_episode_length_s",
                 "0.2", "--evaluate_after_training", "--criterion", "fall_rate=-1", "--batch_schedule", "1:3x3",
                 "--log_root", str(tmp_path / "runs"), "--out", str(out), "agent.num_steps_per_env=2",
                 *FLAT_GROUND_ARGS])
    assert code == 1, capsys.readouterr()  # a fall rate below zero is never met: every checkpoint evaluated
    result = json.loads(out.with_suffix(".json").read_text())
    first, second = result["legs"]
    assert (first["after_iteration"], first["iterations"], first["num_envs"], first["resumed_from"]) == (-1, 2, 2, None)
    assert (second["after_iteration"], second["iterations"], second["num_envs"], second["num_steps_per_env"]) == \
        (1, 2, 3, 3)
    assert second["resumed_from"].endswith("model_1.pt") and second["started_s"] > first["started_s"]
    rows = result["evaluations"]
    assert [row["iteration"] for row in rows] == [0, 1, 2, 3]
    # one clock for the run: the second leg's checkpoints after the first's, after the second leg started
    assert all(a["wall_s"] < b["wall_s"] for a, b in zip(rows, rows[1:])) and rows[2]["wall_s"] > second["started_s"]
    log = out.with_suffix(".log").read_text()
    assert "leg 2 of 2: after iteration 1, 3 envs, resuming" in log
    assert "Total steps: 4" in log and "Total steps: 9" in log  # 2 envs x 2 steps, then 3 envs x 3 steps
    assert result["batch_schedule"] == [[1, 3, 3]]



LEG_OPTIONS = TimeToPolicyOptions(task="Velocity-T1-v0", budget_s=60.0, device="cpu", num_envs=2)
FAKE_LEG = """
import pathlib, sys
iterations, resumed, log_root = int(sys.argv[1]), sys.argv[2], pathlib.Path(sys.argv[3])
# where agile train writes the checkpoint of its last iteration: a new run folder under the log root
run = log_root / "exp" / f"run{len(list(log_root.glob('exp/*')))}"
run.mkdir(parents=True)
last = iterations - 1 if resumed == "None" else int(resumed.rsplit("_", 1)[1][:-3]) + iterations
(run / f"model_{last}.pt").write_text("")
"""


def legs_of(tmp_path, script: str, schedule=((1, 3, 3),)):
    """TrainingLegs of a run whose every leg is a small Python process given its iterations, the checkpoint it
    resumes and the log root."""
    import sys
    import time

    from agile.run.training_legs import TrainingLegs

    def command_of(leg_options):
        return [sys.executable, "-c", script, str(leg_options.max_iterations), str(leg_options.resume), str(tmp_path)]

    planned = plan_legs(schedule, num_envs=2, max_iterations=8, resumed_iteration=None)
    return TrainingLegs(LEG_OPTIONS, planned, command_of, str(tmp_path), tmp_path / "legs.log", time.monotonic())


def wait_for_end(legs, timeout_s: float = 60.0):
    import time

    deadline = time.monotonic() + timeout_s
    while (code := legs.poll()) is None:
        assert time.monotonic() < deadline, "the legs did not end"
        time.sleep(0.05)
    return code


def test_each_leg_after_one_that_ends_well_resumes_its_newest_checkpoint(tmp_path):
    legs = legs_of(tmp_path, FAKE_LEG, schedule=((1, 3, 3), (4, 4, 4)))
    assert wait_for_end(legs) == 0
    assert [(r["after_iteration"], r["iterations"], r["num_envs"]) for r in legs.records] == \
        [(-1, 2, 2), (1, 3, 3), (4, 3, 4)]  # 8 iterations in all: 0-1, 2-4, 5-7
    assert [r["resumed_from"] and Path(r["resumed_from"]).name for r in legs.records] == \
        [None, "model_1.pt", "model_4.pt"]
    assert sorted(p.name for p in tmp_path.glob("exp/*/model_*.pt")) == ["model_1.pt", "model_4.pt", "model_7.pt"]
    assert "leg 3 of 3: after iteration 4, 4 envs" in (tmp_path / "legs.log").read_text()


def test_a_leg_that_fails_ends_the_run_with_its_exit_code(tmp_path):
    legs = legs_of(tmp_path, "raise SystemExit(3)")
    assert wait_for_end(legs) == 3 and len(legs.records) == 1  # no second leg after a failed first


def test_stopping_ends_the_running_leg_and_starts_no_other(tmp_path):
    import time

    legs = legs_of(tmp_path, "import time; time.sleep(60)")
    started = time.monotonic()
    legs.stop()
    assert time.monotonic() - started < 30 and legs.process.poll() is not None
    assert legs.poll() is not None and len(legs.records) == 1
