"""Train a task with RSL-RL PPO.

    agile train --task Velocity-T1-v0 --num_envs 4096 --max_iterations 3000
    agile train --task Velocity-T1-v0 --resume            # newest checkpoint of the experiment
    agile train --task Velocity-G1-History-v0 --init_policy agile/data/policy/Velocity-G1-History-v0.pt
    agile train --task Velocity-T1-v0 --init_policy agile/data/policy/Velocity-T1-v0.pt \\
        --init_action_std 0.3
    agile train --task Velocity-T1-v0 agent.algorithm.learning_rate=5e-4 env.episode_length_s=20
    agile train --task Velocity-Height-G1-Student-History-v0 \\
        --init_policy agile/data/policy/Velocity-Height-G1-Student-History-v0.pt     # distil the shipped student on
    torchrun --standalone --nproc_per_node=2 scripts/train.py --task Velocity-T1-v0 --distributed   # 2 GPUs
    agile train --task MultiRate-G1-T1-Velocity-v0 --trainer happo   # HARL's HAPPO (pip install 'agile[harl]')

Checkpoints, tensorboard logs and the resolved configs go to logs/rsl_rl/<experiment>/<time>_<run>/ (with
--distributed: rank 0's; every rank runs --num_envs envs on cuda:LOCAL_RANK with seed + rank).
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from functools import partial
from pathlib import Path

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError

from agile.run.task_kinds import run_command
from agile.run.train_options import DEFAULT_LOG_ROOT, TrainOptions, TrainResult
from agile.run.training_iterations import learn
from agile.run.training_start import check_rank_weights, distributed_rank, restore_start, starting_point

PROGRESS_MODES = ("auto", "bar", "log")
"""`agile.rl.progress.PROGRESS_MODES`, named here so that --help does not import the simulator."""
LOGGERS = ("tensorboard", "wandb", "neptune")
TRAINERS = ("rsl_rl", "happo")
"""rsl_rl: RSL-RL's PPO (per agent group on a multi-agent task); happo: HARL's HAPPO on a multi-agent task
(`agile.marl.harl`, the extra agile[harl])."""
MANY_CPU_ENVS = 256
"""Above this env count a CPU training is told that it is slow and how to make it fast."""


def train(*, task: str, num_envs: int | None = None, device: str | None = None, seed: int | None = None,
          rnn: str | None = None, overrides=(), max_iterations: int | None = None, resume: bool = False,
          checkpoint: str | None = None, init_policy=(), init_action_std: float | None = None,
          logger: str | None = None, run_name: str | None = None, log_root: str = DEFAULT_LOG_ROOT,
          video: bool = False, video_interval: int = 500, video_length: int = 200,
          inject_nan_actions: tuple | None = None, progress: str = "auto", full_log_every: int = 100,
          teacher: str | None = None, distributed: bool = False, trust_checkpoint: bool = False,
          collect_datasets_anew: bool = False, trainer: str = "rsl_rl") -> TrainResult:
    """Train `task` with RSL-RL (PPO, or distillation for a distilled task) and export the policy at the end; a
    multi-agent task with `trainer` "happo": HARL's HAPPO (`agile.run.happo`).

    The env and agent configs are the task's with `overrides` ("env.<path>=<value>", "agent.<path>=<value>"), `seed`,
    `rnn` ("lstm" | "gru") and `max_iterations` applied; `num_envs` None: the task's on a GPU, 4 on a CPU. A run starts
    afresh, from `init_policy` (a checkpoint's actor weights; a multi-agent task: "GROUP=PATH" each), or continues
    (`resume`: the newest checkpoint of the experiment under `log_root`, or `checkpoint`). Checkpoints, logs and the
    resolved configs go to <log_root>/<experiment>/<time>_<run_name>/. `progress`: "bar" | "log" (rsl-rl's block every
    iteration) | "auto" (the bar on a terminal). Raises AgileError for what it refuses (the field and its valid values
    named), before anything is built; Ctrl-C saves a checkpoint of where the run was before it ends the run."""
    started_at = time.time()  # before the imports the run needs: the user waits for them too
    task_setup.check_task(task)
    options = TrainOptions(
        task=task, num_envs=num_envs, device=device, seed=seed, rnn=rnn, overrides=tuple(overrides),
        max_iterations=max_iterations, resume=resume, checkpoint=checkpoint,
        init_policy=(init_policy,) if isinstance(init_policy, str) else tuple(init_policy),
        init_action_std=init_action_std, logger=logger, run_name=run_name, log_root=log_root, video=video,
        video_interval=video_interval, video_length=video_length, inject_nan_actions=inject_nan_actions,
        progress=progress, full_log_every=full_log_every, teacher=teacher, distributed=distributed,
        trust_checkpoint=trust_checkpoint, collect_datasets_anew=collect_datasets_anew, trainer=trainer,
        started_at=started_at)
    check_options(options)
    check_trainer(options)
    rank, rank_device = distributed_rank(options)
    return run_command("train", task, dataclasses.replace(options, device=rank_device), rank)


def run_configs(options: TrainOptions, rank=None) -> task_setup.TaskConfigs:
    """The run's env and agent configs and device (`task_setup.load_task`), with the options that set agent config
    fields applied and, on a distributed run, this rank's seed (the seed + the rank)."""
    env_cfg, agent_cfg, device = task_setup.load_task(task=options.task, num_envs=options.num_envs,
                                                      device=options.device, seed=options.seed, rnn=options.rnn,
                                                      overrides=options.overrides, trainer=options.trainer)
    if rank is not None:
        env_cfg.seed += rank.rank
        agent_cfg.seed += rank.rank
        print(f"[agile] rank {rank.rank} of {rank.world_size} on {device}, seed {env_cfg.seed}", flush=True)
    for name in ("max_iterations", "logger", "run_name"):
        if getattr(options, name) is not None:
            setattr(agent_cfg, name, getattr(options, name))
    return task_setup.TaskConfigs(env_cfg, agent_cfg, device)


def check_options(options: TrainOptions) -> None:
    """Refuse, before anything is built, options that cannot go together or hold no valid value."""
    if options.progress not in PROGRESS_MODES:
        raise AgileError(f"progress must be one of {', '.join(PROGRESS_MODES)}, got {options.progress!r}")
    if options.logger not in (None, *LOGGERS):
        raise AgileError(f"logger must be one of {', '.join(LOGGERS)} (or None: the task's), got {options.logger!r}")
    if options.max_iterations is not None and options.max_iterations < 1:
        raise AgileError(f"max_iterations must be at least 1, got {options.max_iterations}")
    task_setup.check_writable(options.log_root, "log_root")
    if options.inject_nan_actions is not None:
        share, every = options.inject_nan_actions
        if not (0.0 < share <= 1.0 and every >= 1 and every == int(every)):
            raise AgileError(f"inject_nan_actions (SHARE, EVERY): SHARE within (0, 1], EVERY a whole number >= 1; got "
                             f"{share:g} {every:g}")


def check_trainer(options: TrainOptions) -> None:
    """Refuse, before anything is built, a trainer that cannot train the task, is not installed, or an option it does
    not take."""
    import importlib.util

    import agile.tasks

    trainer = options.trainer
    if trainer not in TRAINERS:
        raise AgileError(f"--trainer must be one of {', '.join(TRAINERS)}, got {trainer!r}")
    if trainer == "rsl_rl":
        return
    kind = agile.tasks.task_kind(options.task)
    if kind != "multi_agent":
        raise AgileError(f"--trainer {trainer}: needs a multi-agent task; {options.task} is {kind}")
    trainers = agile.tasks.task_spec(options.task).trainer_cfgs
    if trainer not in trainers:
        raise AgileError(f"--trainer {trainer}: {options.task} has no {trainer} config (it trains with: "
                         f"{', '.join(['rsl_rl', *trainers])})")
    if importlib.util.find_spec("harl") is None:
        raise AgileError(f"--trainer {trainer} needs HARL's HAPPO (the package harl-aht): pip install 'agile[harl]'")
    given = [f"--{name}" for name in ("resume", "checkpoint", "init_policy", "init_action_std", "rnn", "video",
                                      "teacher", "distributed", "inject_nan_actions") if getattr(options, name)]
    if given:
        raise AgileError(f"--trainer {trainer} trains a new run (--num_envs, --seed, --max_iterations, --log_root, "
                         f"--run_name, agent.* overrides of its config); it does not take {', '.join(given)}")


def build_runner(options: TrainOptions, env, agent_cfg, log_dir: str | None, started_at: float | None = None):
    """The training runner over `env` (NaN actions injected where asked; on a CPU the first env step is timed);
    `started_at` (time.time()): when the run started."""
    from agile.rl.runner import training_runner
    from agile.rl.progress import show_progress
    from agile.rl.rsl_rl_adapter import set_git_status_repos

    wrap = None
    if options.inject_nan_actions is not None:
        from agile.rl.fault_injection import NanActionVecEnv

        share, every = options.inject_nan_actions
        wrap = partial(NanActionVecEnv, share=share, every_iterations=int(every),
                       steps_per_iteration=agent_cfg.num_steps_per_env)
    elif str(env.device) == "cpu":
        from agile.run.first_step_timing import FirstStepTimingVecEnv

        wrap = partial(FirstStepTimingVecEnv, steps_per_iteration=agent_cfg.num_steps_per_env)
    with task_setup.quiet_stdout():
        runner = training_runner(env, agent_cfg, log_dir, wrap, overrides=list(options.overrides),
                                 started_at=started_at)
    print(f"[agile] algorithm: {type(runner.alg).__name__}")  # its extensions in the name
    set_git_status_repos(runner, task_setup.git_repos())
    if log_dir is not None:
        show_progress(runner, options.progress, options.full_log_every, sys.stdout.isatty(), agent_cfg.max_iterations)
    return runner


def warn_many_envs_on_cpu(num_envs: int, device: str) -> None:
    """Before a CPU build of many envs: it is slow, the first env step will say how slow, and fewer envs are fast."""
    if device == "cpu" and num_envs > MANY_CPU_ENVS:
        print(f"[agile] {num_envs} envs on a CPU: the build and every iteration grow with the env count (the first env "
              f"step says how long an iteration takes here); a GPU trains thousands of envs, a CPU run is quicker with "
              f"--num_envs 64 or fewer", flush=True)


def save_interrupted(runner, log_dir: str | None) -> str | None:
    """After Ctrl-C: a checkpoint of the weights as the interruption found them (model_<iteration>.pt); None where
    the run writes none (a distributed run's other ranks)."""
    if log_dir is None:
        return None
    path = os.path.join(log_dir, f"model_{runner.current_learning_iteration}.pt")
    runner.save(path)
    return path


def train_single_agent(options: TrainOptions, rank) -> TrainResult:
    """`train` for every kind but multi-agent (`agile.run.task_kinds`)."""
    env_cfg, agent_cfg, device = run_configs(options, rank)
    start = starting_point(options, agent_cfg)
    if start["resume_contents"] is not None:
        task_setup.warn_overrides_not_repeated(start["resume_contents"], {"env": env_cfg, "agent": agent_cfg},
                                               "continue the training it was in")
    warn_many_envs_on_cpu(env_cfg.num_envs, device)
    env = task_setup.make_env(task=options.task, env_cfg=env_cfg, device=device,
                              collect_datasets_anew=options.collect_datasets_anew)
    print(f"[agile] {options.task}: {task_setup.plural(env.num_envs, 'env')} on {device}, "
          f"obs {env.observation_manager.group_dims}, actions {env.action_manager.total_action_dim}")
    log_dir = None  # distributed: rank 0 writes the logs, checkpoints and exports
    if rank is None or rank.is_main:
        log_dir = task_setup.new_log_dir(options.log_root, agent_cfg.experiment_name, agent_cfg.run_name)
        task_setup.dump_configs(log_dir, env_cfg, agent_cfg)
    runner = build_runner(options, env, agent_cfg, log_dir, options.started_at)
    restore_start(runner, env, agent_cfg, start, options, log_dir)
    try:
        learn(runner, env_cfg, agent_cfg, device, options, log_dir, start)
    except KeyboardInterrupt:
        saved = save_interrupted(runner, log_dir)
        print(f"\n[agile] training interrupted at iteration {runner.current_learning_iteration}"
              + (f": its weights saved in {saved} (--checkpoint to continue from it)" if saved else ""), flush=True)
        raise
    if rank is not None:
        check_rank_weights(runner, rank)
    exported = {}
    if log_dir is not None:
        from agile.run.export import export

        exported = export(options.task, env, agent_cfg, runner, os.path.join(log_dir, "exported"))
        print(f"[agile] logs and checkpoints in {log_dir}; exported policy in {os.path.dirname(exported['jit'])}")
    env.close()
    checkpoints = sorted(Path(log_dir).glob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1])) if log_dir else []
    return TrainResult(log_dir=log_dir, checkpoint=str(checkpoints[-1]) if checkpoints else None, exported=exported)


