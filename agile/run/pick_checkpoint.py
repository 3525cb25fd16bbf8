"""Which checkpoint of a training run to keep: its checkpoints evaluated against the task's criteria on the same
episodes, and the best named.

    agile pick_checkpoint --task HeightTracking-G1-v0 --run logs/rsl_rl/height_tracking_g1/<run> --every 100
    agile pick_checkpoint --task Velocity-T1-v0 --run <run> --every 50 --out picked.json env.scene.terrain=null

A policy that drifts as it trains (a posture split moving from one thousand iterations to the next) is best kept at
its best checkpoint, not its last. Every model_<iteration>.pt of the run whose iteration is a multiple of --every, and
the newest, is evaluated in the task's evaluation setting (the catalogue's env count and episode length unless given,
the registered start rows, pushes off; the overrides the run trained with are given after the options), one env built
once and reseeded before each checkpoint, so that every checkpoint meets the same starts and commands. A checkpoint's
score is its worst margin to the criteria (`agile/tasks/catalogue.py`: value / maximum, per band where a maximum bounds
a breakdown such as HeightTracking's commanded-height bands; at most 1 where every criterion is met); the best is the
lowest. Fewer envs, shorter episodes or the CPU still rank them, but (as `eval_all`) do not judge whether one meets
the criteria. Prints a table; --out writes the rows as JSON. From Python: `pick_checkpoint(task=..., run_dir=..., ...)`
returns them.
"""

from __future__ import annotations

import json
from pathlib import Path

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError


def run_checkpoints(run_dir: Path, every: int) -> list[tuple[int, Path]]:
    """(iteration, path) of the run's model_<iteration>.pt whose iteration is a multiple of `every`, and the newest."""
    found = sorted((int(p.stem.split("_")[1]), p) for p in run_dir.glob("model_*.pt")
                   if p.stem.split("_")[1].isdigit())
    picked = [(it, p) for it, p in found if it % every == 0]
    if found and found[-1] not in picked:
        picked.append(found[-1])
    return picked


def judge(metrics: dict, criteria: dict, minima: dict) -> dict:
    """The row of one evaluation: the criteria it misses, its score, and the metrics the criteria name."""
    from agile.tasks.catalogue import criterion_values, missed_criteria, worst_margin

    breakdowns = metrics.get("error_by_command", {})
    named = {name: criterion_values(metrics, name, breakdown=False)[0][1] for name in [*criteria, *minima]
             if name not in breakdowns}
    bands = {name: [round(value, 4) for _, value in criterion_values(metrics, name)]
             for name in breakdowns if name in criteria}
    missed = missed_criteria(metrics, criteria, minima)
    return {"met": not missed, "score": worst_margin(metrics, criteria, minima), "missed": missed, **named, **bands}


