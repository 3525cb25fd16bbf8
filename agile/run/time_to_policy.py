"""Time to policy: train a task from scratch for a wall-clock budget and report when its policy first meets the
task's criteria (agile/tasks/catalogue.py), with the curve of its evaluations against wall time.

    agile time_to_policy --task Velocity-G1-History-v0 --budget_s 600 --out g1_h100
    agile time_to_policy --task Velocity-T1-v0 --budget_s 300 --gpus 4 --out t1_4gpu    # torchrun, ranks on GPUs 0-3
    agile time_to_policy --task Velocity-T1-v0 --target shippable --budget_s 1500 --evaluate_after_training \\
        --log_root t1_runs --out t1_ship                                          # its ship bar; the run kept
    agile time_to_policy --task Velocity-T1-v0 --target shippable --budget_s 1500 --evaluate_after_training \\
        --resume t1_runs/<experiment>/<run>/model_4000.pt --out t1_ship_2        # on from there, its time counted in
    agile time_to_policy --task Velocity-T1-v0 --target shippable --budget_s 1800 --evaluate_after_training \\
        --batch_schedule 1000:1024x96 --out t1_ship_legs   # after iteration 1,000: 1,024 envs x 96 steps

The training runs as a child process (`agile train`, or torchrun over --gpus GPUs with --distributed) and saves a
checkpoint every --save_interval iterations; this process evaluates the newest checkpoint on the training's first
GPU whenever a new one appears (the task's eval setting: the catalogue's env count and episode length, the
registered start rows, pushes off), and stops the run once one meets every criterion or the budget is spent. Wall
times count from the training's start; the time to the first iteration (the env build, kernel compilation
included) is reported apart. Writes <out>.json and, with matplotlib, <out>.png.

Evaluating beside the training on its GPU slows it (two processes take turns on one GPU: 0.73 s per iteration
against 0.52 s alone, G1 on an H100). `--eval_device cuda:N` evaluates on another GPU of the host;
`--evaluate_after_training` trains for the whole budget undisturbed, then evaluates the checkpoints in order: the
time to policy is then when the first one that meets the criteria was written, as a training without evaluations
would have reached it. `--target shippable` judges by the task's ship bar instead (`ship_bar` of its registration:
the training's mean terrain level, read from the checkpoint, then the falls on the start rows, then over every row);
a training that outlasts one budget continues with `--resume` from the newest checkpoint of a run kept with
`--log_root`, its wall time counted on from the time the checkpoint records (the result's "climb": how fast the
terrain level rose over the newest checkpoints, and when it would reach the bar at that pace). From Python:
`time_to_policy(task=..., budget_s=..., out=..., ...)` returns what <out>.json holds.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import statistics
import sys
import tempfile
from pathlib import Path

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError
from agile.run.time_to_policy_judge import (TARGETS, check_target, climb_in_words, newest_checkpoint,
                                            recorded_wall_s)
from agile.run.time_to_policy_run import TimeToPolicyOptions, run_until_criteria
from agile.run.time_to_policy_plots import outcome, plot, seed_name
from agile.run.training_legs import SCHEDULE_FORM, check_batch_schedule, parse_batch_schedule


def seed_summary(results: list[dict]) -> dict:
    """Over one run per seed: each seed's time to policy, the median and the worst, a run that missed its criteria
    counted as its budget (and named in `missed_seeds`)."""
    times = [r["time_to_policy_s"] if r["time_to_policy_s"] is not None else r["budget_s"] for r in results]
    return {"seeds": [r["seed"] for r in results], "time_to_policy_s": [r["time_to_policy_s"] for r in results],
            "median_s": statistics.median(times), "worst_s": max(times),
            "missed_seeds": [r["seed"] for r in results if r["time_to_policy_s"] is None],
            "met": sum(r["time_to_policy_s"] is not None for r in results)}


def check_count(value, field: str, minimum: int = 1) -> None:
    if value is not None and value < minimum:
        raise AgileError(f"{field} must be at least {minimum}, got {value}")


def time_to_policy_options(*, task: str, budget_s: float, seed: int | None = None, seeds=None, gpus: int = 1,
                           num_envs: int | None = None, device: str | None = None, save_interval: int = 50,
                           max_iterations: int = 100_000, eval_num_envs: int | None = None,
                           eval_device: str | None = None, eval_episode_length_s: float | None = None,
                           evaluate_after_training: bool = False, criteria: dict | None = None,
                           target: str = "criteria", resume: str | None = None, recipe: str | None = None,
                           overrides=(), batch_schedule=()) -> tuple[TimeToPolicyOptions, list]:
    """The checked options of `time_to_policy` (see it) and the seeds to run, one after another (`[seed]` without
    `seeds`); raises AgileError naming the field for what it refuses, before anything runs."""
    from agile.run.recipes import RECIPES

    task_setup.check_task(task)
    if not budget_s > 0:
        raise AgileError(f"budget_s must be positive, got {budget_s}")
    for value, field in ((gpus, "gpus"), (save_interval, "save_interval"), (max_iterations, "max_iterations"),
                         (num_envs, "num_envs"), (eval_num_envs, "eval_num_envs")):
        check_count(value, field)
    if eval_episode_length_s is not None and not eval_episode_length_s > 0:
        raise AgileError(f"eval_episode_length_s must be positive (or None: the task's), got {eval_episode_length_s}")
    if seed is not None and seeds is not None:
        raise AgileError("seed and seeds: give one (seeds: one run per seed)")
    if seeds is not None and len(seeds) == 0:
        raise AgileError("seeds must name at least one seed (or be None: one run)")
    if recipe is not None and recipe not in RECIPES:
        raise AgileError(f"recipe must be one of {', '.join(sorted(RECIPES))} (or None), got {recipe!r}")
    for name, maximum in (criteria or {}).items():
        if not isinstance(maximum, (int, float)):
            raise AgileError(f"criteria: {{metric: maximum}}, a number each; {name} is {maximum!r}")
    check_target(task, target, criteria)
    task_setup.check_overrides(task=task, overrides=(*RECIPES.get(recipe, ()), *overrides))
    if resume is not None:
        if seeds is not None:
            raise AgileError("resume and seeds: a resumed run continues one training (give its seed)")
        if not Path(resume).is_file():
            raise AgileError(f"resume: no checkpoint file {resume}")
        recorded_wall_s(resume)
    # torchrun's ranks take the host's first GPUs, or CPU processes
    device, _ = task_setup.resolve_device(device if gpus == 1 or device == "cpu" else "cuda:0")
    if eval_device is not None:
        eval_device, _ = task_setup.resolve_device(eval_device)
    options = TimeToPolicyOptions(
        task=task, budget_s=budget_s, device=device, seed=seed, gpus=gpus, num_envs=num_envs,
        save_interval=save_interval, max_iterations=max_iterations, eval_num_envs=eval_num_envs,
        eval_device=eval_device, eval_episode_length_s=eval_episode_length_s,
        evaluate_after_training=evaluate_after_training, criteria=dict(criteria) if criteria else None,
        target=target, resume=resume, recipe=recipe, overrides=(*RECIPES.get(recipe, ()), *overrides),
        batch_schedule=check_batch_schedule(batch_schedule))
    return options, list(seeds) if seeds is not None else [seed]


def time_to_policy(*, task: str, budget_s: float, out: str, seed: int | None = None, seeds=None, gpus: int = 1,
                   num_envs: int | None = None, device: str | None = None, save_interval: int = 50,
                   max_iterations: int = 100_000, eval_num_envs: int | None = None, eval_device: str | None = None,
                   eval_episode_length_s: float | None = None, evaluate_after_training: bool = False,
                   criteria: dict | None = None, target: str = "criteria", resume: str | None = None,
                   log_root: str | None = None, recipe: str | None = None, overrides=(), batch_schedule=()) -> dict:
    """Train `task` from scratch for `budget_s` seconds of wall time (a child process: `agile train`, or torchrun over
    `gpus` GPUs of this host, or CPU ranks with `device` "cpu"; `num_envs` per GPU, a checkpoint every `save_interval`
    iterations) and evaluate its checkpoints against `criteria` ({metric: maximum}; None: the task's, from
    agile/tasks/catalogue.py) until one meets them: the newest whenever one appears (on `eval_device`, default the
    training's), or, with `evaluate_after_training`, in order once the budget is spent. `eval_num_envs`,
    `eval_episode_length_s`: the evaluation setting (default: the task's). `recipe` (agile.run.recipes): its
    overrides before `overrides`. `seeds`: one run per seed, one after another, instead of one with `seed`.
    `target` "shippable": the task's ship bar instead (its registration's `ship_bar`: the training's mean terrain level,
    the falls on the start rows and over every row). `resume`: a checkpoint to continue (its recorded wall time counted
    in). `batch_schedule`: ((after_iteration, num_envs, num_steps_per_env), ...), the training going on from the
    checkpoint of each such iteration with that batch shape, a process per leg (agile.run.training_legs; the legs in
    the result). `log_root`: a new folder that keeps the training's run (its checkpoints, to resume from;
    <log_root>/seed<N> with `seeds`); default a temporary one, deleted at the end.

    Writes <out>.json (the result), <out>.log (the training's output) and, with matplotlib, <out>.png (the curve);
    with `seeds`, <out>_seed<N>.json and .log per run and the summary over them in <out>.json. Returns what <out>.json
    holds: the run's result ("time_to_policy_s" None where the criteria were not met), or the summary. Raises
    AgileError naming the field for what it refuses, before anything runs."""
    from agile.run.eval_all import source_commit

    options, seed_list = time_to_policy_options(
        task=task, budget_s=budget_s, seed=seed, seeds=seeds, gpus=gpus, num_envs=num_envs, device=device,
        save_interval=save_interval, max_iterations=max_iterations, eval_num_envs=eval_num_envs,
        eval_device=eval_device, eval_episode_length_s=eval_episode_length_s,
        evaluate_after_training=evaluate_after_training, criteria=criteria, target=target, resume=resume,
        recipe=recipe, overrides=overrides, batch_schedule=batch_schedule)
    if log_root is not None and Path(log_root).exists() and (not Path(log_root).is_dir()
                                                             or any(Path(log_root).iterdir())):
        raise AgileError(f"log_root: {log_root} is not an empty folder; give a new one (the run's checkpoints go "
                         f"there)")
    task_setup.check_writable(f"{out}.json", "out")
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    commit = source_commit()
    results = []
    for run_seed in seed_list:
        run_options = dataclasses.replace(options, seed=run_seed)
        run_out = out if seeds is None else f"{out}_seed{run_seed}"
        with kept_or_temporary(log_root, None if seeds is None else f"seed{run_seed}") as run_root:
            def write(result: dict, run_root=run_root, run_out=run_out) -> None:
                result.update(device=options.device, commit=commit)
                newest = newest_checkpoint(run_root)
                if log_root is not None and newest is not None:
                    result["newest_checkpoint"] = str(newest[1])
                partial = Path(f"{run_out}.json.tmp")  # renamed whole: a run cut off mid-write leaves the last one
                partial.write_text(json.dumps(result, indent=2))
                partial.replace(f"{run_out}.json")

            result = run_until_criteria(run_options, run_root, Path(f"{run_out}.log"), report=write)
            write(result)
        if "newest_checkpoint" in result:
            print(f"[agile] the run's newest checkpoint: {result['newest_checkpoint']} (resume to continue it)",
                  flush=True)
        met = result["time_to_policy_s"]
        pace = result["climb"]
        if met is None and pace is not None:
            print(f"[agile] mean terrain level {pace['mean_terrain_level']:g} at {pace['to_wall_s']:g} s, "
                  f"{climb_in_words(pace, result['minima']['mean_terrain_level'])}", flush=True)
        failed = result["training_exit_code"] not in (None, 0)
        print(f"[agile] {task}, {seed_name(run_seed)}: {outcome(result)}; first iteration at "
              f"{result['first_iteration_s']} s; {run_out}.json" + (f" (the training's output: {run_out}.log)"
                                                                      if failed else ""), flush=True)
        results.append(result)
    written = results[0]
    title = f"{task}: {outcome(results[0])}"
    if seeds is not None:
        written = {"task": task, "device": options.device, "commit": commit, "budget_s": budget_s, "gpus": gpus,
                   "num_envs_per_gpu": num_envs, "recipe": recipe, "overrides": list(options.overrides),
                   **seed_summary(results), "runs": [f"{Path(out).name}_seed{r['seed']}.json" for r in results]}
        Path(f"{out}.json").write_text(json.dumps(written, indent=2))
        title = (f"{task}: {written['met']} of {len(results)} seeds met, median {written['median_s']:.0f} s, "
                 f"worst {written['worst_s']:.0f} s")
        print(f"[agile] {title} (a miss counts as the budget); {out}.json")
    try:
        if not plot(results, f"{out}.png", title):
            print(f"[agile] no curve: no checkpoint was written within {budget_s:g} s (every "
                  f"{save_interval} iterations; --save_interval for more)")
    except ImportError:
        print("[agile] no plot: matplotlib is missing (pip install 'agile[plot]')")
    return written


def parse_criteria(specs: list[str]) -> dict[str, float]:
    """{name: maximum} of the command line's --criterion NAME=MAX."""
    return arguments.parse_number_items(specs, "--criterion takes NAME=MAXIMUM, e.g. fall_rate=0.05; got '{item}'")


def kept_or_temporary(log_root: str | None, subfolder: str | None):
    """A context holding the folder a run trains in: `log_root` (/`subfolder`), created and kept, or a temporary
    folder deleted at the end."""
    if log_root is None:
        return tempfile.TemporaryDirectory(prefix="agile_time_to_policy_")
    path = Path(log_root) / subfolder if subfolder else Path(log_root)
    path.mkdir(parents=True, exist_ok=True)
    return contextlib.nullcontext(str(path))


def criteria_met(result: dict) -> bool:
    """Whether `time_to_policy`'s result (one run's, or the summary over seeds) met the criteria in every run."""
    if "missed_seeds" in result:
        return not result["missed_seeds"]
    return result["time_to_policy_s"] is not None


@command
def main(argv=None) -> int:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--task", required=True, help="registered task ID, e.g. Velocity-G1-History-v0")
    parser.add_argument("--budget_s", type=float, required=True, help="wall-clock budget of the whole run [s]")
    parser.add_argument("--gpus", type=int, default=1, help="GPUs of this host to train on (torchrun when > 1)")
    parser.add_argument("--num_envs", type=int, default=None, help="training envs per GPU (default: the task's)")
    parser.add_argument("--device", default=None,
                        help="cuda:0 or cpu (default: cuda:0 with a GPU); cpu with --gpus N: N CPU ranks (gloo)")
    seeds = parser.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=int, default=None, help="training seed (default: the task's)")
    seeds.add_argument("--seeds", type=int, nargs="+", default=None, metavar="SEED",
                       help="one run per seed, one after another: each seed's time to policy, the median and the "
                            "worst (a run that misses counts as its budget) in <out>.json, <out>_seed<N>.json per run")
    parser.add_argument("--save_interval", type=int, default=50, help="iterations between checkpoints (evaluations)")
    parser.add_argument("--max_iterations", type=int, default=100_000,
                        help="iterations the training is started for; the budget or the criteria end it first")
    parser.add_argument("--eval_num_envs", type=int, default=None, help="envs per evaluation (default: the task's)")
    parser.add_argument("--eval_device", default=None,
                        help="device of the evaluations, e.g. cuda:1 (default: the training's first GPU)")
    parser.add_argument("--evaluate_after_training", action="store_true",
                        help="train the whole budget undisturbed, then evaluate the checkpoints in order")
    parser.add_argument("--eval_episode_length_s", type=float, default=None,
                        help="episode length of an evaluation (default: the task's)")
    parser.add_argument("--criterion", action="append", default=None, metavar="NAME=MAX",
                        help="a criterion instead of the task's (repeat for several), e.g. fall_rate=0.05")
    parser.add_argument("--target", choices=TARGETS, default="criteria",
                        help="criteria: the task's criteria; shippable: its ship bar (mean terrain level, falls on "
                             "the start rows and over every row)")
    parser.add_argument("--resume", default=None, metavar="CHECKPOINT",
                        help="continue this checkpoint's training, its recorded wall time counted in")
    parser.add_argument("--batch_schedule", nargs="+", default=None, metavar="ITERATION:ENVSxSTEPS",
                        help=f"go on with another batch shape after an iteration, from its checkpoint (a training "
                             f"process per leg): {SCHEDULE_FORM}")
    parser.add_argument("--log_root", default=None,
                        help="a new folder to keep the run in (its checkpoints, to resume; default: deleted)")
    parser.add_argument("--out", required=True, help="write <out>.json and <out>.png (the curve)")
    parser.add_argument("--verbose", action="store_true", help="show Warp's kernel loads and library warnings")
    parser.add_argument("overrides", nargs="*", help=arguments.OVERRIDE_HELP)
    arguments.add_recipe_arg(parser)
    args = arguments.parse(parser, argv)
    result = time_to_policy(
        task=args.task, budget_s=args.budget_s, out=args.out, seed=args.seed, seeds=args.seeds, gpus=args.gpus,
        num_envs=args.num_envs, device=args.device, save_interval=args.save_interval,
        max_iterations=args.max_iterations, eval_num_envs=args.eval_num_envs, eval_device=args.eval_device,
        eval_episode_length_s=args.eval_episode_length_s, evaluate_after_training=args.evaluate_after_training,
        criteria=parse_criteria(args.criterion) if args.criterion else None, target=args.target,
        resume=args.resume, log_root=args.log_root, recipe=args.recipe, overrides=arguments.given_overrides(args),
        batch_schedule=parse_batch_schedule(args.batch_schedule or []))
    return 0 if criteria_met(result) else 1


if __name__ == "__main__":
    sys.exit(main())
