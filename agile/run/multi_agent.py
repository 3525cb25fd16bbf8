"""train.py and eval.py for multi-agent tasks (`kind: multi_agent`): every agent group trained by its own PPO
in one process, checkpoints per group, evaluation per agent."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from agile.run import task_setup
from agile.errors import AgileError
from agile.run.multi_agent_world import episode_slots, evaluate, evaluation_cfg, make_world


def group_files(specs: list[str] | None, groups, what: str) -> dict[str, str]:
    """{group: file} from GROUP=PATH arguments, checked before anything is built."""
    files = {}
    for spec in specs or []:
        group, sep, path = spec.partition("=")
        if not sep or group not in groups:
            raise AgileError(f"{what} takes GROUP=PATH with GROUP one of {list(groups)}, got '{spec}'")
        if not os.path.isfile(path):
            raise AgileError(f"{what} file not found: {path}")
        files[group] = path
    return files


def run_checkpoints(run_dir: str, groups) -> dict[str, str]:
    """The newest model_<it>.pt of every group in a multi-agent run folder (<run>/<group>/model_<it>.pt)."""
    found = {}
    for group in groups:
        models = sorted(Path(run_dir, group).glob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1]))
        if not models:
            raise AgileError(f"no checkpoint of group '{group}' under {Path(run_dir, group)}")
        found[group] = str(models[-1])
    return found


def check_train_options(options) -> None:
    """Refuse, before anything is built, the `TrainOptions` a multi-agent training does not take."""
    if options.video or options.init_action_std is not None or options.rnn:
        raise AgileError("--video, --init_action_std and --rnn are single-agent options (multi-agent training takes "
                         "--init_policy GROUP=PATH, --resume and --checkpoint RUN_FOLDER)")
    if options.checkpoint:
        check_run_folder(options.checkpoint)
    if (options.resume or options.checkpoint) and options.init_policy:
        raise AgileError("--init_policy starts a new run; it cannot be combined with --resume/--checkpoint")


def latest_run(log_root: str, experiment: str, groups) -> str:
    """The newest run folder of an experiment that holds a checkpoint of every group."""
    runs = sorted(p for p in Path(log_root, experiment).glob("*")
                  if p.is_dir() and all(list((p / g).glob("model_*.pt")) for g in groups))
    if not runs:
        raise AgileError(f"no run with a checkpoint of every group {list(groups)} under {Path(log_root, experiment)}")
    return str(runs[-1])


def train_multi_agent(options, rank):
    """`agile.run.train.train` for a multi-agent task (`options`: its `TrainOptions`): every agent group trained, its
    policy exported; a `TrainResult`."""
    from agile.marl.runner import MultiAgentRunner
    from agile.run.train import run_configs
    from agile.run.train_options import TrainResult
    from agile.rl.checkpoints import restore_runner
    from agile.rl.progress import show_progress
    from agile.rl.rsl_rl_adapter import set_git_status_repos
    from agile.utils.config import ConfigError

    if options.trainer == "happo":
        from agile.run import happo

        return happo.train(options)
    check_train_options(options)
    if rank is not None:
        raise AgileError("--distributed trains single-agent tasks; a multi-agent task trains on one device")
    started_at = options.started_at  # the checkpoints' wall time counts from the train call: imports, world build
    env_cfg, agent_cfg, device = run_configs(options)
    init_files = group_files(options.init_policy, agent_cfg.groups, "--init_policy")
    init_contents = {g: task_setup.read_checkpoint(p, options.trust_checkpoint) for g, p in init_files.items()}
    resume_files = {}
    if options.resume or options.checkpoint:
        run_dir = options.checkpoint or latest_run(options.log_root, agent_cfg.experiment_name, agent_cfg.groups)
        resume_files = run_checkpoints(run_dir, agent_cfg.groups)
    resume_contents = {g: task_setup.read_checkpoint(p, options.trust_checkpoint) for g, p in resume_files.items()}
    world = make_world(options.task, env_cfg, device)
    log_dir = task_setup.new_log_dir(options.log_root, agent_cfg.experiment_name, agent_cfg.run_name)
    task_setup.dump_configs(log_dir, env_cfg, agent_cfg)
    try:
        with task_setup.quiet_stdout():
            runner = MultiAgentRunner(world, agent_cfg, log_dir, str(world.device), started_at=started_at)
    except ConfigError as err:
        raise AgileError(str(err)) from err
    for group, contents in resume_contents.items():
        print(f"[agile] group '{group}': resuming from {resume_files[group]}")
        restore_runner(runner.runners[group], contents)
        runner.runners[group].continue_wall_time(contents)
    if resume_contents:  # the next iteration after the newest group's
        runner.current_learning_iteration = max(c["iter"] for c in resume_contents.values()) + 1
    for group, contents in init_contents.items():
        print(f"[agile] group '{group}': actor initialised from {init_files[group]}")
        restore_runner(runner.runners[group], contents, load_cfg={"actor": True})
    if options.progress == "bar":
        print("[agile] --progress bar: a multi-agent run prints each group's block every iteration instead")
    for group_runner in runner.runners.values():
        set_git_status_repos(group_runner, task_setup.git_repos())
        # rsl-rl's block every iteration; into a file without its terminal escape codes
        show_progress(group_runner, "log", options.full_log_every, sys.stdout.isatty(), agent_cfg.max_iterations)
    runner.learn(agent_cfg.max_iterations)
    export_dir = os.path.join(log_dir, "exported")
    export_groups(runner, export_dir)
    print(f"[agile] logs and checkpoints of each group in {log_dir}/<group>, its exported policy in "
          f"{export_dir}/<group>")
    return TrainResult(log_dir=log_dir, checkpoint=None, exported={"groups": export_dir})


def export_groups(runner, out_dir: str) -> None:
    """policy.pt and policy.onnx of every group; with the IO descriptor of its (first) agent's robot, except for a
    joint group, whose policy drives several robots."""
    from agile.export.io_descriptor import io_descriptor
    from agile.export.policy_files import export_policy
    from agile.rl_env.io_descriptor_file import write_io_descriptor

    for group, view in runner.views.items():
        group_dir = os.path.join(out_dir, group)
        export_policy(runner.runners[group], group_dir)
        if view.mode != "joint":
            write_io_descriptor(os.path.join(group_dir, "io_descriptor.yaml"),
                                io_descriptor(view.env, runner.cfg.groups[group].runner))


def restored_runner(world, agent_cfg, run_dir: str | None, trust: bool):
    """A MultiAgentRunner (no logging) holding every group's newest checkpoint of a training run folder."""
    from agile.marl.runner import MultiAgentRunner
    from agile.rl.checkpoints import restore_runner

    files = run_checkpoints(run_dir, agent_cfg.groups)
    with task_setup.quiet_stdout():
        runner = MultiAgentRunner(world, agent_cfg, None, str(world.device))
    for group, path in files.items():
        restore_runner(runner.runners[group], task_setup.read_checkpoint(path, trust))
    return runner, files


