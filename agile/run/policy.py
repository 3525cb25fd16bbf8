"""Loading trained policies and preparing env configs for running them."""

from __future__ import annotations

import contextlib
import dataclasses
import io


class PolicyMismatchError(ValueError):
    """A checkpoint holds no model of the kind the task's agent config acts with (a PPO actor vs a student)."""


def inference_cfg(env_cfg):
    """The env cfg for running a policy: no observation noise, no curriculum, and no training-only action terms
    (a harness holding the robot up while it learns)."""
    from agile.rl_env.managers import ObsGroup, is_training_only

    for f in dataclasses.fields(env_cfg.observations):
        group = getattr(env_cfg.observations, f.name)
        if isinstance(group, ObsGroup):
            group.enable_corruption = False
    for f in dataclasses.fields(env_cfg.actions):
        if is_training_only(getattr(env_cfg.actions, f.name)):
            setattr(env_cfg.actions, f.name, None)
    env_cfg.curriculum = None
    return env_cfg


def load_runner(checkpoint: dict, env, agent_cfg, verbose: bool = False):
    """An RSL-RL runner (no logging) holding the models of a checkpoint or of a shipped actor-only file (contents
    from `agile.rl.checkpoints.load_checkpoint`). `verbose`: let rsl-rl print its models."""
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl import RslRlVecEnvWrapper, policy_obs_set, policy_state_key, to_rsl_rl_dict
    from agile.rl.checkpoints import restore_runner

    # a PPO checkpoint holds an actor, a distilled one a student: the other kind would load nothing that acts
    if policy_state_key(agent_cfg) not in checkpoint:
        raise PolicyMismatchError(
            f"the checkpoint holds {sorted(k for k in checkpoint if k.endswith('_state_dict'))}, not the "
            f"'{policy_state_key(agent_cfg)}' this task's policy needs")
    wrapped = RslRlVecEnvWrapper(env)
    with contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO()):
        runner = OnPolicyRunner(wrapped, to_rsl_rl_dict(agent_cfg), log_dir=None, device=str(env.device))
    # a shipped policy holds the acting model only; a training checkpoint also the critic (or teacher) and optimizer
    policy_only = "optimizer_state_dict" not in checkpoint
    try:
        restore_runner(runner, checkpoint, load_cfg={policy_obs_set(agent_cfg): True} if policy_only else None)
    except RuntimeError as err:  # torch's load_state_dict: a network of other sizes (another task's policy)
        mismatches = [line.strip() for line in str(err).splitlines() if "size mismatch" in line]
        if not mismatches:
            raise
        raise PolicyMismatchError(f"the checkpoint's networks do not fit {env.task_name}'s observations and actions "
                                  f"(a policy of another task?): {mismatches[0]}") from None
    return runner


def load_policy(checkpoint: dict, env, agent_cfg, verbose: bool = False):
    """The deterministic actor of a checkpoint, as a callable on the env's observation TensorDict."""
    from agile.rl import flatten_groups

    actor = load_runner(checkpoint, env, agent_cfg, verbose).get_inference_policy(device=str(env.device))

    def policy(obs):
        actor.reset(env.episode_length_buf == 0)  # a recurrent actor starts each episode from a zero hidden state
        return actor(flatten_groups(obs))

    return policy
