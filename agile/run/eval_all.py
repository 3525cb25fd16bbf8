"""Evaluate every task with a shipped policy (trainable, distilled or multi-agent, from the task catalogue) and write
one JSON per task, report.md and, where matplotlib is installed, PNG plots into --out. A multi-agent task's criteria
bound each of its agents (a row per agent in the report).

    agile eval_all --out eval_report                  # GPU: each task's eval settings and criteria
    agile eval_all --device cpu --num_envs 2 --episode_length_s 1 --out /tmp/eval   # tiny CPU run

The report names the GPU and the commit it was made at ($AGILE_SOURCE_COMMIT where set, else the checkout's).
Exit code 1 when a policy misses its criteria (fall rate, velocity errors, base-height error for tasks with a
height command; see agile/tasks/catalogue.py). On CPU, or with fewer envs or shorter episodes than a task's
eval settings, the run only proves that every policy loads and steps: criteria are reported, not checked.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError
from agile.run.policy import inference_cfg

from agile.run.rollout_metrics import evaluate


def disable_interval_events(env_cfg) -> None:
    """Pushes and random wrenches off, as eval.py does without --pushes: the criteria are for undisturbed walking."""
    from agile.rl_env.managers import EventTerm

    if env_cfg.events is None:
        return
    for name, term in vars(env_cfg.events).items():
        if isinstance(term, EventTerm) and term.mode == "interval":
            setattr(env_cfg.events, name, None)


def device_name(device: str) -> str:
    """The device in words, for the report: the GPU's model name, or "cpu"."""
    import torch

    return torch.cuda.get_device_name(torch.device(device)) if device.startswith("cuda") else "cpu"


