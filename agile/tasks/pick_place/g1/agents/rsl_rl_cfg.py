"""AGILE `G1PickPlaceTrackingPpoRunnerCfg`: 20k iterations, actor and critic [256, 128, 64] on the one `policy`
group, entropy 0.005, observations normalised.

AGILE also anneals the action noise (from progress 0.1 once the success rate passes 0.3, decay 0.9998 per
iteration); rsl-rl-lib 5.5.1 has no such schedule and agile does not add one (docs/pick_place.md)."""

from agile.rl_env.rsl_rl import DistributionCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg


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
        algorithm=PpoAlgorithmCfg(),  # its defaults are this runner's AGILE settings (lr 1e-3 adaptive, entropy 0.005)
    )