def check_run_folder(checkpoint: str | None) -> str:
    if checkpoint is None or not os.path.isdir(checkpoint):
        raise AgileError(f"--checkpoint of a multi-agent task is a training run folder (<run>/<group>/model_<it>.pt), "
                         f"got {checkpoint}")
    return checkpoint


def run_world(*, task: str, checkpoint: str | None, num_envs: int | None = None, device: str | None = None,
              seed: int | None = None, rnn: str | None = None, overrides=(), episodes: int | None = None,
              num_steps: int | None = None, episode_length_s: float | None = None, pushes: bool = False,
              video: str | None = None, trust_checkpoint: bool = False) -> dict:
    """Run a multi-agent task's trained groups from its training run folder `checkpoint` (per-group PPO or HAPPO;
    None: the folder agile ships for the task) for `episodes` per env (eval) or `num_steps` steps of the world (play);
    per-agent metrics and what was run. `video`: env 0 rendered into this mp4."""
    from agile.run.recorders import VideoRecorder

    from agile.run import happo

    if checkpoint is None:  # the task's shipped folder of group checkpoints, run in its training conditions
        checkpoint, overrides = task_setup.policy_to_run(task=task, checkpoint=None, overrides=overrides)
    run_dir = check_run_folder(checkpoint)
    is_happo_run = happo.newest_checkpoint(run_dir) is not None  # else a run of per-group PPO learners
    env_cfg, agent_cfg, device = task_setup.load_task(task=task, num_envs=num_envs, device=device, seed=seed, rnn=rnn,
                                                      overrides=overrides)
    if episode_length_s is not None:
        env_cfg.episode_length_s = episode_length_s
    if not is_happo_run:
        run_checkpoints(run_dir, agent_cfg.groups)  # a missing group is reported before the build
    world = make_world(task, evaluation_cfg(env_cfg, pushes), device)
    recorders = [VideoRecorder(video, world)] if video else []
    num_slots = episode_slots(world, episodes) if episodes is not None else num_steps
    if is_happo_run:
        metrics, files = happo.evaluate_run(world, run_dir, num_slots, recorders, trust_checkpoint)
    else:
        runner, files = restored_runner(world, agent_cfg, run_dir, trust_checkpoint)
        policies = {view: runner.runners[g].get_inference_policy(device=str(world.device))
                    for g, view in runner.views.items()}
        metrics = evaluate(world, policies, num_slots, recorders)
    for recorder in recorders:
        recorder.close()
        print(f"[agile] video: {recorder.path}")
    if episodes is not None:
        for agent_metrics in metrics.values():
            agent_metrics["episodes"] = episodes * world.num_envs
            agent_metrics["fall_rate"] = agent_metrics["falls"] / (episodes * world.num_envs)
    return {"agents": metrics, "task": task, "checkpoints": files, "device": device,
            "num_envs": world.num_envs, "episode_length_s": world.max_episode_length_s}


