"""PPO for the Go1 velocity tasks: the velocity family's runner, with the left-right mirror augmentation."""

from agile.rl import PpoRunnerCfg
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg


def go1_velocity_ppo_runner_cfg() -> PpoRunnerCfg:
    # mjlab trains its Go1 velocity tasks for 10k iterations of 24 steps (rough) with the same actor and critic sizes
    return velocity_ppo_runner_cfg(experiment_name="velocity_go1", max_iterations=10_000)