def build_parser():
    parser = arguments.new_parser(__doc__)
    arguments.add_common_args(parser)
    arguments.add_recipe_arg(parser)
    parser.add_argument("--max_iterations", type=int, default=None,
                        help="PPO iterations to run (default: the task's); with --resume, iterations after the "
                             "checkpoint's")
    parser.add_argument("--resume", action="store_true", help="continue from a checkpoint (--checkpoint or newest)")
    parser.add_argument("--checkpoint", default=None, help="checkpoint file to resume from")
    parser.add_argument("--init_policy", default=None, action="append", metavar="PATH",
                        help="start a new run from this checkpoint's actor weights only (fresh critic, optimizer and "
                        "iteration count), e.g. a shipped policy to fine-tune on a changed task; a distilled task's "
                        "student from a distilled student's weights (its distillation goes on); for a multi-agent "
                        "task GROUP=PATH, once per agent group to initialise")
    parser.add_argument("--init_action_std", type=float, default=None, metavar="STD",
                        help="with --init_policy: reset the actor's action noise to STD (in action units), e.g. to "
                        "explore again when fine-tuning a converged policy on a harder task")
    parser.add_argument("--logger", choices=LOGGERS, default=None,
                        help="where rsl-rl logs the training (default: the task's agent config, tensorboard)")
    parser.add_argument("--run_name", default=None, help="suffix of the log folder")
    parser.add_argument("--log_root", default=DEFAULT_LOG_ROOT,
                        help="folder of the runs, <log_root>/<experiment>/<time>_<run name>/")
    parser.add_argument("--video", action="store_true", help="record a clip of the policy every --video_interval "
                        "iterations into <log dir>/videos (a separate 1-env world, rendered headless)")
    parser.add_argument("--video_interval", type=int, default=500, help="iterations between clips")
    parser.add_argument("--video_length", type=int, default=200, help="env steps per clip")
    parser.add_argument("--inject_nan_actions", type=float, nargs=2, default=None, metavar=("SHARE", "EVERY"),
                        help="reliability runs: NaN actions for a SHARE of the envs (e.g. 0.01) at the start of every "
                        "EVERY-th iteration; the env ends and counts them (Episode_Termination/invalid_action)")
    parser.add_argument("--progress", choices=PROGRESS_MODES, default="auto",
                        help="bar: one line with the ETA, mean reward and episode length, rsl-rl's full block every "
                        "--full_log_every iterations; log: the full block every iteration; auto (default): bar on a "
                        "terminal, log otherwise (log files)")
    parser.add_argument("--full_log_every", type=int, default=100, metavar="N",
                        help="with the bar: rsl-rl's full block every N iterations (0: never)")
    parser.add_argument("--teacher", default=None, metavar="PATH",
                        help="distillation tasks: the teacher, a PPO checkpoint of the teacher task or its TorchScript "
                        "export (default: the policy agile ships for the teacher task)")
    parser.add_argument("--distributed", action="store_true",
                        help="data-parallel over the processes torchrun starts (one per GPU; --device cpu: gloo on "
                        "CPU processes): each rank its own --num_envs envs and seed + rank, logs on rank 0")
    parser.add_argument("--trainer", choices=TRAINERS, default="rsl_rl",
                        help="rsl_rl: RSL-RL's PPO (a multi-agent task: per agent group); happo: HARL's HAPPO on a "
                        "multi-agent task, one actor per agent and a centralised critic (pip install 'agile[harl]')")
    arguments.add_checkpoint_args(parser)
    return parser


@command
def main(argv=None) -> None:
    args = arguments.parse(build_parser(), argv)
    train(task=args.task, num_envs=args.num_envs, device=args.device, seed=args.seed, rnn=args.rnn,
          overrides=args.overrides, max_iterations=args.max_iterations, resume=args.resume, checkpoint=args.checkpoint,
          init_policy=args.init_policy or (), init_action_std=args.init_action_std, logger=args.logger,
          run_name=args.run_name, log_root=args.log_root, video=args.video, video_interval=args.video_interval,
          video_length=args.video_length, inject_nan_actions=args.inject_nan_actions,
          progress=args.progress, full_log_every=args.full_log_every, teacher=args.teacher,
          distributed=args.distributed, trust_checkpoint=args.trust_checkpoint, collect_datasets_anew=args.no_cache,
          trainer=args.trainer)


if __name__ == "__main__":
    main()
