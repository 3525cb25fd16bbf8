"""Where a training run starts: the rank of a distributed run, a checkpoint resumed, an initial policy's actor, a
distillation's teacher; each file read and checked before the env is built."""

from __future__ import annotations

import math
import os

from agile.errors import AgileError
from agile.run import task_setup
from agile.run.train_options import TrainOptions


def distributed_rank(options: TrainOptions):
    """(this process's rank when torchrun started it (with --distributed), else None; the device it trains on)."""
    from agile.rl.distributed import make_current, rank_device, rank_from_env

    rank = rank_from_env()
    if rank is None:
        if options.distributed:
            raise AgileError("--distributed: start the processes with torchrun (WORLD_SIZE is unset or 1), e.g. "
                             "torchrun --standalone --nproc_per_node=2 scripts/train.py --task ... --distributed")
        return None, options.device
    if not options.distributed:
        raise AgileError(f"WORLD_SIZE={rank.world_size} (torchrun) without --distributed: add --distributed to train "
                         f"data-parallel")
    try:
        device = rank_device(rank, options.device)
    except ValueError as err:
        raise AgileError(str(err)) from err
    make_current(device)
    return rank, device


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
        raise AgileError(f"the {rank.world_size} ranks ended with different weights (sha256 by rank: {digests})")
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
        raise AgileError(f"--init_policy {path}: a distilled task's student starts from a distilled student (its "
                         f"student_state_dict); the file holds {sorted(checkpoint)}")
    if "student_state_dict" not in checkpoint:
        raise AgileError(f"--init_policy {path}: no actor_state_dict or student_state_dict in it (it holds "
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
            raise AgileError(f"--init_action_std: the policy in {path} has no state-independent std to reset")
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
        raise AgileError(f"{task} fine-tunes the policy of {source_task}, and agile ships none: train {source_task} "
                         f"first and give --init_policy PATH (its model_<it>.pt)")
    print(f"[agile] {task} fine-tunes {source_task}: the actor starts from its shipped policy {path}")
    return str(path)


def distillation_teacher(options: TrainOptions, agent_cfg, resuming: bool) -> str | None:
    """The teacher file of a distillation run (None for PPO, and when resuming: the checkpoint holds it)."""
    import agile.tasks
    from agile.rl import is_distillation

    if not is_distillation(agent_cfg):
        if options.teacher:
            raise AgileError(f"--teacher: {options.task} is trained by PPO, not distilled from a teacher")
        return None
    if resuming:
        return None
    path = options.teacher or agile.tasks.pretrained_policy(agent_cfg.teacher_task)
    if path is None:
        raise AgileError(f"{options.task} distils the policy of {agent_cfg.teacher_task}, and agile ships none: train "
                         f"it first and give --teacher PATH (its model_<it>.pt or exported/policy.pt)")
    if not os.path.isfile(path):
        raise AgileError(f"--teacher file not found: {path}")
    return str(path)


def starting_point(options: TrainOptions, agent_cfg) -> dict:
    """Where a single-agent run starts, each file read before the env is built (one that is missing or would run
    code is refused at once): {"resume_path", "resume_contents", "init_policy", "init_contents", "teacher"}."""
    from agile.rl import policy_state_key

    if len(options.init_policy) > 1:
        raise AgileError(f"init_policy takes one checkpoint for a single-agent task, got {list(options.init_policy)}")
    init_policy = options.init_policy[0] if options.init_policy else None
    resume_path = None
    if options.resume or options.checkpoint:
        resume_path = options.checkpoint or task_setup.latest_checkpoint(options.log_root, agent_cfg.experiment_name)
        if not os.path.isfile(resume_path):
            raise AgileError(f"checkpoint not found: {resume_path}")
    if init_policy and resume_path:
        raise AgileError("--init_policy starts a new run; it cannot be combined with --resume/--checkpoint")
    resume_contents = task_setup.read_checkpoint(resume_path, options.trust_checkpoint) if resume_path else None
    if init_policy is None and resume_path is None:
        init_policy = shipped_init_policy(options.task, agent_cfg)
    if init_policy and not os.path.isfile(init_policy):
        raise AgileError(f"--init_policy file not found: {init_policy}")
    if options.init_action_std is not None and (not init_policy or not options.init_action_std > 0):
        raise AgileError("--init_action_std needs --init_policy and a positive value "
                         "(a new run's initial std is agent.actor.distribution_cfg.init_std)")
    init_contents = None
    if init_policy:  # refused before the env is built when it holds no policy
        init_contents = as_policy_checkpoint(task_setup.read_checkpoint(init_policy, options.trust_checkpoint),
                                             init_policy, policy_state_key(agent_cfg))
    return {"resume_path": resume_path, "resume_contents": resume_contents, "init_policy": init_policy,
            "init_contents": init_contents,
            "teacher": distillation_teacher(options, agent_cfg, resuming=resume_path is not None)}


def restore_start(runner, env, agent_cfg, start: dict, options: TrainOptions, log_dir: str | None) -> None:
    """Put the runner (and the env's training state) where the run starts: a checkpoint resumed, a teacher loaded,
    an initial policy's actor."""
    from agile.rl import policy_obs_set, policy_state_key
    from agile.rl.checkpoints import restore_runner
    from agile.rl.algorithms.distillation import load_teacher

    if start["resume_path"]:
        print(f"[agile] resuming from {start['resume_path']}")
        restore_runner(runner, start["resume_contents"])  # loaded on the CPU: a GPU run can be resumed on another
        runner.continue_wall_time(start["resume_contents"])
        env_state = (start["resume_contents"].get("infos") or {}).get("env_state")
        if env_state is not None:  # step counter (reward-weight ramps) and terrain levels
            try:
                env.load_training_state(env_state)
            except ValueError as err:  # a checkpoint of another env (terrain, curriculum terms, env count)
                raise AgileError(f"--checkpoint {start['resume_path']}: {err}") from err
        else:
            print("[agile] the checkpoint holds no env state (an older checkpoint): curricula start over")
        print(f"[agile] continuing at iteration {runner.current_learning_iteration}")
    if start["teacher"]:
        print(f"[agile] teacher: {start['teacher']}")
        try:
            load_teacher(runner, start["teacher"], trust=options.trust_checkpoint)
        except ValueError as err:
            raise AgileError(str(err)) from err
    if start["init_policy"]:
        print(f"[agile] {policy_obs_set(agent_cfg)} initialised from {start['init_policy']}")
        initial = initial_policy_checkpoint(start["init_contents"], start["init_policy"], policy_state_key(agent_cfg),
                                            log_dir, options.init_action_std)
        restore_runner(runner, initial, load_cfg={policy_obs_set(agent_cfg): True})
