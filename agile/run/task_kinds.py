"""What a task's kind changes in the commands, in one place: each command asks `task_runtime(task)` for the function
that runs it, chosen by the kind in the task's spec (`agile.tasks.registration.TaskSpec.kind`). A multi-agent task
(several robots at their own rates in one world) trains, evaluates, plays, exports and benchmarks its own way; every
other kind as a single-agent task (a distilled task differs in its agent config, which the runner reads; a startup
dataset is the spec's `startup_dataset`, which the env build consults)."""

from __future__ import annotations

import dataclasses

COMMANDS = ("train", "eval", "play", "export", "benchmark")


@dataclasses.dataclass(frozen=True)
class TaskRuntime:
    """The function ("module:function", imported when used) each command runs for the tasks of a kind: train takes
    the run's `TrainOptions` and its rank (None: not distributed) and returns a `TrainResult`; the others take the
    command's options and return what they measured or wrote: eval an `agile.run.eval.EvalOptions` (the metrics, or a
    sweep's result), play a `agile.run.play.PlayOptions` (what was played), export an
    `agile.run.export.ExportOptions` ({kind or group: path}), benchmark an `agile.run.benchmark.BenchmarkOptions`
    (a row per env count)."""
    train: str
    eval: str
    play: str
    export: str
    benchmark: str

    def function(self, command: str):
        from agile.utils.config import load_entry_point

        return load_entry_point(getattr(self, command))


SINGLE_AGENT = TaskRuntime(train="agile.run.train:train_single_agent", eval="agile.run.eval:eval_single_agent",
                           play="agile.run.play:play_single_agent", export="agile.run.export:export_single_agent",
                           benchmark="agile.run.benchmark:benchmark_single_agent")
MULTI_AGENT = TaskRuntime(train="agile.run.multi_agent:train_multi_agent",
                          eval="agile.run.multi_agent:eval_multi_agent",
                          play="agile.run.multi_agent:play_multi_agent",
                          export="agile.run.multi_agent:export_multi_agent",
                          benchmark="agile.run.multi_agent_benchmark:benchmark_multi_agent")
RUNTIMES = {"multi_agent": MULTI_AGENT}
"""The kinds that run otherwise than a single-agent task."""


def task_runtime(task: str) -> TaskRuntime:
    """The runtime of the task's kind (an unknown task: `agile.tasks.UnknownTaskError`)."""
    import agile.tasks

    return RUNTIMES.get(agile.tasks.task_kind(task), SINGLE_AGENT)


def run_command(command: str, task: str, *args):
    """Run `command` for `task` the way its kind runs it."""
    return task_runtime(task).function(command)(*args)
