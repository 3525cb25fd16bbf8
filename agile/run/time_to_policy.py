"""Time to policy: train a task from scratch for a wall-clock budget and report when its policy first meets the
task's criteria (agile/tasks/catalogue.py), with the curve of its evaluations against wall time.

    agile time_to_policy --task Velocity-G1-History-v0 --budget_s 600 --out g1_h100
    agile time_to_policy --task Velocity-T1-v0 --budget_s 300 --gpus 4 --out t1_4gpu    # torchrun, ranks on GPUs 0-3

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
would have reached it.
"""

from __future__ import annotations

import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError

FIRST_ITERATION_MARK = "Learning iteration"
"""What rsl-rl's log prints for every iteration (the training runs with --progress log)."""
CURVE_METRICS = ("fall_rate", "lin_vel_error_mps", "ang_vel_error_radps", "base_height_error_m")


def training_command(args, log_root: str) -> list[str]:
    """The child process: `agile train` on one device, or torchrun over --gpus GPUs."""
    train_args = ["--task", args.task, "--max_iterations", str(args.max_iterations), "--log_root", log_root,
                  "--progress", "log", f"agent.save_interval={args.save_interval}", *args.overrides]
    if args.num_envs is not None:
        train_args += ["--num_envs", str(args.num_envs)]
    if args.seed is not None:
        train_args += ["--seed", str(args.seed)]
    if args.gpus > 1:  # ranks on the host's first GPUs, or on the CPU (gloo) where the run is on the CPU
        cpu_ranks = ["--device", "cpu"] if args.device == "cpu" else []
        return [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc_per_node={args.gpus}",
                "-m", "agile.run.train", *train_args, "--distributed", *cpu_ranks]
    return [sys.executable, "-m", "agile.run.train", *train_args, "--device", args.device]


def all_checkpoints(log_root: str) -> list[tuple[int, Path]]:
    """(iteration, path) of every model_<it>.pt of the run under log_root, in order."""
    return sorted((int(p.stem.split("_")[1]), p) for p in Path(log_root).glob("*/*/model_*.pt"))


def newest_checkpoint(log_root: str) -> tuple[int, Path] | None:
    """(iteration, path) of the newest model_<it>.pt of the run under log_root, or None."""
    found = all_checkpoints(log_root)
    return found[-1] if found else None


def evaluator(task: str, overrides: list[str], device: str, num_envs: int | None = None,
              episode_length_s: float | None = None, seed: int | None = None):
    """A function (checkpoint path -> eval.py's metrics) over one env in the task's evaluation setting (the catalogue's
    env count and episode length unless given, `overrides` as trained, pushes off), built once. With `seed`, every
    evaluation starts from it: each checkpoint meets the same starts and commands."""
    import torch

    import agile.tasks
    from agile.rl.checkpoints import load_checkpoint
    from agile.run.rollout_metrics import evaluate
    from agile.run.eval_all import disable_interval_events
    from agile.run.policy import inference_cfg, load_policy
    from agile.tasks.catalogue import task_entry
    from agile.utils.config import apply_overrides

    settings = task_entry(task).eval_settings
    env_cfg, agent_cfg = agile.tasks.load_cfgs(task)
    apply_overrides({"env": env_cfg, "agent": agent_cfg}, [*overrides, *settings.get("overrides", [])])
    env_cfg.num_envs = num_envs or settings["num_envs"]
    env_cfg.episode_length_s = episode_length_s or settings["episode_length_s"]
    env_cfg = inference_cfg(env_cfg)
    disable_interval_events(env_cfg)
    env = task_setup.make_env(task=task, env_cfg=env_cfg, device=device)

    def run(path: Path) -> dict:
        policy = load_policy(load_checkpoint(str(path)), env, agent_cfg)
        if seed is not None:
            torch.manual_seed(seed)
        return evaluate(env, policy, settings["num_episodes"])

    return run


def criteria_of(args) -> tuple[dict, dict]:
    """(maxima, minima): the task's criteria from the catalogue, or the maxima given as --criterion NAME=MAX."""
    from agile.tasks.catalogue import task_entry

    if not args.criterion:
        entry = task_entry(args.task)
        return dict(entry.criteria), dict(entry.minima)
    criteria = {}
    for spec in args.criterion:
        name, _, value = spec.partition("=")
        try:
            criteria[name] = float(value)
        except ValueError:
            raise AgileError(f"--criterion takes NAME=MAXIMUM, e.g. fall_rate=0.05; got '{spec}'")
    return criteria, {}


