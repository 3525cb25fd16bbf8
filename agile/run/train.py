"""Train a task with RSL-RL PPO.

    agile train --task Velocity-T1-v0 --num_envs 4096 --max_iterations 3000
    agile train --task Velocity-T1-v0 --resume            # newest checkpoint of the experiment
    agile train --task Velocity-G1-History-v0 --init_policy agile/data/policy/Velocity-G1-History-v0.pt
    agile train --task Velocity-T1-v0 --init_policy agile/data/policy/Velocity-T1-v0.pt \
        --init_action_std 0.3
    agile train --task Velocity-T1-v0 agent.algorithm.learning_rate=5e-4 env.episode_length_s=20
    agile train --task Velocity-Height-G1-Student-History-v0 \
        --init_policy agile/data/policy/Velocity-Height-G1-Student-History-v0.pt     # distil the shipped student on
    torchrun --standalone --nproc_per_node=2 scripts/train.py --task Velocity-T1-v0 --distributed   # 2 GPUs

Checkpoints, tensorboard logs and the resolved configs go to logs/rsl_rl/<experiment>/<time>_<run>/ (with
--distributed: rank 0's; every rank runs --num_envs envs on cuda:LOCAL_RANK with seed + rank).
"""

from __future__ import annotations

import math
import os
import sys
from functools import partial

from agile.run import common as cli

from agile.run import multi_agent


def set_learning_rate(algorithm, learning_rate: float) -> None:
    """The PPO algorithm's learning rate, as its adaptive schedule sets it (the attribute and every group). A
    group's learning rate held as a tensor (the sync-free update adapts it on the device) is written in place."""
    import torch

    algorithm.learning_rate = learning_rate
    for group in algorithm.optimizer.param_groups:
        if isinstance(group["lr"], torch.Tensor):
            group["lr"].fill_(learning_rate)
        else:
            group["lr"] = learning_rate


def warm_up_critic(runner, iterations: int, learning_rate: float) -> None:
    """Train `iterations` PPO iterations at `learning_rate` with the actor's weights held (its gradients off;
    Adam skips weights without one, and the actor's unchanged outputs leave the adaptive learning rate as it
    is): only the critic learns the returns of the policy it will judge. PPO then starts at the algorithm's
    own learning rate."""
    actor, ppo_learning_rate = runner.alg.get_policy(), runner.alg.learning_rate
    print(f"[agile] critic warm-up: {iterations} iterations with the actor held, learning rate {learning_rate:g}")
    actor.requires_grad_(False)
    set_learning_rate(runner.alg, learning_rate)
    runner.learn(num_learning_iterations=iterations, init_at_random_ep_len=True)
    runner.current_learning_iteration += 1  # RSL-RL leaves the counter on the last iteration done
    actor.requires_grad_(True)
    set_learning_rate(runner.alg, ppo_learning_rate)


def learn_with_clips(runner, args, env_cfg, device: str, log_dir: str, iterations: int,
                     random_episode_starts: bool = True) -> None:
    """Train in chunks of --video_interval iterations, recording a clip of the current policy after each."""
    import copy

    import torch
    from agile.run.policy import inference_cfg
    from agile.run.recording import VideoRecorder

    from agile.rl import flatten_groups

    record = log_dir is not None  # distributed: the other ranks learn the same chunks and record nothing
    if record:
        video_cfg = inference_cfg(copy.deepcopy(env_cfg))
        video_cfg.num_envs = 1
        video_env = cli.make_env(args.task, video_cfg, device, use_cache=not args.no_cache)
        os.makedirs(os.path.join(log_dir, "videos"), exist_ok=True)
    done = 0
    while done < iterations:
        chunk = min(args.video_interval, iterations - done)
        runner.learn(num_learning_iterations=chunk, init_at_random_ep_len=random_episode_starts and done == 0)
        # RSL-RL leaves the counter on the last iteration done; the next chunk starts one later
        runner.current_learning_iteration += 1
        done += chunk
        if not record:
            continue
        policy = runner.get_inference_policy(device=str(video_env.device))
        # a recurrent actor holds the rollout's hidden state (a row per training env): set it aside for the clip
        training_hidden_state = policy.get_hidden_state()
        policy.reset()
        path = os.path.join(log_dir, "videos", f"iteration_{done}.mp4")
        recorder = VideoRecorder(path, video_env)
        obs, _ = video_env.reset()
        with torch.inference_mode():
            for _ in range(args.video_length):
                obs, _, terminated, truncated, _ = video_env.step(policy(flatten_groups(obs)))
                policy.reset(terminated | truncated)
                recorder.record(video_env)
        recorder.close()
        policy.reset(hidden_state=training_hidden_state)
        print(f"[agile] clip: {path}")
    if record:
        video_env.close()


