"""Evaluate a policy over the task's command range: tracking errors, fall rate, episode length, rewards.

    agile eval --task Velocity-G1-History-v0 --num_envs 256 --num_episodes 2   # shipped policy
    agile eval --task Velocity-T1-v0 --checkpoint model.pt --device cpu --num_envs 2 --out eval.json
    agile eval --task Velocity-G1-History-v0 --device cpu --num_envs 2 --command 0.5 0 0   # walk
    agile eval --task Velocity-Height-G1-v0 --num_envs 1024 --sweep_lin_vel_x -0.5 0 0.5 \\
        --sweep_base_height 0.4 0.56 0.72 --out sweep.json                      # a table and sweep.png
    agile eval --task HeightTracking-G1-v0 --num_envs 256 --episode_length_s 15 \\
        --sweep_command 0.1 0.3 0.5 0.7 0.92 --out heights.json                # where it settles per height

Each env runs `--num_episodes` episodes of `--episode_length_s` (pushes off unless --pushes); commands are drawn by
the task's command term, or fixed with --command. Without --checkpoint the policy shipped with agile for the task is
evaluated. Prints a summary; --out writes every metric as JSON: those of `agile.run.rollout_metrics.evaluate` (what each
key means is there). From Python: `evaluate_checkpoint(task=..., ...)` returns them.
"""

from __future__ import annotations

import dataclasses
import json
import os
import typing

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError

from agile.run.task_kinds import run_command
from agile.run.metric_breakdowns import error_by_command_tables
from agile.run.rollout_metrics import evaluate, evaluate_per_env, summarise, velocity_command_name
from agile.run.policy import inference_cfg
from agile.run.sweep_plots import plot_sweep


@dataclasses.dataclass(frozen=True)
class EvalOptions:
    """Everything `agile eval` evaluates with, for a task of any kind (`agile.run.task_kinds`: the kind's eval function
    takes it). A single-agent task: `evaluate_checkpoint`'s keyword arguments, or a sweep (`sweep_lin_vel_x` [m/s],
    times `sweep_base_height` [m]; or `sweep_command`: values of the task's one-value command); a multi-agent task:
    `checkpoint` is its training run folder. `out`: the metrics (or the sweep's rows) written as JSON there."""
    task: str
    checkpoint: str | None = None
    num_envs: int | None = None
    device: str | None = None
    seed: int | None = None
    rnn: str | None = None
    overrides: tuple = ()
    num_episodes: int = 1
    episode_length_s: float = 20.0
    pushes: bool = False
    command: tuple | None = None
    sweep_lin_vel_x: tuple | None = None
    sweep_base_height: tuple | None = None
    sweep_command: tuple | None = None
    usd: str | None = None
    video: str | None = None
    out: str | None = None
    trust_checkpoint: bool = False
    collect_datasets_anew: bool = False


def check_eval_options(options: EvalOptions) -> None:
    """Refuse, before anything is built, options that cannot go together (for a task of any kind; the kind's eval
    function refuses what it does not take)."""
    if options.sweep_command is not None and (options.sweep_lin_vel_x is not None or options.command is not None):
        raise AgileError("--sweep_command holds its own commands: not with --sweep_lin_vel_x or --command")
    if options.num_episodes < 1:
        raise AgileError(f"num_episodes must be at least 1, got {options.num_episodes}")
    for path, field in ((options.out, "out"), (options.usd, "usd"), (options.video, "video")):
        if path is not None:
            task_setup.check_writable(path, field)


def sweep_cells(lin_vel_x_mps: list[float], base_height_m: list[float] | None) -> list[tuple[float, ...]]:
    """The commands of a sweep grid: (vx, 0, 0) or (vx, 0, 0, h), vx fastest."""
    if base_height_m is None:
        return [(vx, 0.0, 0.0) for vx in lin_vel_x_mps]
    return [(vx, 0.0, 0.0, h) for h in base_height_m for vx in lin_vel_x_mps]