def wait_for_first_iteration(log_path: Path, process, start: float, budget_s: float) -> float | None:
    """Seconds from the start to the training's first logged iteration (None: it ended or the budget ran out)."""
    while time.monotonic() - start < budget_s and process.poll() is None:
        if log_path.exists() and FIRST_ITERATION_MARK in log_path.read_text(errors="replace"):
            return time.monotonic() - start
        time.sleep(0.5)
    return None


class CheckpointJudge:
    """Evaluates checkpoints against the criteria (the evaluation env built at the first) and keeps the rows."""

    def __init__(self, args, criteria: dict, minima: dict, device: str, start_epoch: float):
        self.args, self.criteria, self.minima, self.device = args, criteria, minima, device
        self.start_epoch = start_epoch
        self.evaluate = None
        self.rows: list[dict] = []

    def __call__(self, iteration: int, path: Path) -> dict:
        from agile.tasks.catalogue import missed_criteria

        written_s = path.stat().st_mtime - self.start_epoch  # when the training wrote it
        if self.evaluate is None:
            args = self.args
            self.evaluate = evaluator(args.task, args.overrides, self.device, args.eval_num_envs,
                                      args.eval_episode_length_s)
        metrics = self.evaluate(path)
        missed = missed_criteria(metrics, self.criteria, self.minima)
        row = {"iteration": iteration, "wall_s": round(written_s, 1), "met": not missed, "missed": missed,
               **{k: metrics[k] for k in CURVE_METRICS if k in metrics}, "episodes": metrics.get("episodes")}
        if metrics.get("error_by_command"):  # which commands a missed error comes from (yaw rate by turn rate, ...)
            row["error_by_command"] = metrics["error_by_command"]
        self.rows.append(row)
        print(f"[agile] {row['wall_s']:7.1f} s, iteration {iteration}: "
              + ", ".join(f"{k} {row[k]:.3f}" for k in CURVE_METRICS if k in row)
              + (" -> criteria met" if not missed else ""), flush=True)
        return row


def run_until_criteria(args, criteria: dict, minima: dict, device: str, log_root: str, log_path: Path) -> dict:
    start, start_epoch = time.monotonic(), time.time()
    with open(log_path, "w") as log:
        process = subprocess.Popen(training_command(args, log_root), stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True)
    first_iteration_s = wait_for_first_iteration(log_path, process, start, args.budget_s)
    judge = CheckpointJudge(args, criteria, minima, args.eval_device or device, start_epoch)
    met_at = None
    try:
        if args.evaluate_after_training:
            while time.monotonic() - start < args.budget_s and process.poll() is None:
                time.sleep(1.0)
        else:
            met_at = judge_as_they_come(args, judge, process, start, log_root)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGTERM)
            process.wait(timeout=60)
    if args.evaluate_after_training:
        for iteration, path in all_checkpoints(log_root):
            if judge(iteration, path)["met"]:
                met_at = judge.rows[-1]
                break
    return {"task": args.task, "seed": args.seed, "gpus": args.gpus, "num_envs_per_gpu": args.num_envs,
            "budget_s": args.budget_s,
            "recipe": args.recipe, "overrides": list(args.overrides),  # the recipe's first, then the given ones
            "evaluated": "after the training" if args.evaluate_after_training else f"beside it, on {judge.device}",
            "criteria": criteria, "minima": minima,
            "first_iteration_s": None if first_iteration_s is None else round(first_iteration_s, 1),
            "time_to_policy_s": met_at["wall_s"] if met_at else None,
            "iteration_at_criteria": met_at["iteration"] if met_at else None, "evaluations": judge.rows}


def judge_as_they_come(args, judge: CheckpointJudge, process, start: float, log_root: str) -> dict | None:
    """Evaluate the newest checkpoint whenever a new one appears; the row of the first that meets the criteria."""
    evaluated = -1
    while time.monotonic() - start < args.budget_s:
        newest = newest_checkpoint(log_root)
        if newest is None or newest[0] == evaluated:
            if process.poll() is not None:
                return None  # the training ended and every checkpoint is evaluated
            time.sleep(1.0)
            continue
        iteration, path = newest
        time.sleep(0.5)  # rsl-rl writes the file in one torch.save: let it finish
        evaluated = iteration
        if judge(iteration, path)["met"]:
            return judge.rows[-1]
    return None


def outcome(result: dict) -> str:
    """The run's verdict in words, for the plot's title."""
    if result["time_to_policy_s"] is None:
        return f"criteria not met within {result['budget_s']:.0f} s"
    return f"time to policy {result['time_to_policy_s']:.0f} s (iteration {result['iteration_at_criteria']})"