def source_commit() -> str:
    """The commit the report was made at: AGILE_SOURCE_COMMIT where set (a tree copied to another machine, whose
    .git may be stale), else this checkout's ("+ uncommitted changes" where the tree differs from it), else
    "unknown" (an installed package)."""
    import subprocess

    if os.environ.get("AGILE_SOURCE_COMMIT"):
        return os.environ["AGILE_SOURCE_COMMIT"]

    def git(*args) -> str:
        return subprocess.run(["git", "-C", str(task_setup.REPO_ROOT), *args], capture_output=True, text=True,
                              check=True).stdout.strip()

    try:
        commit = git("rev-parse", "--short=12", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return commit + (" + uncommitted changes" if dirty else "")


def evaluate_task(entry, *, device: str | None = None, seed: int | None = None, num_envs: int | None = None,
                  num_episodes: int | None = None, episode_length_s: float | None = None) -> dict:
    """Build the task's env in its shipped policy's training conditions, run the policy, return the metrics. The
    counts and the episode length not given are the task's evaluation settings (its catalogue entry's)."""
    settings = dict(entry.eval_settings)
    given = {"num_envs": num_envs, "num_episodes": num_episodes, "episode_length_s": episode_length_s}
    settings.update({key: value for key, value in given.items() if value is not None})
    overrides = list(settings.pop("overrides", []))  # the task's evaluation setting, e.g. a motion from its start
    shipped = task_setup.shipped_policy(task=entry.task, overrides=overrides)  # its training conditions go first
    checkpoint = shipped.path
    if entry.kind == "multi_agent":
        from agile.run.multi_agent import run_world

        metrics = run_world(task=entry.task, checkpoint=checkpoint, num_envs=settings["num_envs"], device=device,
                            seed=seed, overrides=shipped.overrides, episodes=settings["num_episodes"],
                            episode_length_s=settings["episode_length_s"])
        device = metrics["device"]
        metrics = {"agents": metrics["agents"], "group_checkpoints": metrics["checkpoints"]}
    else:
        metrics, device = evaluate_single_agent(entry, checkpoint, shipped.overrides, device=device, seed=seed,
                                                settings=settings)
    full_setting = (device != "cpu" and all(settings[k] >= entry.eval_settings[k] for k in settings))
    settings["overrides"] = overrides
    return {"task": entry.task, "kind": entry.kind, "checkpoint": checkpoint, "device": device,
            "device_name": device_name(device), "commit": source_commit(), **settings,
            "criteria": entry.criteria, "minima": entry.minima, "criteria_checked": full_setting, **metrics}


def evaluate_single_agent(entry, checkpoint: str, overrides: list[str], *, device: str | None, seed: int | None,
                          settings: dict) -> tuple[dict, str]:
    """(the metrics of the policy `checkpoint` run in the task's env, the device it ran on)."""
    contents = task_setup.read_checkpoint(checkpoint, trust=False)
    env_cfg, agent_cfg, device = task_setup.load_task(task=entry.task, num_envs=settings["num_envs"], device=device,
                                                 seed=seed, overrides=overrides)
    env_cfg = inference_cfg(env_cfg)
    env_cfg.episode_length_s = settings["episode_length_s"]
    disable_interval_events(env_cfg)
    env = task_setup.make_env(task=entry.task, env_cfg=env_cfg, device=device)
    try:
        policy = task_setup.load_policy(contents, env, agent_cfg)
        return evaluate(env, policy, settings["num_episodes"]), device
    finally:
        env.close()


def report_rows(results: list[dict]) -> list[dict]:
    """One row per single-agent task, and one per agent of a multi-agent task (named "<task> <agent>", its agent's
    metrics against the task's criteria)."""
    rows = []
    for r in results:
        if "agents" not in r:
            rows.append(r)
            continue
        common = {k: v for k, v in r.items() if k not in ("agents", "group_checkpoints")}
        rows += [{**common, "error_by_command": {}, **metrics, "task": f"{r['task']} {agent}"}
                 for agent, metrics in r["agents"].items()]
    return rows


def verdict(result: dict) -> tuple[str, list[str]]:
    """('pass' | 'FAIL' | 'not checked', the criteria missed)."""
    from agile.tasks.catalogue import missed_criteria

    missed = missed_criteria(result, result["criteria"], result.get("minima"))
    if not result["criteria_checked"]:
        return "not checked", missed
    return ("FAIL" if missed else "pass"), missed


def report_markdown(results: list[dict], plots: list[str]) -> str:
    from agile.tasks.catalogue import criterion_values

    results = report_rows(results)
    made_at = sorted({f"{r.get('device_name', r['device'])} at commit {r.get('commit', 'unknown')}" for r in results})
    lines = ["# Evaluation of the shipped policies", "",
             "Written by `agile eval_all`: every task of kind trainable, distilled or multi-agent with a shipped "
             "policy (`agile list`; a row per agent of a multi-agent task), pushes off, commands drawn by the task's "
             "command term.", "",
             f"Made on {'; '.join(made_at)}.", ""]
    if not all(r["criteria_checked"] for r in results):
        lines += ["**Criteria not checked** for the runs marked so: they ran on CPU or with fewer envs or shorter "
                  "episodes than the task's eval settings, which proves only that the policy loads and steps.", ""]
    lines += ["| task | kind | device | envs x episodes x length | fall rate | vel error [m/s] | yaw-rate error [rad/s] "
              "| height error [m] | episode length [s] | verdict |", "|" + "---|" * 10]
    for r in results:
        # a task without a velocity (or height) command has no such error: "-"; the height column is the base-height
        # command's error, or the task's own height criterion (HeightTracking's tracked point, an episode metric)
        heights = [criterion_values(r, name, breakdown=False)[0][1] for name in ("base_height_error_m", *r["criteria"])
                   if name.endswith("height_error_m")]
        height = next((value for value in heights if value is not None), None)
        errors = [f"{r[k]:.3f}" if k in r else "-" for k in ("lin_vel_error_mps", "ang_vel_error_radps")]
        errors.append("-" if height is None else f"{height:.3f}")
        state, missed = verdict(r)
        length = f"{r['mean_episode_length_s']:.2f}" if "mean_episode_length_s" in r else "-"
        lines.append(f"| {r['task']} | {r['kind']} | {r['device']} | {r['num_envs']} x {r['num_episodes']} x "
                     f"{r['episode_length_s']:g} s | {r['fall_rate']:.3f} | {' | '.join(errors)} | {length} | {state}"
                     + (f": {'; '.join(missed)}" if missed and state == "FAIL" else "") + " |")
    lines += ["", "Criteria per task:", ""]
    lines += [f"- {r['task']}: " + ", ".join([*(f"{k} <= {v:g}" for k, v in r["criteria"].items()),
                                              *(f"{k} >= {v:g}" for k, v in r.get("minima", {}).items())])
              for r in results]
    lines += ["", "Reward per step of each term:", ""]
    for r in results:
        terms = ", ".join(f"{k} {v:+.4f}" for k, v in r["reward_per_step"].items())
        lines.append(f"- {r['task']}: {terms}")
    with_metrics = [r for r in results if r.get("episode_metrics")]
    if with_metrics:
        lines += ["", "Episode metrics (means over the ended episodes):", ""]
        lines += [f"- {r['task']}: " + ", ".join(f"{k} {v:.4g}" for k, v in r["episode_metrics"].items())
                  for r in with_metrics]
    if plots:
        lines += [""] + [f"![{os.path.splitext(p)[0]}]({p})" for p in plots]
    else:
        lines += ["", "No plots: matplotlib is missing (`pip install 'agile[plot]'`)."]
    return "\n".join(lines) + "\n"


def plot_results(results: list[dict], out_dir: str) -> list[str]:
    """One PNG of the summary metrics (a bar per row of `report_rows`) and one of each row's per-term rewards; file
    names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    metrics = ["fall_rate", "lin_vel_error_mps", "ang_vel_error_radps", "base_height_error_m", "mean_episode_length_s"]
    fig, axes = plt.subplots(1, len(metrics), figsize=(3.6 * len(metrics), 3.6))
    for ax, metric in zip(axes, metrics):
        tasks = [r["task"] for r in results if metric in r]
        ax.bar(range(len(tasks)), [r[metric] for r in results if metric in r])
        for i, r in enumerate(r for r in results if metric in r):
            if metric in r["criteria"]:
                ax.hlines(r["criteria"][metric], i - 0.4, i + 0.4, colors="r", label="maximum" if i == 0 else None)
        ax.set_xticks(range(len(tasks)), tasks, rotation=30, ha="right", fontsize=7)
        ax.set_title(metric)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "summary.png"), dpi=110)
    plt.close(fig)
    names.append("summary.png")
    for r in results:
        terms = r["reward_per_step"]
        fig, ax = plt.subplots(figsize=(6, 0.25 * len(terms) + 1))
        ax.barh(list(terms), list(terms.values()))
        ax.set_title(f"{r['task']}: reward per step by term")
        fig.tight_layout()
        name = f"{r['task'].replace(' ', '_')}_rewards.png"
        fig.savefig(os.path.join(out_dir, name), dpi=110)
        plt.close(fig)
        names.append(name)
        if any(r["error_by_command"].values()):  # none without a command, or where no episode ended in a bin
            names.append(plot_error_by_command(r, out_dir, plt))
    return names


def bin_label(bounds: list) -> str:
    low, high = bounds
    return f">= {low:g}" if high is None else f"{low:g}-{high:g}"


ERROR_BY_COMMAND_AXES = {
    "lin_vel_error_mps_by_speed_mps": ("lin_vel_error_mps", "commanded planar speed [m/s]", "velocity error [m/s]"),
    "ang_vel_error_radps_by_yaw_rate_radps": ("ang_vel_error_radps", "commanded |yaw rate| [rad/s]",
                                              "yaw-rate error [rad/s]"),
    "base_height_error_m_by_height_m": ("base_height_error_m", "commanded base height [m]", "height error [m]"),
    "height_error_m_by_height_m": ("height_error_m_by_height_m", "commanded height [m]", "height error [m]"),
}
"""eval.py's error-by-command keys: (the metric it splits, x label, y label)."""


def plot_error_by_command(result: dict, out_dir: str, plt) -> str:
    """One PNG of a task's tracking errors against what was commanded (bars: mean error per bin of the commanded
    speed, and of the commanded height for a height command; whiskers: +-2 standard errors over the envs, where the
    rows have them); its file name."""
    panels = {key: rows for key, rows in result["error_by_command"].items() if rows}
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.4), squeeze=False)
    for ax, (key, rows) in zip(axes[0], panels.items()):
        metric, x_label, y_label = ERROR_BY_COMMAND_AXES[key]
        whiskers = [2 * (row.get("error_se") or 0.0) for row in rows]
        ax.bar(range(len(rows)), [row["error"] for row in rows], yerr=whiskers if any(whiskers) else None, capsize=3)
        ax.set_xticks(range(len(rows)), [bin_label(row["command"]) for row in rows], fontsize=8)
        ax.set_xlabel(x_label)
        ax.set_ylabel(y_label)
        if metric in result["criteria"]:  # a bound on the mean over all commands, or on each bin's (a by-command key)
            per_bin = metric == key
            ax.axhline(result["criteria"][metric], color="r",
                       label="maximum (of each bin)" if per_bin else "maximum (of the mean over all commands)")
            ax.set_ylim(top=max(ax.get_ylim()[1], 1.15 * result["criteria"][metric]))  # the line inside the plot
            ax.legend(fontsize=7)
    fig.suptitle(f"{result['task']}: tracking error by command")
    fig.tight_layout()
    name = f"{result['task'].replace(' ', '_')}_error_by_command.png"
    fig.savefig(os.path.join(out_dir, name), dpi=110)
    plt.close(fig)
    return name


