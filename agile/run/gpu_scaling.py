"""How training scales over the GPUs of this host: the same training (`agile train`, under torchrun where more than
one GPU) at each GPU count with --num_envs envs per GPU, its env-steps/s from the wall times its checkpoints record,
the speed-up and efficiency against the fewest GPUs measured, the all-reduce of the update's gradients timed alone
at each count (`agile.run.allreduce_timing`; its share of an iteration: the all-reduces an update makes times one),
and that every rank ended with the same weights (`agile train` fails where they differ). Writes <out>.json and one
training log per count (<out>_gpus<N>.log).

    agile gpu_scaling --task Velocity-T1-v0 --num_envs 4096 --gpus 1 2 4 8 --recipe fast --out t1_scaling
    agile gpu_scaling --task Velocity-T1-v0 --num_envs 2 --gpus 1 2 --device cpu --iterations 6 --out s   # CPU ranks
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from agile.errors import AgileError
from agile.run import arguments, task_setup
from agile.run.arguments import command
from agile.run.time_to_policy_judge import all_checkpoints
from agile.run.train_options import torchrun_command, training_command


def scaling_training_args(*, task: str, num_envs: int, iterations: int, save_interval: int, log_root: str,
                          overrides=()) -> list[str]:
    """`agile train`'s arguments of one timed training."""
    return ["--task", task, "--num_envs", str(num_envs), "--max_iterations", str(iterations), "--log_root", log_root,
            "--progress", "log", f"agent.save_interval={save_interval}", *overrides]


def run_logged(cmd: list[str], log_path: Path, timeout_s: float, what: str) -> None:
    """Run `cmd` with its output in `log_path`; AgileError naming the log where it fails or outlasts `timeout_s`."""
    with open(log_path, "w") as log:
        try:
            code = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, timeout=timeout_s).returncode
        except subprocess.TimeoutExpired:
            raise AgileError(f"{what} ran past --timeout_s {timeout_s:g} s; its output: {log_path}") from None
    if code != 0:
        raise AgileError(f"{what} failed (exit code {code}); its output: {log_path}")


def measured_training(log_root: str) -> dict:
    """From a finished run under `log_root`: its seconds per iteration between the first checkpoint past the first
    third of the run and the last one (the env build, kernel compilation and first iterations left out), the env
    steps per iteration of one GPU (its agent.yaml), the all-reduces its update makes, and the gradients' size."""
    import yaml

    from agile.rl.checkpoints import load_checkpoint

    checkpoints = all_checkpoints(log_root)
    last_iteration = checkpoints[-1][0] if checkpoints else 0
    timed = [(it, path) for it, path in checkpoints if it >= last_iteration / 3]
    if len(timed) < 2 or timed[-1][0] == timed[0][0]:
        raise AgileError(f"{log_root}: fewer than two checkpoints to time from (more --iterations, or a smaller "
                         f"--save_interval)")
    (first_it, first), (last_it, last) = timed[0], timed[-1]
    walls = [load_checkpoint(str(path))["infos"]["wall_s"] for path in (first, last)]
    agent = yaml.safe_load((last.parent / "params" / "agent.yaml").read_text())
    saved = load_checkpoint(str(last))
    gradient_floats = sum(value.numel() for key in ("actor_state_dict", "critic_state_dict")
                          for name, value in saved[key].items() if not name.startswith("obs_normalizer"))
    return {"timed_iterations": [first_it, last_it], "iteration_s": (walls[1] - walls[0]) / (last_it - first_it),
            "steps_per_env": agent["num_steps_per_env"], "gradient_floats": gradient_floats,
            "allreduces_per_iteration": agent["algorithm"]["num_learning_epochs"]
            * agent["algorithm"]["num_mini_batches"]}