def sweep(env, policy, num_episodes: int, cells: list[tuple[float, ...]], command_name: str | None = None) -> list:
    """Each env holds one cell's command (env i: cell i mod cells) for all its episodes; metrics per cell."""
    import torch

    command_name = velocity_command_name(env, command_name)
    if command_name is None:
        raise AgileError(f"a sweep sets velocity commands; this task has none (commands: "
                         f"{env.command_manager.active_terms})")
    term = env.command_manager.get_term(command_name)
    if len(cells[0]) != term.command.shape[1]:
        raise AgileError(f"the sweep gives {len(cells[0])} command values; {command_name} has {term.command.shape[1]} "
                         "(--sweep_base_height is for tasks with a height command)")
    if env.num_envs < len(cells):
        raise AgileError(f"the sweep has {len(cells)} cells: use at least that many envs (--num_envs)")
    cell_of_env = torch.arange(env.num_envs, device=env.device) % len(cells)
    term.set_fixed_command(torch.tensor(cells, device=env.device)[cell_of_env])
    result = evaluate_per_env(env, policy, num_episodes, command_name)
    rows = []
    for i, cell in enumerate(cells):
        metrics = summarise(result["sums"], env.step_dt, mask=cell_of_env == i)
        rows.append({"command": list(cell), "num_envs": int((cell_of_env == i).sum()), **metrics})
    return rows


def sweep_table(rows: list) -> str:
    """The sweep as a Markdown table."""
    height = "base_height_error_m" in rows[0]
    header = "| vx [m/s] |" + (" height [m] |" if height else "") + " fall rate | vel error [m/s] |" + \
        (" height error [m] |" if height else "") + " episodes |"
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for row in rows:
        cells = [f"{row['command'][0]:+.2f}"] + ([f"{row['command'][3]:.2f}"] if height else [])
        cells += [f"{row['fall_rate']:.3f}", f"{row['lin_vel_error_mps']:.3f}"]
        cells += [f"{row['base_height_error_m']:.3f}"] if height else []
        cells += [str(row["episodes"])]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def sweep_result(options: EvalOptions, evaluation, rows_key: str, rows: list) -> dict:
    """A sweep's rows ("cells" or "values") with what was evaluated and how: what --out holds."""
    return {"task": options.task, "checkpoint": evaluation.checkpoint, "device": evaluation.device,
            "num_envs": evaluation.env.num_envs, "episodes_per_env": options.num_episodes,
            "episode_length_s": options.episode_length_s, rows_key: rows}


def write_sweep(result: dict, out: str) -> None:
    """A sweep's result as JSON in `out`, and its plot beside it."""
    with open(out, "w") as f:
        json.dump(result, f, indent=2)
    print(f"[agile] sweep: {out}")
    plot_sweep(out)


def run_sweep(options: EvalOptions, evaluation) -> dict:
    """The grid of fixed velocity commands (`sweep_lin_vel_x` times `sweep_base_height`), metrics per cell."""
    heights_m = list(options.sweep_base_height) if options.sweep_base_height is not None else None
    rows = sweep(evaluation.env, evaluation.policy, options.num_episodes,
                 sweep_cells(list(options.sweep_lin_vel_x), heights_m))
    print(sweep_table(rows))
    return sweep_result(options, evaluation, "cells", rows)


def run_command_sweep(options: EvalOptions, evaluation) -> dict:
    """Each env held at one of `sweep_command`'s values: where the robot settles, per value."""
    from agile.run.command_sweep import command_sweep, reward_terms_table, sweep_table as command_sweep_table

    rows = command_sweep(evaluation.env, evaluation.policy, options.num_episodes, list(options.sweep_command))
    print(command_sweep_table(rows))
    print("reward per step where the envs settle (weighted, before dt):")
    print(reward_terms_table(rows))
    return sweep_result(options, evaluation, "values", rows)


class Evaluation(typing.NamedTuple):
    """A policy ready to evaluate: the env built for it, the policy (observations -> actions), the checkpoint file and
    the device."""
    env: object
    policy: object
    checkpoint: str
    device: str


def set_fixed_velocity_command(env_cfg, task: str, velocity: tuple[float, float, float]) -> None:
    """Every env commanded `velocity` (vx [m/s], vy [m/s], wz [rad/s]) by the task's velocity command (the command term
    whose ranges hold lin_vel_x, lin_vel_y and ang_vel_z), none standing still."""
    commands = {name: term for name, term in vars(env_cfg.commands or object()).items()
                if all(hasattr(getattr(term, "ranges", None), f) for f in ("lin_vel_x", "lin_vel_y", "ang_vel_z"))}
    if len(commands) != 1:
        raise AgileError(f"command: {task} has {len(commands)} velocity commands ({sorted(commands)}); a fixed "
                         "velocity command needs one")
    command = next(iter(commands.values()))
    vx, vy, wz = velocity
    command.ranges.lin_vel_x, command.ranges.lin_vel_y, command.ranges.ang_vel_z = (vx, vx), (vy, vy), (wz, wz)
    command.rel_standing_envs = 0.0