@command
def main(argv=None) -> int:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--out", required=True, help="folder for <task>.json, report.md and the plots")
    parser.add_argument("--device", default=None, help="cuda:0 or cpu (default: cuda:0 when a GPU is present)")
    parser.add_argument("--num_envs", type=int, default=None, help="envs per task (default: each task's eval setting)")
    parser.add_argument("--num_episodes", type=int, default=None, help="episodes per env (default: the task's)")
    parser.add_argument("--episode_length_s", type=float, default=None, help="episode length (default: the task's)")
    parser.add_argument("--tasks", nargs="+", default=None, help="only these tasks (default: every one with a policy)")
    parser.add_argument("--seed", type=int, default=None, help="random seed")
    parser.add_argument("--verbose", action="store_true", help="show Warp's kernel loads and library warnings")
    args = arguments.parse(parser, argv)
    from agile.tasks.catalogue import evaluated_tasks

    entries = evaluated_tasks()
    if args.tasks:
        by_name = {e.task: e for e in entries}
        unknown = [t for t in args.tasks if t not in by_name]
        if unknown:
            raise AgileError(f"no shipped policy to evaluate for {unknown}. Tasks with one: {sorted(by_name)}")
        entries = [by_name[t] for t in args.tasks]
    os.makedirs(args.out, exist_ok=True)
    results = []
    for entry in entries:
        print(f"[agile] eval_all: {entry.task}", flush=True)
        result = evaluate_task(entry, device=args.device, seed=args.seed, num_envs=args.num_envs,
                               num_episodes=args.num_episodes, episode_length_s=args.episode_length_s)
        with open(os.path.join(args.out, f"{entry.task}.json"), "w") as f:
            json.dump(result, f, indent=2)
        results.append(result)
    rows = report_rows(results)
    plots = plot_results(rows, args.out) if importlib.util.find_spec("matplotlib") else []
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(results, plots))
    failed = [r["task"] for r in rows if verdict(r)[0] == "FAIL"]
    for r in rows:
        print(f"[agile] {r['task']}: {verdict(r)[0]}" + (f" ({'; '.join(verdict(r)[1])})" if verdict(r)[1] else ""))
    print(f"[agile] report: {os.path.join(args.out, 'report.md')}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
