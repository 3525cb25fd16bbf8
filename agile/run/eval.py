"""Evaluate a policy over the task's command range: tracking errors, fall rate, episode length, rewards.

    agile eval --task Velocity-G1-History-v0 --num_envs 256 --num_episodes 2   # shipped policy
    agile eval --task Velocity-T1-v0 --checkpoint model.pt --device cpu --num_envs 2 --out eval.json
    agile eval --task Velocity-G1-History-v0 --device cpu --num_envs 2 --command 0.5 0 0   # walk
    agile eval --task Velocity-Height-G1-v0 --num_envs 1024 --sweep_lin_vel_x -0.5 0 0.5 \
        --sweep_base_height 0.4 0.56 0.72 --out sweep.json                      # a table and sweep.png
    agile eval --task HeightTracking-G1-v0 --num_envs 256 --episode_length_s 15 \
        --sweep_command 0.1 0.3 0.5 0.7 0.92 --out heights.json                # where it settles per height

Each env runs `num_episodes` episodes of `episode_length_s` (pushes off unless --pushes); an env whose episode ends
early starts another within the window, which is not counted: every env contributes exactly `num_episodes`.
Commands are drawn by the task's command term (uniform over its ranges, a share standing), or fixed with --command.
Without --checkpoint the policy shipped with agile for the task is evaluated. Prints and writes JSON.
Velocity errors are measured for tasks with a velocity command (also by commanded planar speed and by commanded
|yaw rate|, under "error_by_command"), the height error (commanded minus measured above the terrain) for those with a
base-height command; every task reports its episode metrics as means over the ended
episodes under "episode_metrics": its command terms' (`CommandTerm.metrics`, "<term>/<name>": the motion-tracking
errors, pick-and-place success) and its metric terms' (the env cfg's `metrics`, "<name>": the stand-up success);
a command that draws kinds of episode (pick-and-place: which trajectory) gets episodes, falls and those metrics per
kind under "episodes_by_variant" (by its name), and a task on a terrain grid the same by the cell each episode
spawned on ("terrain_cell": "row <r> col <c> <sub-terrain>"); "falls_by_episode_time_s" counts the ended episodes
and the falls per second of episode time at which they ended; "robots_fallen", "robot_fall_rate" and
"max_falls_of_one_robot" count falls by env (its robot's randomisation is drawn once per run); a command that
measures its own error (`CommandTerm.command_error`: the height-tracking command's) gets it by commanded value under
"error_by_command" ("height_error_m_by_height_m").
JSON files written before these were merged have the command terms' under "command_metrics".
"""

from __future__ import annotations

import json
import os

from agile.run import common as cli

from agile.run import multi_agent
from agile.run.common import load_policy
from agile.run.eval_breakdowns import (HEIGHT_BIN_EDGES_M, SPEED_BIN_EDGES_MPS, YAW_RATE_BIN_EDGES_RADPS,
                                     ErrorByCommand, FallsByTime,
                                      OutcomesByVariant, spawn_cell_variants)
from agile.run.policy import inference_cfg
from agile.run.sweep_plots import plot_sweep

FALL_TIME_BIN_S = 1.0
"""Width of the bins of `falls_by_episode_time_s`, when in their episodes episodes ended and fell."""


def velocity_command_name(env, command_name: str | None = None) -> str | None:
    """The command whose velocity errors are measured: `command_name`, or the one command term with a velocity
    layout (`CommandTerm.command_fields`); None where the task has none (motion tracking, pick-and-place)."""
    from agile.rl_env.managers.command_manager import VELOCITY_FIELDS

    terms = env.command_manager.terms
    with_velocity = [name for name, term in terms.items() if term.command_fields[:3] == VELOCITY_FIELDS]
    if command_name is not None and command_name not in with_velocity:
        cli.fail(f"command '{command_name}' is not a velocity command; the task's velocity commands: {with_velocity}")
    if command_name is None and len(with_velocity) > 1:
        cli.fail(f"the task has several velocity commands {with_velocity}: name the one to evaluate")
    return command_name or (with_velocity[0] if with_velocity else None)


def height_command_sensor(env, command_name: str | None) -> str | None:
    """The height scanner that measures the commanded base height, for a velocity command with a height."""
    if command_name is None:
        return None
    term = env.command_manager.get_term(command_name)
    return term.cfg.height_sensor_name if "base_height_m" in term.command_fields else None