def prepare_evaluation(*, task: str, checkpoint: str | None = None, num_envs: int | None = None,
                       device: str | None = None, seed: int | None = None, rnn: str | None = None, overrides=(),
                       episode_length_s: float = 20.0, pushes: bool = False,
                       command: tuple[float, float, float] | None = None, trust_checkpoint: bool = False,
                       collect_datasets_anew: bool = False) -> Evaluation:
    """The env and the policy of an evaluation: `checkpoint` (default: the policy agile ships for `task`) in the
    task's env for running a policy (`inference_cfg`) with `overrides`, episodes of `episode_length_s`, the interval
    events (pushes) off unless `pushes`, and every env given the velocity `command` where one is given."""
    checkpoint, overrides = task_setup.policy_to_run(task=task, checkpoint=checkpoint, overrides=overrides)
    contents = task_setup.read_checkpoint(checkpoint, trust_checkpoint)
    env_cfg, agent_cfg, device = task_setup.load_task(task=task, num_envs=num_envs, device=device, seed=seed,
                                                      rnn=rnn, overrides=overrides)
    task_setup.warn_overrides_not_repeated(contents, {"env": env_cfg}, "evaluate the task it was trained on")
    env_cfg = inference_cfg(env_cfg)
    if command is not None:
        set_fixed_velocity_command(env_cfg, task, command)
    env_cfg.episode_length_s = episode_length_s
    if not pushes and env_cfg.events is not None:
        from agile.rl_env.managers import EventTerm

        for name, term in vars(env_cfg.events).items():
            if isinstance(term, EventTerm) and term.mode == "interval":
                setattr(env_cfg.events, name, None)
    env = task_setup.make_env(task=task, env_cfg=env_cfg, device=device, collect_datasets_anew=collect_datasets_anew)
    return Evaluation(env, task_setup.load_policy(contents, env, agent_cfg), checkpoint, device)


def evaluate_checkpoint(*, task: str, checkpoint: str | None = None, num_envs: int | None = None,
                        device: str | None = None, seed: int | None = None, rnn: str | None = None, overrides=(),
                        num_episodes: int = 1, episode_length_s: float = 20.0, pushes: bool = False,
                        command: tuple[float, float, float] | None = None, usd: str | None = None,
                        video: str | None = None, trust_checkpoint: bool = False,
                        collect_datasets_anew: bool = False) -> dict:
    """Evaluate `checkpoint` (default: the shipped policy) on `task` (`prepare_evaluation`): every env runs
    `num_episodes` episodes; the metrics of `agile.run.rollout_metrics.evaluate` (what each key means is there) and what
    was evaluated. `usd` / `video`: the rollout recorded as an animated USD stage / env 0 rendered into an mp4."""
    from agile.run.recorders import UsdRecorder, VideoRecorder

    for path, field in ((usd, "usd"), (video, "video")):
        if path is not None:
            task_setup.check_writable(path, field)
    env, policy, checkpoint, device = prepare_evaluation(
        task=task, checkpoint=checkpoint, num_envs=num_envs, device=device, seed=seed, rnn=rnn, overrides=overrides,
        episode_length_s=episode_length_s, pushes=pushes, command=command, trust_checkpoint=trust_checkpoint,
        collect_datasets_anew=collect_datasets_anew)
    try:
        recorders = []
        if usd:
            recorders.append(UsdRecorder(usd, env, num_frames=num_episodes * env.max_episode_length))
        if video:
            recorders.append(VideoRecorder(video, env))
        metrics = evaluate(env, policy, num_episodes, recorders=recorders)
        for recorder in recorders:
            recorder.close()
    finally:
        env.close()
    metrics.update({"task": task, "checkpoint": checkpoint, "device": device,
                    "command": list(command) if command is not None else None,
                    "episode_length_s": episode_length_s, "pushes": pushes})
    return metrics


SUMMARY_KEYS = ("fall_rate", "mean_episode_length_s", "lin_vel_error_mps", "ang_vel_error_radps",
                "base_height_error_m")
"""The metrics an evaluation's summary shows, where the task measures them (the rest are in the JSON)."""


