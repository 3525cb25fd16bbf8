"""AGILE `T1VelocityPpoRunnerCfg`."""

from agile.rl import PpoRunnerCfg
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg


def t1_velocity_ppo_runner_cfg() -> PpoRunnerCfg:
    # T1's actions are joint offsets of 1 rad per unit: with the usual initial noise of 1.0 a random policy pays
    # far more per second alive (action rate, base rocking) than the one-off termination penalty, and PPO learns
    # to fall first; from 0.3 episodes grow from the start (CPU probe, docs/policies.md)
    return velocity_ppo_runner_cfg(experiment_name="velocity_t1", max_iterations=100_000, init_action_std=0.3)