def evaluate_per_env(env, policy, num_episodes: int, command_name: str | None = None, recorders=()) -> dict:
    """Sums per env over `num_episodes` episodes of every env: (N,) tensors of tracking errors over the steps
    alive (with a velocity command), steps alive, episodes ended, falls, ended episodes' lengths and the episode
    metrics of the ended episodes ("episode_metric/<key>", keys of `env.last_episode_metrics`); each reward term's
    total; and the errors by commanded speed (and height)."""
    import torch

    from agile.rl_env.mdp import base_height_above_ground

    n = env.num_envs
    zeros = lambda: torch.zeros(n, device=env.device)  # noqa: E731
    command_name = velocity_command_name(env, command_name)
    keys = ["steps_alive", "episodes", "falls", "ended_length_steps"]
    keys += ["lin_vel_error_mps", "ang_vel_error_radps"] if command_name is not None else []
    height_sensor = height_command_sensor(env, command_name)
    keys += ["base_height_error_m"] if height_sensor is not None else []
    sums = {key: zeros() for key in keys}
    terminations = env.termination_manager
    failure_terms = [name for name, cfg in terminations.term_cfgs.items() if not cfg.time_out]
    sums.update({f"ended_by/{name}": zeros() for name in failure_terms})
    last_metrics = env.last_episode_metrics  # commands' and metric terms', written in place for the ended envs
    sums.update({f"episode_metric/{key}": zeros() for key in last_metrics})
    episode_steps = zeros()
    falls_by_time = FallsByTime(env.max_episode_length * env.step_dt, FALL_TIME_BIN_S, env.device)
    term_sums = {name: torch.zeros((), device=env.device) for name in env.reward_manager.weights}
    robot = env.scene[env.action_manager.policy_entity_name()]  # the robot the policy drives
    by_speed = ErrorByCommand(SPEED_BIN_EDGES_MPS, env.device)
    by_yaw_rate = ErrorByCommand(YAW_RATE_BIN_EDGES_RADPS, env.device)
    by_height = ErrorByCommand(HEIGHT_BIN_EDGES_M, env.device)
    obs, _ = env.reset()
    command_errors = {}  # the errors the command terms measure themselves (a height command's), by command value
    for term in env.command_manager.terms.values():
        sample = term.command_error()
        if sample is not None:
            command_errors[f"{sample.error_name}_by_{sample.command_name}"] = (
                term, ErrorByCommand(sample.bin_edges, env.device))
    commands = env.command_manager.terms
    by_variant = {name: OutcomesByVariant(term.episode_variants, last_metrics) for name, term in commands.items()
                  if term.episode_variants() is not None}
    spawn_cells = spawn_cell_variants(env.sim)
    if spawn_cells is not None:
        by_variant["terrain_cell"] = OutcomesByVariant(spawn_cells, last_metrics)
    with torch.inference_mode():
        for step in range(num_episodes * env.max_episode_length):
            # each env's first `num_episodes` episodes only: one that falls starts another inside the window, and
            # counting those would count their falls but not the time-outs the window cuts off (over-counting falls)
            counted = sums["episodes"] < num_episodes
            if command_name is not None:
                command = env.command_manager.get_command(command_name).clone()
            obs, reward, terminated, truncated, _ = env.step(policy(obs))
            for recorder in recorders:
                recorder.record(env, step * env.step_dt)
            done, terminated = (terminated | truncated) & counted, terminated & counted
            alive = (~done & counted).float()  # the state of a reset env is its new episode's first state
            if command_name is not None:
                lin_vel_error = torch.linalg.norm(command[:, :2] - robot.root_lin_vel_b[:, :2], dim=1)
                sums["lin_vel_error_mps"] += lin_vel_error * alive
                by_speed.add(torch.linalg.norm(command[:, :2], dim=1), lin_vel_error, alive)
                yaw_rate_error = (command[:, 2] - robot.root_ang_vel_b[:, 2]).abs()
                sums["ang_vel_error_radps"] += yaw_rate_error * alive
                by_yaw_rate.add(command[:, 2].abs(), yaw_rate_error, alive)
            if height_sensor is not None:
                height_error = (command[:, 3] - base_height_above_ground(env, sensor_name=height_sensor)).abs()
                sums["base_height_error_m"] += height_error * alive
                by_height.add(command[:, 3], height_error, alive)
            sums["steps_alive"] += alive
            for term, by_value in command_errors.values():
                sample = term.command_error()
                by_value.add(sample.commanded, sample.error, alive * sample.counted.float())
            for name in term_sums:
                term_sums[name] += env.reward_manager.step_reward[name].sum()
            episode_steps += 1
            sums["ended_length_steps"] += episode_steps * done
            falls_by_time.add(episode_steps * env.step_dt, done, terminated)
            episode_steps.masked_fill_(done | ~counted, 0.0)
            sums["episodes"] += done.float()
            sums["falls"] += terminated.float()
            for name in failure_terms:  # which failure ended the episode (several can at once)
                sums[f"ended_by/{name}"] += (terminations.term_dones[name] & counted).float()
            for key, value in last_metrics.items():
                sums[f"episode_metric/{key}"] += value * done
            for outcomes in by_variant.values():
                outcomes.add(done, terminated, last_metrics)
    by_command = {"lin_vel_error_mps_by_speed_mps": by_speed.rows(),
                  "ang_vel_error_radps_by_yaw_rate_radps": by_yaw_rate.rows()} if command_name is not None else {}
    if height_sensor is not None:
        by_command["base_height_error_m_by_height_m"] = by_height.rows()
    by_command.update({key: by_value.rows() for key, (_, by_value) in command_errors.items()})
    return {"sums": sums, "reward_totals": term_sums, "steps": num_episodes * env.max_episode_length,
            "error_by_command": by_command,
            "episodes_by_variant": {name: outcomes.rows() for name, outcomes in by_variant.items()},
            "falls_by_episode_time_s": falls_by_time.rows()}


