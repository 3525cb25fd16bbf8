"""AGILE `G1PickPlaceTrackingPpoRunnerCfg`: 20k iterations, actor and critic [256, 128, 64] on the one `policy`
group, entropy 0.005 annealed (from progress 0.1, i.e. iteration 2,000 of 20,000, once the episodes last 30% of
their length on average: x0.9998 per iteration, down to 0.001), observations normalised."""

from agile.rl import DistributionCfg, EntropyAnnealingCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg


def g1_pick_place_ppo_runner_cfg() -> PpoRunnerCfg:
    return PpoRunnerCfg(
        experiment_name="pick_place_g1",
        num_steps_per_env=24,
        max_iterations=20_000,
        save_interval=500,
        obs_groups={"actor": ["policy"], "critic": ["policy"]},
        actor=MlpModelCfg(hidden_dims=[256, 128, 64], activation="elu", obs_normalization=True,
                          distribution_cfg=DistributionCfg(init_std=1.0)),
        critic=MlpModelCfg(hidden_dims=[256, 128, 64], activation="elu", obs_normalization=True),
        # PPO's defaults are this runner's AGILE settings (lr 1e-3 adaptive, entropy 0.005)
        algorithm=PpoAlgorithmCfg(entropy_annealing=EntropyAnnealingCfg(
            start_iteration=2_000, min_episode_length_share=0.3, decay_per_iteration=0.9998, min_entropy_coef=0.001)),
    )
