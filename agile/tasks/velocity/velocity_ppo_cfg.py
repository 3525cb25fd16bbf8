"""PPO settings shared by AGILE's velocity tasks (`T1VelocityPpoRunnerCfg`, `G1VelocityPpoRunnerCfg`)."""

from agile.rl import DistributionCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg


MIRROR_AUGMENTATION = {"use_data_augmentation": True, "use_mirror_loss": False, "mirror_loss_coeff": 0.0,
                       "data_augmentation_func": "agile.rl_env.mdp.symmetry:lr_mirror"}
"""Left-right mirrored samples added to every mini-batch (AGILE's `lr_mirror_T1/G1` augmentation)."""


def velocity_ppo_runner_cfg(experiment_name: str, max_iterations: int, init_action_std: float = 1.0,
                            entropy_coef: float = 0.005, gamma: float = 0.99,
                            symmetry_cfg: dict | None = MIRROR_AUGMENTATION) -> PpoRunnerCfg:
    """Actor [256, 256, 128], critic [512, 256, 128], ELU; adaptive lr 1e-3 (KL 0.01); by default (AGILE's velocity
    runners) entropy 0.005, gamma 0.99 and the mirror augmentation (`symmetry_cfg` None: none).
    `init_action_std`: the policy's initial action noise, in units of the (scaled) action."""
    return PpoRunnerCfg(
        experiment_name=experiment_name,
        num_steps_per_env=24,
        max_iterations=max_iterations,
        save_interval=250,  # AGILE
        # empirical observation normalisation: measured on G1, without it episodes plateau at 1.2 s (the
        # policy never balances); with it they reach the 30 s limit by iteration ~400 (docs/policies.md)
        actor=MlpModelCfg(hidden_dims=[256, 256, 128], activation="elu", obs_normalization=True,
                          distribution_cfg=DistributionCfg(init_std=init_action_std)),
        critic=MlpModelCfg(hidden_dims=[512, 256, 128], activation="elu", obs_normalization=True),
        algorithm=PpoAlgorithmCfg(learning_rate=1.0e-3, schedule="adaptive", desired_kl=0.01, gamma=gamma, lam=0.95,
                                  entropy_coef=entropy_coef, num_learning_epochs=5, num_mini_batches=4,
                                  symmetry_cfg=None if symmetry_cfg is None else dict(symmetry_cfg)),
    )