def summarise(sums: dict, step_dt: float, mask=None) -> dict:
    """The metrics of the envs in `mask` (all envs if None) from `evaluate_per_env`'s sums."""
    total = {key: float(value.sum() if mask is None else value[mask].sum()) for key, value in sums.items()}
    episodes = max(total["episodes"], 1.0)
    steps_alive = max(total["steps_alive"], 1.0)
    falls_per_env = sums["falls"] if mask is None else sums["falls"][mask]
    metrics = {"episodes": int(total["episodes"]), "falls": int(total["falls"]),
               "fall_rate": total["falls"] / episodes,
               # each env's robot keeps its startup randomisation (masses, gains, ...) for the whole evaluation, and
               # one that cannot walk falls in every episode it is given: how many robots fell, the most falls of one
               "robots_fallen": int((falls_per_env > 0).sum()),
               "robot_fall_rate": float((falls_per_env > 0).float().mean()) if falls_per_env.numel() else 0.0,
               "max_falls_of_one_robot": int(falls_per_env.max()) if falls_per_env.numel() else 0,
               "mean_episode_length_s": total["ended_length_steps"] * step_dt / episodes}
    for key in ("lin_vel_error_mps", "ang_vel_error_radps", "base_height_error_m"):  # what the task commands
        if key in total:
            metrics[key] = total[key] / steps_alive
    # "falls" are the episodes a failure term ended; by term (an episode two terms ended counts for both)
    metrics["falls_by_term"] = {key.split("/", 1)[1]: int(value) for key, value in total.items()
                                if key.startswith("ended_by/")}
    metrics["episode_metrics"] = {key.split("/", 1)[1]: value / episodes for key, value in total.items()
                                  if key.startswith("episode_metric/")}
    return metrics


def evaluate(env, policy, num_episodes: int, command_name: str | None = None, recorders=()) -> dict:
    """Fall rate, episode length and the episode metrics over every env's `num_episodes` episodes; the velocity
    errors (over the steps alive) for a velocity command, the base-height error where it has a height."""
    result = evaluate_per_env(env, policy, num_episodes, command_name, recorders)
    metrics = {"num_envs": env.num_envs, **summarise(result["sums"], env.step_dt)}
    metrics["reward_per_step"] = {name: float(v) / (env.num_envs * result["steps"])
                                  for name, v in result["reward_totals"].items()}
    metrics["error_by_command"] = result["error_by_command"]
    if result["episodes_by_variant"]:
        metrics["episodes_by_variant"] = result["episodes_by_variant"]
    metrics["falls_by_episode_time_s"] = result["falls_by_episode_time_s"]
    return metrics


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
        cli.fail(f"a sweep sets velocity commands; this task has none (commands: {env.command_manager.active_terms})")
    term = env.command_manager.get_term(command_name)
    if len(cells[0]) != term.command.shape[1]:
        cli.fail(f"the sweep gives {len(cells[0])} command values; {command_name} has {term.command.shape[1]} "
                 "(--sweep_base_height is for tasks with a height command)")
    if env.num_envs < len(cells):
        cli.fail(f"the sweep has {len(cells)} cells: use at least that many envs (--num_envs)")
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