def print_agents(metrics: dict) -> None:
    for name, m in metrics["agents"].items():
        by_term = ", ".join(f"{term} {count}" for term, count in m.get("falls_by_term", {}).items() if count)
        print(f"[agile] {name} at {m['control_hz']:g} Hz: falls {m['falls']}" + (f" ({by_term})" if by_term else "")
              + f", linear tracking error {m['lin_vel_error_mps']:.3f} m/s")


def world_options(options) -> dict:
    """`run_world`'s keyword arguments that an eval's or a play's options (`EvalOptions`, `PlayOptions`) share."""
    return dict(task=options.task, checkpoint=options.checkpoint, num_envs=options.num_envs, device=options.device,
                seed=options.seed, rnn=options.rnn, overrides=options.overrides, video=options.video,
                trust_checkpoint=options.trust_checkpoint)


def eval_multi_agent(options) -> dict:
    """`agile eval` for a multi-agent task (`options`: its `EvalOptions`): each agent's summary printed, the metrics
    returned and written as JSON to `out` where given."""
    if any(getattr(options, name) is not None for name in ("command", "sweep_lin_vel_x", "sweep_command", "usd")):
        raise AgileError("--command, the sweeps and --usd are single-agent options (a multi-agent task takes --video)")
    metrics = run_world(**world_options(options), episodes=options.num_episodes,
                        episode_length_s=options.episode_length_s, pushes=options.pushes)
    metrics["pushes"] = options.pushes
    print_agents(metrics)
    if options.out:
        with open(options.out, "w") as f:
            json.dump(metrics, f, indent=2)
        print(f"[agile] metrics: {options.out}")
    return metrics


def play_multi_agent(options) -> dict:
    """`agile play` for a multi-agent task (`options`: its `PlayOptions`): headless, its trained groups, for
    `num_steps` steps; the per-agent metrics."""
    from agile.run.play import DEFAULT_HEADLESS_STEPS

    if options.viewer == "viser" or options.usd or options.sinusoidal:
        raise AgileError("a multi-agent task plays headless with its trained groups (--checkpoint RUN_FOLDER, "
                         "--video); --viewer, --usd and --sinusoidal are single-agent options")
    if options.video_reference:
        raise AgileError("--video_reference: a multi-agent task's commands have no reference pose")
    metrics = run_world(**world_options(options), num_steps=options.num_steps or DEFAULT_HEADLESS_STEPS)
    print_agents(metrics)
    return metrics


def export_multi_agent(options) -> dict:
    """`agile export` for a multi-agent task (`options`: its `ExportOptions`): every group of a training run, as
    TorchScript into <out_dir>/<group>/; {group: its folder}."""
    if options.format != "torchscript":
        raise AgileError(f"--format {options.format}: a multi-agent task exports each group's policy as TorchScript")
    run_dir = check_run_folder(options.checkpoint)
    env_cfg, agent_cfg, device = task_setup.load_task(task=options.task, num_envs=options.num_envs,
                                                      device=options.device, seed=options.seed, rnn=options.rnn,
                                                      overrides=options.overrides)
    world = make_world(options.task, evaluation_cfg(env_cfg, pushes=False), device)
    runner, _ = restored_runner(world, agent_cfg, run_dir, options.trust_checkpoint)
    export_groups(runner, options.out_dir)
    return {group: os.path.join(options.out_dir, group) for group in runner.views}
