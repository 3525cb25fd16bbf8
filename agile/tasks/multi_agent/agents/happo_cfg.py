"""Both robots trained by HAPPO (`agile train --trainer happo`): one actor each, no shared parameters, a centralised
critic on both robots' critic observations, learning the sum of their velocity-task rewards."""

from agile.marl.harl import HappoCfg


def multi_rate_velocity_happo_cfg() -> HappoCfg:
    # the rollout (0.48 s) and iteration count of the per-group PPO runs (multi_rate_velocity_runner_cfg), so that a
    # comparison spends the same simulated experience; the layer sizes of the robots' PPO actors (HARL's activations
    # have no ELU: ReLU, its default); entropy 0.005, gamma 0.99 (a slot of the schedule is 20 ms, the G1's period)
    # and 5 epochs of 4 mini-batches as the PPO runs
    return HappoCfg(experiment_name="multi_rate_g1_t1_velocity_happo", max_iterations=3000, save_interval=250,
                    rollout_s=0.48, hidden_dims=[256, 256, 128], activation="relu", entropy_coef=0.005,
                    gamma=0.99, num_epochs=5, num_mini_batches=4)