def summary(metrics: dict) -> str:
    """A few lines of what an evaluation measured: episodes, falls, the tracking errors, the episode metrics."""
    lines = [f"{metrics['task']}: {metrics['episodes']} episodes of {metrics['episode_length_s']:g} s "
             f"({metrics['num_envs']} envs on {metrics['device']}), policy {metrics['checkpoint']}"]
    lines += [f"  {key}: {metrics[key]:.4g}" for key in SUMMARY_KEYS if metrics.get(key) is not None]
    lines += [f"  {key}: {value:.4g}" for key, value in metrics.get("episode_metrics", {}).items()
              if isinstance(value, (int, float))]
    return "\n".join(lines)


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    arguments.add_common_args(parser, task_required=False)  # --plot_sweep alone builds nothing
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (default: the shipped policy); "
                        "for a multi-agent task its training run folder (the newest model of each group)")
    parser.add_argument("--command", type=float, nargs=3, default=None, metavar=("VX", "VY", "WZ"),
                        help="a fixed velocity command [m/s, m/s, rad/s] for every env")
    parser.add_argument("--num_episodes", type=int, default=1, help="episodes per env")
    parser.add_argument("--episode_length_s", type=float, default=20.0, help="length of each evaluated episode [s]")
    parser.add_argument("--pushes", action="store_true", help="keep the task's interval events (pushes)")
    parser.add_argument("--sweep_lin_vel_x", type=float, nargs="+", default=None, metavar="VX",
                        help="evaluate a grid of fixed commands instead: these forward speeds [m/s] (vy = wz = 0) ...")
    parser.add_argument("--sweep_base_height", type=float, nargs="+", default=None, metavar="H",
                        help="... times these base heights [m] (tasks with a height command); a table, and with "
                        "--out a heat map next to the JSON (.png)")
    parser.add_argument("--sweep_command", type=float, nargs="+", default=None, metavar="V",
                        help="hold each env at one of these values of the task's one-value command that measures its "
                        "own error (HeightTracking: the height [m]) and report where the robot settles, per value")
    parser.add_argument("--plot_sweep", default=None, metavar="SWEEP.json",
                        help="only draw a sweep's JSON (no env, no policy): the heat map, or where the envs settled")
    parser.add_argument("--out", default=None, help="write the metrics as JSON here (the command prints a summary)")
    parser.add_argument("--usd", default=None, metavar="PATH.usd", help="record the rollout as an animated USD stage")
    parser.add_argument("--video", default=None, metavar="PATH.mp4", help="render env 0 headless into an mp4")
    arguments.add_checkpoint_args(parser)
    args = arguments.parse(parser, argv)

    if args.plot_sweep:
        if not os.path.isfile(args.plot_sweep):
            raise AgileError(f"--plot_sweep {args.plot_sweep}: no such file")
        plot_sweep(args.plot_sweep)
        return
    if args.task is None:
        parser.error("the following arguments are required: --task")
    options = EvalOptions(
        task=args.task, checkpoint=args.checkpoint, num_envs=args.num_envs, device=args.device, seed=args.seed,
        rnn=args.rnn, overrides=tuple(args.overrides), num_episodes=args.num_episodes,
        episode_length_s=args.episode_length_s, pushes=args.pushes, command=args.command,
        sweep_lin_vel_x=args.sweep_lin_vel_x, sweep_base_height=args.sweep_base_height,
        sweep_command=args.sweep_command, usd=args.usd, video=args.video, out=args.out,
        trust_checkpoint=args.trust_checkpoint, collect_datasets_anew=args.no_cache)
    check_eval_options(options)
    run_command("eval", options.task, options)


def eval_single_agent(options: EvalOptions) -> dict:
    """`agile eval` for every kind but multi-agent (`agile.run.task_kinds`): the metrics of `evaluate_checkpoint`
    (a summary printed), or a sweep's result (its table printed); written as JSON to `out` where given."""
    evaluation_options = dict(
        task=options.task, checkpoint=options.checkpoint, num_envs=options.num_envs, device=options.device,
        seed=options.seed, rnn=options.rnn, overrides=options.overrides, episode_length_s=options.episode_length_s,
        pushes=options.pushes, command=options.command, trust_checkpoint=options.trust_checkpoint,
        collect_datasets_anew=options.collect_datasets_anew)
    if options.sweep_command is not None or options.sweep_lin_vel_x is not None:
        if options.usd or options.video:
            raise AgileError("--usd and --video record an evaluation's rollout, not a sweep's")
        evaluation = prepare_evaluation(**evaluation_options)
        result = (run_command_sweep if options.sweep_command is not None else run_sweep)(options, evaluation)
        if options.out:
            write_sweep(result, options.out)
        return result
    metrics = evaluate_checkpoint(**evaluation_options, num_episodes=options.num_episodes, usd=options.usd,
                                  video=options.video)
    print(summary(metrics))
    tables = error_by_command_tables(metrics["error_by_command"])
    if tables:
        print(f"[agile] tracking errors by what was commanded:\n{tables}")
    if options.out:
        with open(options.out, "w") as f:
            json.dump(metrics, f, indent=2)
        print(f"[agile] metrics: {options.out}")
    else:
        print("[agile] --out FILE.json writes every metric (per term, per command bin, per variant) as JSON")
    return metrics


if __name__ == "__main__":
    main()