def write_sweep(args, env, checkpoint: str, device: str, rows_key: str, rows: list) -> None:
    """A sweep's rows as JSON in --out, with what was evaluated and how."""
    result = {"task": args.task, "checkpoint": checkpoint, "device": device, "num_envs": env.num_envs,
              "episodes_per_env": args.num_episodes, "episode_length_s": args.episode_length_s, rows_key: rows}
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
    print(f"[agile] sweep: {args.out}")


def run_sweep(args, env, policy, checkpoint: str, device: str) -> None:
    rows = sweep(env, policy, args.num_episodes, sweep_cells(args.sweep_lin_vel_x, args.sweep_base_height))
    print(sweep_table(rows))
    if args.out:
        write_sweep(args, env, checkpoint, device, "cells", rows)
        plot_sweep(args.out)


def run_command_sweep(args, env, policy, checkpoint: str, device: str) -> None:
    from agile.run.command_sweep import command_sweep, reward_terms_table, sweep_table as command_sweep_table

    rows = command_sweep(env, policy, args.num_episodes, args.sweep_command)
    print(command_sweep_table(rows))
    print("reward per step where the envs settle (weighted, before dt):")
    print(reward_terms_table(rows))
    if args.out:
        write_sweep(args, env, checkpoint, device, "values", rows)
        plot_sweep(args.out)


def main(argv=None) -> None:
    parser = cli.new_parser(__doc__)
    cli.add_common_args(parser, task_required=False)  # --plot_sweep alone builds nothing
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
    parser.add_argument("--out", default=None, help="write the metrics as JSON here")
    parser.add_argument("--usd", default=None, metavar="PATH.usd", help="record the rollout as an animated USD stage")
    parser.add_argument("--video", default=None, metavar="PATH.mp4", help="render env 0 headless into an mp4")
    cli.add_checkpoint_args(parser)
    args = cli.parse(parser, argv)

    if args.plot_sweep:
        if not os.path.isfile(args.plot_sweep):
            cli.fail(f"--plot_sweep {args.plot_sweep}: no such file")
        plot_sweep(args.plot_sweep)
        return
    if args.task is None:
        parser.error("the following arguments are required: --task")
    if args.sweep_command is not None and (args.sweep_lin_vel_x is not None or args.command is not None):
        cli.fail("--sweep_command holds its own commands: not with --sweep_lin_vel_x or --command")
    if multi_agent.is_multi_agent(args.task):
        multi_agent.eval_main(args)
        return
    checkpoint = args.checkpoint or cli.shipped_policy(args)
    if checkpoint is None:
        cli.fail(f"no --checkpoint given and agile ships no policy for {args.task}")
    contents = cli.read_checkpoint(str(checkpoint), args.trust_checkpoint)
    env_cfg, agent_cfg, device = cli.load_task(args)
    env_cfg = inference_cfg(env_cfg)
    if args.command is not None:
        command = getattr(env_cfg.commands, "base_velocity", None)
        if command is None:
            cli.fail(f"--command sets the base_velocity command; {args.task} has none")
        vx, vy, wz = args.command
        command.ranges.lin_vel_x, command.ranges.lin_vel_y, command.ranges.ang_vel_z = (vx, vx), (vy, vy), (wz, wz)
        command.rel_standing_envs = 0.0
    env_cfg.episode_length_s = args.episode_length_s
    if not args.pushes and env_cfg.events is not None:
        from agile.rl_env.managers import EventTerm

        for name, term in vars(env_cfg.events).items():
            if isinstance(term, EventTerm) and term.mode == "interval":
                setattr(env_cfg.events, name, None)
    env = cli.make_env(args.task, env_cfg, device, use_cache=not args.no_cache)
    from agile.run.recording import UsdRecorder, VideoRecorder

    recorders = []
    if args.usd:
        recorders.append(UsdRecorder(args.usd, env, num_frames=args.num_episodes * env.max_episode_length))
    if args.video:
        recorders.append(VideoRecorder(args.video, env))
    policy = load_policy(contents, env, agent_cfg)
    if args.sweep_command is not None:
        run_command_sweep(args, env, policy, checkpoint, device)
        return
    if args.sweep_lin_vel_x is not None:
        run_sweep(args, env, policy, checkpoint, device)
        return
    metrics = evaluate(env, policy, args.num_episodes, recorders=recorders)
    for recorder in recorders:
        recorder.close()
    metrics.update({"task": args.task, "checkpoint": checkpoint, "device": device, "command": args.command,
                    "episode_length_s": args.episode_length_s, "pushes": args.pushes})
    print(json.dumps(metrics, indent=2))
    if args.out:
        with open(args.out, "w") as f:
            json.dump(metrics, f, indent=2)


if __name__ == "__main__":
    main()
