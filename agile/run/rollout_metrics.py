"""The evaluation loop and its metrics, shared by `agile eval`, `agile eval_all`, `agile time_to_policy` and the
sweeps: a policy run over every env's first `num_episodes` episodes, on the device, without a host sync per step.

An env whose episode ends early starts another within the window, which is not counted: every env contributes
exactly `num_episodes`. Commands are drawn by the task's command term (uniform over its ranges, a share standing),
unless the caller fixed them. Velocity errors are measured for tasks with a velocity command (also by commanded
planar speed and by commanded |yaw rate|, under "error_by_command"), the height error (commanded minus measured
above the terrain) for those with a base-height command; every task reports its episode metrics as means over the
ended episodes under "episode_metrics": its command terms' (`CommandTerm.metrics`, "<term>/<name>": the motion-tracking
errors, pick-and-place success) and its metric terms' (the env cfg's `metrics`, "<name>": the stand-up success);
a command that draws kinds of episode (pick-and-place: which trajectory) gets episodes, falls and those metrics per
kind under "episodes_by_variant" (by its name), and a task on a terrain grid the same by the cell each episode
spawned on ("terrain_cell": "row <r> col <c> <sub-terrain>"); "falls_by_episode_time_s" counts the ended episodes
and the falls per second of episode time at which they ended; "robots_fallen", "robot_fall_rate" and
"max_falls_of_one_robot" count falls by env (its robot's randomisation is drawn once per run); a command that
measures its own error (`CommandTerm.command_error`: the height-tracking command's) gets it by commanded value under
"error_by_command" ("height_error_m_by_height_m"). Each bin of "error_by_command" holds its mean error, that mean's
standard error over the envs ("error_se": how far a bin's figure may move with another seed), steps and envs.
JSON files written before these were merged have the command terms' under "command_metrics".
"""

from __future__ import annotations

from agile.errors import AgileError
from agile.run.metric_breakdowns import (HEIGHT_BIN_EDGES_M, SPEED_BIN_EDGES_MPS, YAW_RATE_BIN_EDGES_RADPS,
                                       ErrorByCommand, FallsByTime, OutcomesByVariant, spawn_cell_variants)

FALL_TIME_BIN_S = 1.0
"""Width of the bins of `falls_by_episode_time_s`, when in their episodes episodes ended and fell."""


def velocity_command_name(env, command_name: str | None = None) -> str | None:
    """The command whose velocity errors are measured: `command_name`, or the one command term with a velocity
    layout (`CommandTerm.command_fields`); None where the task has none (motion tracking, pick-and-place)."""
    from agile.rl_env.managers.command_manager import VELOCITY_FIELDS

    terms = env.command_manager.terms
    with_velocity = [name for name, term in terms.items() if term.command_fields[:3] == VELOCITY_FIELDS]
    if command_name is not None and command_name not in with_velocity:
        raise AgileError(f"command '{command_name}' is not a velocity command; the task's velocity commands: "
                         f"{with_velocity}")
    if command_name is None and len(with_velocity) > 1:
        raise AgileError(f"the task has several velocity commands {with_velocity}: name the one to evaluate")
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