def seed_summary(results: list[dict]) -> dict:
    """Over one run per seed: each seed's time to policy, the median and the worst, a run that missed its criteria
    counted as its budget (and named in `missed_seeds`)."""
    times = [r["time_to_policy_s"] if r["time_to_policy_s"] is not None else r["budget_s"] for r in results]
    return {"seeds": [r["seed"] for r in results], "time_to_policy_s": [r["time_to_policy_s"] for r in results],
            "median_s": statistics.median(times), "worst_s": max(times),
            "missed_seeds": [r["seed"] for r in results if r["time_to_policy_s"] is None],
            "met": sum(r["time_to_policy_s"] is not None for r in results)}


def plot(results: list[dict], path: str, title: str) -> bool:
    """The curve of each evaluated metric against wall time into `path`, one line per run (seed); False (no file)
    when no checkpoint was evaluated (none written within the budget)."""
    metrics = [m for m in CURVE_METRICS if any(m in row for r in results for row in r["evaluations"])]
    if not metrics:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.4), squeeze=False)
    for ax, metric in zip(axes[0], metrics):
        for result in results:
            rows = [r for r in result["evaluations"] if metric in r]
            line, = ax.plot([r["wall_s"] for r in rows], [r[metric] for r in rows], marker="o", ms=3,
                            label=f"seed {result['seed']}: {outcome(result)}")
            if result["first_iteration_s"] is not None:
                ax.axvline(result["first_iteration_s"], color=line.get_color(), ls=":")
        if metric in results[0]["criteria"]:
            ax.axhline(results[0]["criteria"][metric], color="r", label="maximum")
        ax.set_xlabel("wall time since start [s]")
        ax.set_title(metric)
    axes[0][0].legend(fontsize=6)
    fig.suptitle(f"{title} ({results[0]['gpus']} GPU(s); dotted: first iteration)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


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
    parser.add_argument("--out", required=True, help="write <out>.json and <out>.png (the curve)")
    parser.add_argument("--verbose", action="store_true", help="show Warp's kernel loads and library warnings")
    parser.add_argument("overrides", nargs="*", help=arguments.OVERRIDE_HELP)
    arguments.add_recipe_arg(parser)
    args = arguments.parse(parser, argv)
    if args.gpus < 1 or args.save_interval < 1 or not args.budget_s > 0:
        raise AgileError("--gpus and --save_interval must be at least 1 and --budget_s positive")
    device, _ = task_setup.resolve_device(args.device if args.gpus == 1 or args.device == "cpu" else "cuda:0")
    args.device = device
    if args.eval_device is not None:
        args.eval_device, _ = task_setup.resolve_device(args.eval_device)
    criteria, minima = criteria_of(args)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    from agile.run.eval_all import source_commit

    commit = source_commit()
    results = []
    for seed in args.seeds or [args.seed]:
        args.seed = seed
        out = args.out if args.seeds is None else f"{args.out}_seed{seed}"
        with tempfile.TemporaryDirectory(prefix="agile_time_to_policy_") as log_root:
            result = run_until_criteria(args, criteria, minima, device, log_root, Path(f"{out}.log"))
        result.update(device=device, commit=commit)
        Path(f"{out}.json").write_text(json.dumps(result, indent=2))
        met = result["time_to_policy_s"]
        print(f"[agile] {args.task}, seed {seed}: " + (
            f"criteria met at {met} s (iteration {result['iteration_at_criteria']})" if met is not None
            else f"criteria not met within {args.budget_s:g} s") + f"; first iteration at "
              f"{result['first_iteration_s']} s; {out}.json", flush=True)
        results.append(result)
    title = args.task
    if args.seeds is not None:
        summary = {"task": args.task, "device": device, "commit": commit, "budget_s": args.budget_s,
                   "gpus": args.gpus, "num_envs_per_gpu": args.num_envs, "recipe": args.recipe,
                   "overrides": list(args.overrides), **seed_summary(results),
                   "runs": [f"{Path(args.out).name}_seed{r['seed']}.json" for r in results]}
        Path(f"{args.out}.json").write_text(json.dumps(summary, indent=2))
        title = (f"{args.task}: {summary['met']} of {len(results)} seeds met, median {summary['median_s']:.0f} s, "
                 f"worst {summary['worst_s']:.0f} s")
        print(f"[agile] {title} (a miss counts as the budget); {args.out}.json")
    else:
        title = f"{args.task}: {outcome(results[0])}"
    try:
        if not plot(results, f"{args.out}.png", title):
            print(f"[agile] no curve: no checkpoint was written within {args.budget_s:g} s (every "
                  f"{args.save_interval} iterations; --save_interval for more)")
    except ImportError:
        print("[agile] no plot: matplotlib is missing (pip install 'agile[plot]')")
    return 0 if all(r["time_to_policy_s"] is not None for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