def distributed_rank(args):
    """This process's rank when torchrun started it (with --distributed), else None; sets args.device to its own."""
    from agile.rl.distributed import make_current, rank_device, rank_from_env

    rank = rank_from_env()
    if rank is None:
        if args.distributed:
            cli.fail("--distributed: start the processes with torchrun (WORLD_SIZE is unset or 1), e.g. "
                     "torchrun --standalone --nproc_per_node=2 scripts/train.py --task ... --distributed")
        return None
    if not args.distributed:
        cli.fail(f"WORLD_SIZE={rank.world_size} (torchrun) without --distributed: add --distributed to train "
                 f"data-parallel")
    try:
        args.device = rank_device(rank, args.device)
    except ValueError as err:
        cli.fail(str(err))
    make_current(args.device)
    return rank


def check_rank_weights(runner, rank) -> None:
    """Every rank prints the digest of its weights; all must agree (rsl-rl broadcasts rank 0's at the start and
    all-reduces every gradient, so a difference means the ranks fell out of step)."""
    import torch

    from agile.rl.algorithms.captured_update import CapturedUpdate
    from agile.rl.distributed import gather_digests, weights_digest

    digest = weights_digest(runner.alg.save())
    print(f"[agile] rank {rank.rank}: weights sha256 {digest}", flush=True)
    digests = gather_digests(digest)
    if isinstance(runner.alg, CapturedUpdate):
        runner.alg.release_graph()  # a live graph with NCCL kernels in it makes the destroy below hang
    torch.distributed.destroy_process_group()
    if len(set(digests)) != 1:
        cli.fail(f"the {rank.world_size} ranks ended with different weights (sha256 by rank: {digests})")
    if rank.is_main:
        print(f"[agile] all {rank.world_size} ranks hold the same weights", flush=True)


def as_policy_checkpoint(checkpoint: dict, path: str, state_key: str) -> dict:
    """The --init_policy checkpoint (contents of `path`) with its policy under `state_key`, where the run's algorithm
    loads it (`policy_state_key`). PPO ("actor_state_dict"): a PPO checkpoint as it is, a distilled student's
    "student_state_dict" as the actor (fine-tuning by PPO). Distillation ("student_state_dict"): a distilled
    student's checkpoint or shipped file (its distillation goes on)."""
    if state_key in checkpoint:
        return checkpoint
    if state_key == "student_state_dict":
        cli.fail(f"--init_policy {path}: a distilled task's student starts from a distilled student (its "
                 f"student_state_dict); the file holds {sorted(checkpoint)}")
    if "student_state_dict" not in checkpoint:
        cli.fail(f"--init_policy {path}: no actor_state_dict or student_state_dict in it (it holds "
                 f"{sorted(checkpoint)})")
    return {state_key: checkpoint["student_state_dict"], "iter": checkpoint.get("iter", 0),
            "infos": checkpoint.get("infos")}


def initial_policy_checkpoint(checkpoint: dict, path: str, state_key: str, log_dir: str,
                              action_std: float | None) -> dict:
    """The --init_policy checkpoint (`as_policy_checkpoint`'s) copied into the run's folder as init_policy.pt (where
    the run started stays with it), with the policy's action noise set to `action_std` when given."""
    import torch

    if action_std is not None:
        policy = checkpoint[state_key]
        if "distribution.std_param" in policy:
            policy["distribution.std_param"] = torch.full_like(policy["distribution.std_param"], action_std)
        elif "distribution.log_std_param" in policy:
            policy["distribution.log_std_param"] = torch.full_like(policy["distribution.log_std_param"],
                                                                   math.log(action_std))
        else:
            cli.fail(f"--init_action_std: the policy in {path} has no state-independent std to reset")
        print(f"[agile] action noise reset to std {action_std}")
    if log_dir is not None:
        torch.save(checkpoint, os.path.join(log_dir, "init_policy.pt"))
    return checkpoint


def shipped_init_policy(task: str, agent_cfg) -> str | None:
    """A fine-tuning task's default --init_policy: the shipped policy of its `init_policy_task` (None for the
    other tasks)."""
    import agile.tasks

    source_task = getattr(agent_cfg, "init_policy_task", None)
    if not source_task:
        return None
    path = agile.tasks.pretrained_policy(source_task)
    if path is None:
        cli.fail(f"{task} fine-tunes the policy of {source_task}, and agile ships none: train {source_task} first "
                 f"and give --init_policy PATH (its model_<it>.pt)")
    print(f"[agile] {task} fine-tunes {source_task}: the actor starts from its shipped policy {path}")
    return str(path)


