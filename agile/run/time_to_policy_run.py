"""One timed training of `agile time_to_policy` (agile/run/time_to_policy.py): the child processes that train (one,
or one per leg of a batch schedule: agile/run/training_legs.py), and the judging of their checkpoints as they come or
after them, into the run's result."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from agile.run import train_options
from agile.run.time_to_policy_judge import (CheckpointJudge, all_checkpoints, climb, criteria_of, newest_checkpoint,
                                            recorded_point)
from agile.run.training_legs import TrainingLegs, plan_legs

FIRST_ITERATION_MARK = "Learning iteration"
"""What rsl-rl's log prints for every iteration (the training runs with --progress log)."""
CHECKPOINT_WRITE_WAIT_S = 0.5
"""How long a new checkpoint is left before it is read: rsl-rl writes the file in one torch.save."""


@dataclasses.dataclass(frozen=True)
class TimeToPolicyOptions:
    """One timed run (`time_to_policy`'s keyword arguments, checked, for one seed; see them for each field):
    `device` is resolved, `overrides` hold the recipe's first, then the given ones."""
    task: str
    budget_s: float
    device: str
    seed: int | None = None
    gpus: int = 1
    num_envs: int | None = None
    save_interval: int = 50
    max_iterations: int = 100_000
    eval_num_envs: int | None = None
    eval_device: str | None = None
    eval_episode_length_s: float | None = None
    evaluate_after_training: bool = False
    criteria: dict | None = None
    target: str = "criteria"
    resume: str | None = None
    recipe: str | None = None
    overrides: tuple = ()
    batch_schedule: tuple = ()
    """(after_iteration, num_envs, num_steps_per_env) of each later leg (agile.run.training_legs)."""


def training_command(options: TimeToPolicyOptions, log_root: str) -> list[str]:
    """The child process: `agile train` on one device, or torchrun over `gpus` GPUs."""
    train_args = ["--task", options.task, "--max_iterations", str(options.max_iterations), "--log_root", log_root,
                  "--progress", "log", f"agent.save_interval={options.save_interval}", *options.overrides]
    if options.num_envs is not None:
        train_args += ["--num_envs", str(options.num_envs)]
    if options.seed is not None:
        train_args += ["--seed", str(options.seed)]
    if options.resume is not None:
        train_args += ["--resume", "--checkpoint", options.resume]
    return train_options.training_command(train_args, options.gpus, options.device)


def wait_for_first_iteration(log_path: Path, process, start: float, budget_s: float) -> float | None:
    """Seconds from the start to the training's first logged iteration (None: it ended or the budget ran out)."""
    while time.monotonic() - start < budget_s and process.poll() is None:
        if log_path.exists() and FIRST_ITERATION_MARK in log_path.read_text(errors="replace"):
            return time.monotonic() - start
        time.sleep(0.5)
    return None


def run_until_criteria(options: TimeToPolicyOptions, log_root: str, log_path: Path, report=None) -> dict:
    """Train in child processes, one per leg (their output in `log_path`, their runs under `log_root`), until a
    checkpoint meets the criteria, the budget is spent or the training ends; the run's result (what <out>.json
    holds, less the device and commit).
    `report(result)`, where given, receives the result so far at every new checkpoint ("status" "training") and
    after every evaluation ("evaluating"), so that a run cut off (a machine taken away) leaves a record of it."""
    criteria, minima = criteria_of(options.task, options.target, options.criteria)
    resumed_iteration, wall_s_before = (None, 0.0) if options.resume is None else recorded_point(options.resume)
    legs = plan_legs(options.batch_schedule, num_envs=options.num_envs, max_iterations=options.max_iterations,
                     resumed_iteration=resumed_iteration)
    start, start_epoch = time.monotonic(), time.time()
    process = TrainingLegs(options, legs, lambda leg_options: training_command(leg_options, log_root), log_root,
                           log_path, start)
    first_iteration_s = wait_for_first_iteration(log_path, process, start, options.budget_s)
    judge = CheckpointJudge(options, criteria, minima, options.eval_device or options.device, start_epoch,
                            wall_s_before)

    def result(met_at: dict | None, status: str) -> dict:
        return {"task": options.task, "seed": options.seed, "gpus": options.gpus,
                "num_envs_per_gpu": options.num_envs, "budget_s": options.budget_s,
                "recipe": options.recipe, "overrides": list(options.overrides),  # the recipe's first, then the given
                "evaluated": ("after the training" if options.evaluate_after_training
                              else f"beside it, on {judge.device}"),
                "target": options.target, "criteria": criteria, "minima": minima,
                "resumed_from": options.resume, "wall_s_before": wall_s_before, "status": status,
                "batch_schedule": [list(entry) for entry in options.batch_schedule], "legs": process.records,
                "training_exit_code": process.exit_code,  # None: it ran on until stopped (budget or criteria)
                "first_iteration_s": None if first_iteration_s is None else round(first_iteration_s, 1),
                "time_to_policy_s": met_at["wall_s"] if met_at else None,
                "iteration_at_criteria": met_at["iteration"] if met_at else None,
                "climb": (climb(judge.rows or judge.levels, minima["mean_terrain_level"])
                          if "mean_terrain_level" in minima else None),
                "evaluations": judge.rows}

    def progress(status: str) -> None:
        if report is not None:
            report(result(None, status))

    met_at = None
    try:
        if options.evaluate_after_training:
            reported = None
            while time.monotonic() - start < options.budget_s and process.poll() is None:
                newest = newest_checkpoint(log_root)
                if newest is not None and newest[0] != reported:
                    reported = newest[0]
                    if "mean_terrain_level" in minima:
                        time.sleep(CHECKPOINT_WRITE_WAIT_S)
                        judge.note_level(*newest)
                    progress("training")
                time.sleep(1.0)
        else:
            met_at = judge_as_they_come(options, judge, process, start, log_root, progress)
    finally:
        process.stop()
    if options.evaluate_after_training:
        for iteration, path in all_checkpoints(log_root):
            row = judge(iteration, path)
            progress("evaluating")
            if row["met"]:
                met_at = row
                break
    return result(met_at, "finished")


def judge_as_they_come(options: TimeToPolicyOptions, judge: CheckpointJudge, process, start: float,
                       log_root: str, progress) -> dict | None:
    """Evaluate the newest checkpoint whenever a new one appears (`progress("training")` after each that misses);
    the row of the first that meets the criteria."""
    evaluated = -1
    while time.monotonic() - start < options.budget_s:
        newest = newest_checkpoint(log_root)
        if newest is None or newest[0] == evaluated:
            if process.poll() is not None:
                return None  # the training ended and every checkpoint is evaluated
            time.sleep(1.0)
            continue
        iteration, path = newest
        time.sleep(CHECKPOINT_WRITE_WAIT_S)
        evaluated = iteration
        if judge(iteration, path)["met"]:
            return judge.rows[-1]
        progress("training")
    return None
