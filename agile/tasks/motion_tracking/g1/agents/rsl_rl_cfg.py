"""AGILE `G1FlatPPORunnerCfg` (BeyondMimic's PPO settings): 30k iterations, actor and critic [512, 256, 128].

AGILE's runner also normalises rewards (0.999) and adds an L2C2 smoothness loss (1.0 / 0.1); rsl-rl-lib 5.5.1 has
neither, and agile does not add them: this runner trains without (docs/motion_tracking.md)."""

from agile.rl import DistributionCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg


def g1_motion_tracking_ppo_runner_cfg() -> PpoRunnerCfg:
    return PpoRunnerCfg(
        experiment_name="motion_tracking_g1",
        num_steps_per_env=24,
        max_iterations=30_000,
        save_interval=500,
        actor=MlpModelCfg(hidden_dims=[512, 256, 128], activation="elu", obs_normalization=True,
                          distribution_cfg=DistributionCfg(init_std=1.0)),
        critic=MlpModelCfg(hidden_dims=[512, 256, 128], activation="elu", obs_normalization=True),
        algorithm=PpoAlgorithmCfg(),  # its defaults are this runner's AGILE settings (lr 1e-3 adaptive, entropy 0.005)
    )