def distillation_teacher(args, agent_cfg, resuming: bool) -> str | None:
    """The teacher file of a distillation run (None for PPO, and when resuming: the checkpoint holds it)."""
    import agile.tasks
    from agile.rl import is_distillation

    if not is_distillation(agent_cfg):
        if args.teacher:
            cli.fail(f"--teacher: {args.task} is trained by PPO, not distilled from a teacher")
        return None
    if resuming:
        return None
    path = args.teacher or agile.tasks.pretrained_policy(agent_cfg.teacher_task)
    if path is None:
        cli.fail(f"{args.task} distils the policy of {agent_cfg.teacher_task}, and agile ships none: train it "
                 f"first and give --teacher PATH (its model_<it>.pt or exported/policy.pt)")
    if not os.path.isfile(path):
        cli.fail(f"--teacher file not found: {path}")
    return str(path)


def main(argv=None) -> None:
    parser = cli.new_parser(__doc__)
    cli.add_common_args(parser)
    cli.add_recipe_arg(parser)
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
    parser.add_argument("--logger", choices=["tensorboard", "wandb", "neptune"], default=None,
                        help="where rsl-rl logs the training (default: the task's agent config, tensorboard)")
    parser.add_argument("--run_name", default=None, help="suffix of the log folder")
    parser.add_argument("--log_root", default=os.path.join("logs", "rsl_rl"),
                        help="folder of the runs, <log_root>/<experiment>/<time>_<run name>/")
    parser.add_argument("--video", action="store_true", help="record a clip of the policy every --video_interval "
                        "iterations into <log dir>/videos (a separate 1-env world, rendered headless)")
    parser.add_argument("--video_interval", type=int, default=500, help="iterations between clips")
    parser.add_argument("--video_length", type=int, default=200, help="env steps per clip")
    parser.add_argument("--inject_nan_actions", type=float, nargs=2, default=None, metavar=("SHARE", "EVERY"),
                        help="reliability runs: NaN actions for a SHARE of the envs (e.g. 0.01) at the start of every "
                        "EVERY-th iteration; the env ends and counts them (Episode_Termination/invalid_action)")
    parser.add_argument("--progress", choices=["auto", "bar", "log"], default="auto",
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
    cli.add_checkpoint_args(parser)
    args = cli.parse(parser, argv)
    rank = distributed_rank(args)

    multi_agent_task = multi_agent.is_multi_agent(args.task)
    if multi_agent_task:
        multi_agent.check_train_args(args)
        if rank is not None:
            cli.fail("--distributed trains single-agent tasks; a multi-agent task trains on one device")
    env_cfg, agent_cfg, device = cli.load_task(args)
    if rank is not None:
        env_cfg.seed += rank.rank
        agent_cfg.seed += rank.rank
        print(f"[agile] rank {rank.rank} of {rank.world_size} on {device}, seed {env_cfg.seed}", flush=True)
    if args.max_iterations is not None:
        agent_cfg.max_iterations = args.max_iterations
    if args.logger is not None:
        agent_cfg.logger = args.logger
    if args.run_name is not None:
        agent_cfg.run_name = args.run_name
    if multi_agent_task:
        multi_agent.train(args, env_cfg, agent_cfg, device)
        return
    if args.init_policy is not None:
        if len(args.init_policy) != 1:
            cli.fail(f"--init_policy takes one checkpoint for a single-agent task, got {args.init_policy}")
        args.init_policy = args.init_policy[0]
    resume_path = None
    if args.resume or args.checkpoint:
        resume_path = args.checkpoint or cli.latest_checkpoint(args.log_root, agent_cfg.experiment_name)
        if not os.path.isfile(resume_path):
            cli.fail(f"checkpoint not found: {resume_path}")
    if args.init_policy and resume_path:
        cli.fail("--init_policy starts a new run; it cannot be combined with --resume/--checkpoint")
    # read before the env is built: a file that is missing or would run code is refused at once
    resume_contents = cli.read_checkpoint(resume_path, args.trust_checkpoint) if resume_path else None
    if resume_contents is not None:
        cli.warn_overrides_not_repeated(resume_contents, {"env": env_cfg, "agent": agent_cfg},
                                        "continue the training it was in")
    if args.init_policy is None and resume_path is None:
        args.init_policy = shipped_init_policy(args.task, agent_cfg)
    if args.init_policy and not os.path.isfile(args.init_policy):
        cli.fail(f"--init_policy file not found: {args.init_policy}")
    if args.init_action_std is not None and (not args.init_policy or not args.init_action_std > 0):
        cli.fail("--init_action_std needs --init_policy and a positive value "
                 "(a new run's initial std is agent.actor.distribution_cfg.init_std)")
    from agile.rl import policy_obs_set, policy_state_key

    init_contents = None
    if args.init_policy:  # refused before the env is built when it holds no policy
        init_contents = as_policy_checkpoint(cli.read_checkpoint(args.init_policy, args.trust_checkpoint),
                                             args.init_policy, policy_state_key(agent_cfg))
    teacher_path = distillation_teacher(args, agent_cfg, resuming=resume_path is not None)
    if args.inject_nan_actions is not None:
        share, every = args.inject_nan_actions
        if not (0.0 < share <= 1.0 and every >= 1 and every == int(every)):
            cli.fail(f"--inject_nan_actions SHARE EVERY: SHARE within (0, 1], EVERY a whole number >= 1; got "
                     f"{share:g} {every:g}")

    from agile.rl.checkpoints import restore_runner
    from agile.rl.runner import training_runner
    from agile.rl.progress import show_progress
    from agile.rl.algorithms.distillation import load_teacher
    from agile.rl.rsl_rl_adapter import set_git_status_repos
    from agile.rl.algorithms.reward_normalization import starts_normalizing

    env = cli.make_env(args.task, env_cfg, device, use_cache=not args.no_cache)
    print(f"[agile] {args.task}: {env.num_envs} envs on {device}, "
          f"obs {env.observation_manager.group_dims}, actions {env.action_manager.total_action_dim}")
    log_dir = None  # distributed: rank 0 writes the logs, checkpoints and exports
    if rank is None or rank.is_main:
        log_dir = cli.new_log_dir(args.log_root, agent_cfg.experiment_name, agent_cfg.run_name)
        cli.dump_configs(log_dir, env_cfg, agent_cfg)
    wrap = None
    if args.inject_nan_actions is not None:
        from agile.rl.fault_injection import NanActionVecEnv

        share, every = args.inject_nan_actions
        wrap = partial(NanActionVecEnv, share=share, every_iterations=int(every),
                       steps_per_iteration=agent_cfg.num_steps_per_env)
    with cli.quiet_stdout():
        runner = training_runner(env, agent_cfg, log_dir, wrap, overrides=args.overrides)
    print(f"[agile] algorithm: {type(runner.alg).__name__}")  # e.g. L2C2SyncFreeUpdatePPO: extensions too
    set_git_status_repos(runner, cli.git_repos())
    if log_dir is not None:
        show_progress(runner, args.progress, args.full_log_every, sys.stdout.isatty(), agent_cfg.max_iterations)
    if resume_path:
        print(f"[agile] resuming from {resume_path}")
        restore_runner(runner, resume_contents)  # loaded on the CPU: a GPU run can be resumed on another device
        env_state = (resume_contents.get("infos") or {}).get("env_state")
        if env_state is not None:  # step counter (reward-weight ramps) and terrain levels
            try:
                env.load_training_state(env_state)
            except ValueError as err:  # a checkpoint of another env (terrain, curriculum terms, env count)
                cli.fail(f"--checkpoint {resume_path}: {err}")
        else:
            print("[agile] the checkpoint holds no env state (an older checkpoint): curricula start over")
        print(f"[agile] continuing at iteration {runner.current_learning_iteration}")
    if teacher_path:
        print(f"[agile] teacher: {teacher_path}")
        try:
            load_teacher(runner, teacher_path, trust=args.trust_checkpoint)
        except ValueError as err:
            cli.fail(str(err))
    if args.init_policy:
        print(f"[agile] {policy_obs_set(agent_cfg)} initialised from {args.init_policy}")
        start = initial_policy_checkpoint(init_contents, args.init_policy, policy_state_key(agent_cfg), log_dir,
                                          args.init_action_std)
        restore_runner(runner, start, load_cfg={policy_obs_set(agent_cfg): True})
    iterations, warmup = agent_cfg.max_iterations, 0
    rescaled = starts_normalizing(agent_cfg, resume_contents)
    if rescaled:
        print("[agile] the checkpoint was trained without reward normalisation: its statistics start afresh, and the "
              "critic learned returns of another scale (critic_warmup_iterations applies)")
    if args.init_policy or rescaled:
        warmup = min(getattr(agent_cfg, "critic_warmup_iterations", 0), iterations)
    if warmup > 0:
        warm_up_critic(runner, warmup, agent_cfg.critic_warmup_learning_rate)
        iterations -= warmup
    if args.video:
        learn_with_clips(runner, args, env_cfg, device, log_dir, iterations, random_episode_starts=warmup == 0)
    elif iterations > 0:
        runner.learn(num_learning_iterations=iterations, init_at_random_ep_len=warmup == 0)
    if rank is not None:
        check_rank_weights(runner, rank)
    if log_dir is not None:
        from agile.run.export import export

        paths = export(args.task, env, agent_cfg, runner, os.path.join(log_dir, "exported"))
        print(f"[agile] logs and checkpoints in {log_dir}; exported policy in {os.path.dirname(paths['jit'])}")
    env.close()


if __name__ == "__main__":
    main()
