"""AGILE `DummyPpoRunnerCfg`: the debug tasks are run by hand; a runner exists so that every script (and the
smoke tests) can build them, and its learning rate of 0 leaves the policy as initialised."""

from agile.rl import DistributionCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg


def debug_ppo_runner_cfg() -> PpoRunnerCfg:
    return PpoRunnerCfg(experiment_name="debug", num_steps_per_env=24, max_iterations=1,
                        obs_groups={"actor": ["policy"], "critic": ["policy"]},
                        actor=MlpModelCfg(hidden_dims=[32, 32], activation="elu", distribution_cfg=DistributionCfg()),
                        critic=MlpModelCfg(hidden_dims=[32, 32], activation="elu"),
                        algorithm=PpoAlgorithmCfg(learning_rate=0.0, schedule="fixed"))
