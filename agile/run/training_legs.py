"""The training of one `agile time_to_policy` run as legs of batch shapes: `--batch_schedule 1000:1024x96` trains
as given to iteration 1,000, then goes on from that checkpoint with 1,024 envs x 96 steps per iteration (a leg is
one `agile train` process; the next resumes the newest checkpoint of the one before, whose terrain levels are spread
over the new env count by terrain column). Fewer envs with longer rollouts keep the samples per iteration and let
each env live faster, which paces the terrain curriculum's climb (docs/time_to_policy.md). Without a schedule the
run is one leg: the one process it always was."""

from __future__ import annotations

import dataclasses
import os
import re
import signal
import subprocess
import time
from pathlib import Path

from agile.errors import AgileError
from agile.run.time_to_policy_judge import newest_checkpoint

SCHEDULE_ITEM = re.compile(r"^(\d+):(\d+)x(\d+)$")
SCHEDULE_FORM = "ITERATION:ENVSxSTEPS, e.g. 1000:1024x96 (after iteration 1,000: 1,024 envs x 96 steps per env)"


@dataclasses.dataclass(frozen=True)
class Leg:
    """One training process of a run: the iterations after `after_iteration` (-1: from scratch), `iterations` of
    them, with `num_envs` (None: the run's) and `num_steps_per_env` (None: the run's overrides')."""
    after_iteration: int
    iterations: int
    num_envs: int | None
    num_steps_per_env: int | None


def parse_batch_schedule(items: list[str]) -> tuple[tuple[int, int, int], ...]:
    """(after_iteration, num_envs, num_steps_per_env) of the command line's ITERATION:ENVSxSTEPS items."""
    parsed = []
    for item in items:
        match = SCHEDULE_ITEM.match(item)
        if match is None:
            raise AgileError(f"--batch_schedule takes {SCHEDULE_FORM}; got '{item}'")
        parsed.append(tuple(int(group) for group in match.groups()))
    return tuple(parsed)


def check_batch_schedule(schedule) -> tuple[tuple[int, int, int], ...]:
    """The schedule as a tuple of (after_iteration, num_envs, num_steps_per_env), after iterations rising, envs and
    steps positive; AgileError naming batch_schedule otherwise."""
    checked = []
    for entry in schedule:
        if (len(entry) != 3 or not all(isinstance(value, int) for value in entry) or entry[0] < 0
                or entry[1] < 1 or entry[2] < 1):
            raise AgileError(f"batch_schedule: each entry is (after_iteration >= 0, num_envs >= 1, "
                             f"num_steps_per_env >= 1), got {entry!r}")
        if checked and entry[0] <= checked[-1][0]:
            raise AgileError(f"batch_schedule: the iterations must rise, got {entry[0]} after {checked[-1][0]}")
        checked.append(tuple(entry))
    return tuple(checked)


def plan_legs(schedule, *, num_envs: int | None, max_iterations: int, resumed_iteration: int | None) -> list[Leg]:
    """The legs of a run of `max_iterations` iterations from scratch (`resumed_iteration` None) or after a
    checkpoint's iteration: the shape in force there first, then each later one of the schedule."""
    shapes = [(-1, num_envs, None), *schedule]
    done = -1 if resumed_iteration is None else resumed_iteration
    first = max(k for k, shape in enumerate(shapes) if shape[0] <= done)
    legs, left = [], max_iterations
    for k in range(first, len(shapes)):
        _, envs, steps = shapes[k]
        iterations = left if k + 1 == len(shapes) else min(left, shapes[k + 1][0] - done)
        if iterations < 1:
            break
        legs.append(Leg(after_iteration=done, iterations=iterations, num_envs=envs, num_steps_per_env=steps))
        done, left = done + iterations, left - iterations
    return legs


def leg_arguments(options, leg: Leg, resume: str | None) -> dict:
    """The fields of the run's options that differ for `leg` (what `training_command` reads)."""
    overrides = tuple(options.overrides)
    if leg.num_steps_per_env is not None:
        overrides += (f"agent.num_steps_per_env={leg.num_steps_per_env}",)  # after the run's: it wins
    return {"num_envs": leg.num_envs if leg.num_envs is not None else options.num_envs,
            "max_iterations": leg.iterations, "resume": resume, "overrides": overrides}


class TrainingLegs:
    """The run's training, leg after leg, each its own process, seen as one process (`poll`, `stop`): `poll` starts
    the next leg when one ends well and returns None until the last has ended (its exit code), or one failed."""

    def __init__(self, options, legs: list[Leg], command_of, log_root: str, log_path: Path, start: float):
        """`command_of(leg_options)`: the process of a leg; `start` (time.monotonic()): the run's start."""
        self.options, self.legs, self.command_of = options, legs, command_of
        self.log_root, self.log_path, self.start = log_root, log_path, start
        self.records: list[dict] = []
        """Each leg started: its shape, the checkpoint it resumed and when it started [s from the run's start]."""
        self.process = None
        self.exit_code: int | None = None
        """How the training ended by itself: 0 after its last leg, a failed leg's code; None while it runs or when
        `stop` ended it."""
        self.start_leg(options.resume)

    def start_leg(self, resume: str | None) -> None:
        leg = self.legs[len(self.records)]
        leg_options = dataclasses.replace(self.options, **leg_arguments(self.options, leg, resume))
        self.records.append({"after_iteration": leg.after_iteration, "iterations": leg.iterations,
                             "num_envs": leg_options.num_envs, "num_steps_per_env": leg.num_steps_per_env,
                             "resumed_from": resume, "started_s": round(time.monotonic() - self.start, 1)})
        with open(self.log_path, "w" if len(self.records) == 1 else "a") as log:
            if len(self.records) > 1:
                log.write(f"[agile] leg {len(self.records)} of {len(self.legs)}: after iteration "
                          f"{leg.after_iteration}, {leg_options.num_envs} envs, resuming {resume}\n")
                log.flush()
            self.process = subprocess.Popen(self.command_of(leg_options), stdout=log, stderr=subprocess.STDOUT,
                                            start_new_session=True)

    def poll(self) -> int | None:
        code = self.process.poll()
        if code is None:
            return None
        newest = newest_checkpoint(self.log_root)
        if code != 0 or len(self.records) == len(self.legs) or newest is None:  # none: nothing to go on from
            self.exit_code = code
            return code
        self.start_leg(str(newest[1]))
        return None

    def stop(self) -> None:
        """End the running leg (its process group: torchrun's ranks too); no later leg starts."""
        self.legs = self.legs[:len(self.records)]
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            self.process.wait(timeout=60)