def table(rows: list[dict]) -> str:
    keys = [k for k in rows[0] if k not in ("iteration", "met", "score", "missed", "checkpoint")]

    def cell(value) -> str:
        if isinstance(value, list):
            return " / ".join(f"{v:.3f}" for v in value)
        return "-" if value is None else f"{value:.4g}"

    lines = ["| iteration | score | met | " + " | ".join(keys) + " |", "|" + "---|" * (len(keys) + 3)]
    met = {True: "yes", False: "no", None: "not judged"}
    lines += [f"| {r['iteration']} | {r['score']:.3f} | {met[r['met']]} | "
              + " | ".join(cell(r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def pick_checkpoint(*, task: str, run_dir: str, every: int = 100, device: str | None = None,
                    num_envs: int | None = None, episode_length_s: float | None = None, seed: int = 0,
                    overrides=()) -> dict:
    """Evaluate the checkpoints of the training run in `run_dir` (model_<iteration>.pt at multiples of `every`, and
    the newest) in `task`'s evaluation setting (`num_envs`, `episode_length_s`: the catalogue's unless given; the
    overrides the run trained with as `overrides`), one env reseeded with `seed` before each, and rank them by their
    worst margin to the task's criteria. Prints a table; returns what `agile pick_checkpoint --out` writes: the setting,
    whether the criteria were judged (the task's setting on a GPU), the rows and the best iteration ("best"). Raises
    AgileError naming the field for a bad run folder, task or count, before anything is built."""
    if every < 1:
        raise AgileError(f"--every must be >= 1, got {every}")
    run_path = Path(run_dir)
    if not run_path.is_dir():
        raise AgileError(f"--run {run_dir}: no such folder")
    checkpoints = run_checkpoints(run_path, every)
    if not checkpoints:
        raise AgileError(f"--run {run_dir}: no model_<iteration>.pt in it")

    from agile.run.time_to_policy_judge import evaluator
    from agile.tasks.catalogue import task_entry
    from agile.utils.config import ConfigError

    task_setup.check_task(task)
    entry = task_entry(task)
    if not entry.criteria and not entry.minima:
        raise AgileError(f"{task} has no evaluation criteria in the catalogue (kind '{entry.kind}'): nothing to "
                         f"pick by")
    device, fallback = task_setup.resolve_device(device)
    if fallback is not None:
        print(f"[agile] {fallback}: evaluating on the CPU")
    try:
        evaluate = evaluator(task, list(overrides), device, num_envs, episode_length_s, seed=seed)
    except ConfigError as err:
        raise AgileError(str(err))
    setting = {"num_envs": num_envs or entry.eval_settings["num_envs"],
               "episode_length_s": episode_length_s or entry.eval_settings["episode_length_s"]}
    # as eval_all judges: fewer envs, shorter episodes or the CPU rank the checkpoints, but cannot say one passes
    judged = device != "cpu" and all(setting[k] >= entry.eval_settings[k] for k in setting)
    if not judged:
        task_setting = entry.eval_settings
        print(f"[agile] {setting['num_envs']} envs x {setting['episode_length_s']:g} s on {device}, not the task's "
              f"evaluation setting ({task_setting['num_envs']} envs x {task_setting['episode_length_s']:g} s on a "
              f"GPU): the checkpoints are ranked, whether one meets the criteria is not judged")
    rows = []
    for iteration, path in checkpoints:
        row = {"iteration": iteration, "checkpoint": str(path), **judge(evaluate(path), entry.criteria, entry.minima)}
        if not judged:
            row["met"] = None
        rows.append(row)
        print(f"[agile] iteration {iteration}: score {row['score']:.3f}" + (" (criteria met)" if row["met"] else ""),
              flush=True)
    best = min(rows, key=lambda r: r["score"])
    print(table(rows))
    verdict = ("criteria not judged" if best["met"] is None else "every criterion met" if best["met"]
               else f"misses {'; '.join(best['missed'])}")
    print(f"[agile] best: iteration {best['iteration']} ({best['checkpoint']}), score {best['score']:.3f}; {verdict}")
    return {"task": task, "run": str(run_path), "every": every, "seed": seed, "device": device, **setting,
            "criteria_judged": judged, "criteria": entry.criteria, "minima": entry.minima, "best": best["iteration"],
            "rows": rows}


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--task", required=True, help="the registered task the run trained")
    parser.add_argument("--run", required=True, help="the training run's folder (its model_<iteration>.pt files)")
    parser.add_argument("--every", type=int, default=100, help="evaluate the checkpoints at multiples of this many "
                        "iterations (and the newest)")
    parser.add_argument("--device", default=None, help="cuda:0 or cpu (default: cuda:0 when a GPU is present)")
    parser.add_argument("--num_envs", type=int, default=None, help="envs per evaluation (default: the task's)")
    parser.add_argument("--episode_length_s", type=float, default=None, help="episode length (default: the task's)")
    parser.add_argument("--seed", type=int, default=0, help="the seed every evaluation starts from")
    parser.add_argument("--out", default=None, help="write the rows (and the best) as JSON here")
    parser.add_argument("overrides", nargs="*", help=arguments.OVERRIDE_HELP)
    args = arguments.parse(parser, argv)
    picked = pick_checkpoint(task=args.task, run_dir=args.run, every=args.every, device=args.device,
                             num_envs=args.num_envs, episode_length_s=args.episode_length_s, seed=args.seed,
                             overrides=args.overrides)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(picked, f, indent=2)


if __name__ == "__main__":
    main()
