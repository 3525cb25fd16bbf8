"""Loading trained policies and preparing env configs for running them."""

from __future__ import annotations

import dataclasses


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


def load_runner(checkpoint: dict, env, agent_cfg):
    """An RSL-RL runner (no logging) holding the models of a checkpoint or of a shipped actor-only file (contents
    from `cli.read_checkpoint`)."""
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl_env.rsl_rl import RslRlVecEnvWrapper, policy_obs_set, policy_state_key, to_rsl_rl_dict
    from agile.rl_env.rsl_rl.checkpoints import restore_runner

    from utils import cli

    # a PPO checkpoint holds an actor, a distilled one a student: the other kind would load nothing that acts
    if policy_state_key(agent_cfg) not in checkpoint:
        cli.fail(f"the checkpoint holds {sorted(k for k in checkpoint if k.endswith('_state_dict'))}, not the "
                 f"'{policy_state_key(agent_cfg)}' this task's policy needs")
    wrapped = RslRlVecEnvWrapper(env)
    with cli.quiet_stdout():  # rsl-rl prints the whole actor and critic
        runner = OnPolicyRunner(wrapped, to_rsl_rl_dict(agent_cfg), log_dir=None, device=str(env.device))
    # a shipped policy holds the acting model only; a training checkpoint also the critic (or teacher) and optimizer
    policy_only = "optimizer_state_dict" not in checkpoint
    restore_runner(runner, checkpoint, load_cfg={policy_obs_set(agent_cfg): True} if policy_only else None)
    return runner


def load_policy(checkpoint: dict, env, agent_cfg):
    """The deterministic actor of a checkpoint (contents from `cli.read_checkpoint`), as a callable on the env's
    observation TensorDict."""
    from agile.rl_env.rsl_rl import flatten_groups

    actor = load_runner(checkpoint, env, agent_cfg).get_inference_policy(device=str(env.device))

    def policy(obs):
        actor.reset(env.episode_length_buf == 0)  # a recurrent actor starts each episode from a zero hidden state
        return actor(flatten_groups(obs))

    return policy