def gpu_scaling(*, task: str, gpus, num_envs: int, out: str, iterations: int = 60, save_interval: int = 10,
                device: str | None = None, allreduce_repeats: int = 50, timeout_s: float = 1800.0, recipe=None,
                overrides=()) -> dict:
    """Train `task` for `iterations` iterations on each GPU count of `gpus` (CPU ranks with `device` "cpu"),
    `num_envs` envs per GPU, and measure each (see the module). Returns what <out>.json holds; raises AgileError
    naming the field for what it refuses, before anything runs, and naming the log of a run that fails."""
    from agile.run.eval_all import source_commit
    from agile.run.recipes import RECIPES

    task_setup.check_task(task)
    gpus = sorted(set(gpus))
    if not gpus or any(n < 1 for n in gpus):
        raise AgileError(f"gpus: positive GPU counts, got {gpus}")
    for value, field, minimum in ((num_envs, "num_envs", 1), (save_interval, "save_interval", 1),
                                  (iterations, "iterations", 3 * save_interval), (allreduce_repeats,
                                                                                  "allreduce_repeats", 1)):
        if value < minimum:
            raise AgileError(f"{field} must be at least {minimum}, got {value}")
    if not timeout_s > 0:
        raise AgileError(f"timeout_s must be positive, got {timeout_s}")
    if recipe is not None and recipe not in RECIPES:
        raise AgileError(f"recipe must be one of {', '.join(sorted(RECIPES))} (or None), got {recipe!r}")
    if device not in (None, "cpu"):
        raise AgileError(f"device: cpu (CPU ranks, gloo) or None (the host's GPUs), got {device!r}")
    if device is None:
        import torch

        if max(gpus) > torch.cuda.device_count():
            raise AgileError(f"gpus: {max(gpus)} GPUs asked, this host has {torch.cuda.device_count()} (--device "
                             f"cpu runs the counts as CPU ranks)")
        device = "cuda:0"  # the one-GPU run's; torchrun's ranks take cuda:LOCAL_RANK
    overrides = (*RECIPES.get(recipe, ()), *overrides)
    task_setup.check_overrides(task=task, overrides=overrides)
    task_setup.check_writable(f"{out}.json", "out")
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    rows = []
    for count in gpus:
        with tempfile.TemporaryDirectory(prefix="agile_gpu_scaling_") as log_root:
            print(f"[agile] {task} on {count} {'CPU rank' if device == 'cpu' else 'GPU'}(s), {num_envs} envs each, "
                  f"{iterations} iterations", flush=True)
            train_args = scaling_training_args(task=task, num_envs=num_envs, iterations=iterations,
                                               save_interval=save_interval, log_root=log_root, overrides=overrides)
            run_logged(training_command(train_args, count, device), Path(f"{out}_gpus{count}.log"), timeout_s,
                       f"the training on {count}")
            row = {"gpus": count, **measured_training(log_root)}
            if count > 1:
                timing = Path(log_root) / "allreduce.json"
                allreduce_args = ["--floats", str(row["gradient_floats"]), "--repeats", str(allreduce_repeats),
                                  "--out", str(timing), *(["--device", "cpu"] if device == "cpu" else [])]
                run_logged(torchrun_command("agile.run.allreduce_timing", allreduce_args, count),
                           Path(f"{out}_allreduce{count}.log"), timeout_s, f"the all-reduce timing on {count}")
                row["allreduce_s"] = json.loads(timing.read_text())["median_s"]
                row["allreduce_share"] = row["allreduce_s"] * row["allreduces_per_iteration"] / row["iteration_s"]
        row["env_steps_per_s"] = count * num_envs * row["steps_per_env"] / row["iteration_s"]
        row["same_weights"] = count == 1 or f"all {count} ranks hold the same weights" in \
            Path(f"{out}_gpus{count}.log").read_text(errors="replace")
        rows.append(row)
    base = rows[0]
    for row in rows:
        row["speedup"] = row["env_steps_per_s"] / base["env_steps_per_s"]
        row["efficiency"] = row["speedup"] * base["gpus"] / row["gpus"]
    result = {"task": task, "device": device, "num_envs_per_gpu": num_envs, "iterations": iterations,
              "recipe": recipe, "overrides": list(overrides), "commit": source_commit(), "rows": rows}
    Path(f"{out}.json").write_text(json.dumps(result, indent=2))
    for row in rows:
        share = f", all-reduce {row['allreduce_share']:.1%} of an iteration" if "allreduce_share" in row else ""
        print(f"[agile] {row['gpus']}: {row['env_steps_per_s']:,.0f} env-steps/s ({row['iteration_s']:.3f} s an "
              f"iteration), {row['speedup']:.2f}x, efficiency {row['efficiency']:.2f}{share}", flush=True)
    return result


@command
def main(argv=None) -> int:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--task", required=True, help="registered task ID, e.g. Velocity-T1-v0")
    parser.add_argument("--gpus", type=int, nargs="+", required=True, help="GPU counts, e.g. 1 2 4 8")
    parser.add_argument("--num_envs", type=int, required=True, help="training envs per GPU")
    parser.add_argument("--iterations", type=int, default=60, help="iterations each training runs")
    parser.add_argument("--save_interval", type=int, default=10,
                        help="iterations between checkpoints, whose recorded wall times time the run")
    parser.add_argument("--device", default=None, help="cpu: CPU ranks (gloo); default the host's GPUs")
    parser.add_argument("--allreduce_repeats", type=int, default=50, help="all-reduces timed at each count")
    parser.add_argument("--timeout_s", type=float, default=1800.0, help="the longest one training may run [s]")
    parser.add_argument("--out", required=True, help="write <out>.json and a log per GPU count")
    parser.add_argument("overrides", nargs="*", help=arguments.OVERRIDE_HELP)
    arguments.add_recipe_arg(parser)
    args = arguments.parse(parser, argv)
    gpu_scaling(task=args.task, gpus=args.gpus, num_envs=args.num_envs, out=args.out, iterations=args.iterations,
                save_interval=args.save_interval, device=args.device, allreduce_repeats=args.allreduce_repeats,
                timeout_s=args.timeout_s, recipe=args.recipe, overrides=arguments.given_overrides(args))
    return 0


if __name__ == "__main__":
    sys.exit(main())
