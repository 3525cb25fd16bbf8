"""RSL-RL (rsl-rl-lib 5.5.1) runner configs as dataclasses; `to_rsl_rl_dict` gives what the runner takes."""

from __future__ import annotations

import dataclasses
from dataclasses import field

from agile.rl.compat import current_name, with_current_names
from agile.utils.config import ConfigError, configclass, to_dict


@configclass
class DistributionCfg:
    class_name: str = "agile.rl.distribution:SyncFreeGaussianDistribution"
    """rsl-rl's GaussianDistribution, sampled without a host synchronisation (the same draws)."""
    init_std: float = 1.0
    std_type: str = "scalar"


@configclass
class MlpModelCfg:
    class_name: str = "MLPModel"
    hidden_dims: list[int] = field(default_factory=lambda: [512, 256, 128])
    activation: str = "elu"
    obs_normalization: bool = False
    distribution_cfg: DistributionCfg | None = None


RNN_TYPES = ("lstm", "gru")


@configclass
class RnnModelCfg(MlpModelCfg):
    """rsl-rl's RNNModel: the (normalised) observations go through an LSTM or GRU whose output feeds the MLP."""

    class_name: str = "RNNModel"
    rnn_type: str = "lstm"
    """One of RNN_TYPES."""
    rnn_hidden_dim: int = 256
    rnn_num_layers: int = 1


@configclass
class RewardNormalizationCfg:
    """AGILE's `reward_normalization_cfg` (its defaults): see `agile.rl.algorithms.reward_normalization`."""

    decay: float = 0.999
    """Per env step, of the running mean and variance of one step's rewards."""
    epsilon: float = 1.0e-2
    return_scale_decay: float | None = 0.999
    """Per rollout, of the return-scale correction; None: no correction (the i.i.d. scale alone)."""
    outlier_threshold: float | None = 10.0
    """Rewards beyond this many standard deviations from the running mean are clipped; None: no clipping."""

    def check(self) -> None:
        for name in ("decay", "return_scale_decay"):
            value = getattr(self, name)
            if value is not None and not 0.0 <= value < 1.0:
                raise ConfigError(f"reward_normalization.{name}: {value}; give a factor in [0, 1)")
        if not self.epsilon > 0.0:
            raise ConfigError(f"reward_normalization.epsilon: {self.epsilon}; give a positive number")
        if self.outlier_threshold is not None and not self.outlier_threshold > 0.0:
            raise ConfigError(f"reward_normalization.outlier_threshold: {self.outlier_threshold}; give a positive "
                              f"number of standard deviations, or None")


@configclass
class L2C2Cfg:
    """AGILE's `l2c2_cfg` (its HeightTracking, PickPlace and G1 runners: 1.0 and 0.1): see
    `agile.rl.algorithms.l2c2`."""

    lambda_actor: float = 1.0
    lambda_critic: float = 0.1

    def check(self) -> None:
        for name in ("lambda_actor", "lambda_critic"):
            if not getattr(self, name) >= 0.0:
                raise ConfigError(f"l2c2.{name}: {getattr(self, name)}; give a weight >= 0")


@configclass
class EntropyAnnealingCfg:
    """AGILE's entropy-coefficient annealing (`agile.rl.algorithms.entropy_annealing`): from `start_iteration` on,
    each iteration whose ended episodes lasted on average more than `min_episode_length_share` of the episode
    length multiplies the coefficient by `decay_per_iteration`, down to `min_entropy_coef`. AGILE states the start
    as a share of its runner's max_iterations; here it is the iteration itself, so that a resumed run (whose
    --max_iterations counts the iterations still to run) starts it at the same point."""

    start_iteration: int = 0
    min_episode_length_share: float = 0.0
    decay_per_iteration: float = 1.0
    min_entropy_coef: float = 0.001

    def check(self) -> None:
        if self.start_iteration < 0:
            raise ConfigError(f"entropy_annealing.start_iteration: {self.start_iteration}; give 0 or more")
        if not 0.0 <= self.min_episode_length_share <= 1.0:
            raise ConfigError(f"entropy_annealing.min_episode_length_share: {self.min_episode_length_share}; "
                              "give a share of the episode length in [0, 1]")
        if not 0.0 < self.decay_per_iteration <= 1.0:
            raise ConfigError(f"entropy_annealing.decay_per_iteration: {self.decay_per_iteration}; give a factor "
                              "in (0, 1]")
        if self.min_entropy_coef < 0.0:
            raise ConfigError(f"entropy_annealing.min_entropy_coef: {self.min_entropy_coef}; give 0 or more")


@configclass
class PpoAlgorithmCfg:
    """rsl-rl's PPO and agile's extensions of it, each switched on here (`agile.rl.extensions` composes the class)."""

    class_name: str = "PPO"
    """rsl-rl's PPO, or a class derived from it (module:Class): the extensions switched on go in front of it."""
    learning_rate: float = 1.0e-3
    num_learning_epochs: int = 5
    num_mini_batches: int = 4
    schedule: str = "adaptive"
    desired_kl: float = 0.01
    gamma: float = 0.99
    lam: float = 0.95
    clip_param: float = 0.2
    entropy_coef: float = 0.005
    value_loss_coef: float = 1.0
    max_grad_norm: float = 1.0
    use_clipped_value_loss: bool = True
    use_mixed_precision: bool = False
    """rsl-rl's bf16 autocast of the update's forward passes (the weights and the optimizer stay FP32): fewer bytes
    and faster matrix products where the update is arithmetic (docs/benchmarks.md); off as AGILE trains."""
    symmetry_cfg: dict | None = None
    """RSL-RL symmetry extension, e.g. {"use_data_augmentation": True, "use_mirror_loss": False,
    "mirror_loss_coeff": 0.0, "data_augmentation_func": "agile.rl_env.mdp.symmetry:lr_mirror"}."""
    reward_normalization: RewardNormalizationCfg | None = None
    """AGILE's reward normalisation (`agile.rl.algorithms.reward_normalization`): the stored rewards scaled towards
    unit-variance returns. None: raw rewards (rsl-rl's PPO)."""
    l2c2: L2C2Cfg | None = None
    """AGILE's L2C2 smoothness term (`agile.rl.algorithms.l2c2`; needs sync_free_update or captured_update). None:
    none."""
    entropy_annealing: EntropyAnnealingCfg | None = None
    """AGILE's entropy-coefficient annealing (`agile.rl.algorithms.entropy_annealing`). None: a fixed coefficient."""
    sync_free_update: bool = False
    """rsl-rl's PPO update without a host synchronisation: the same math, the learning rate adapted on the device
    (`agile.rl.algorithms.sync_free_update`); feed-forward models, Adam, no RND."""
    captured_update: bool = False
    """The sync-free update with its mini-batch step replayed as one CUDA graph (`agile.rl.algorithms.captured_update`;
    on a CPU it runs eagerly): implies sync_free_update."""


@configclass
class RunnerCommonCfg:
    """What every runner config has: the run's name and seed, the rollout length, the schedule and logging."""

    experiment_name: str = "agile"
    run_name: str = ""
    seed: int = 42
    num_steps_per_env: int = 24
    max_iterations: int = 1000
    save_interval: int = 100
    logger: str = "tensorboard"
    check_for_nan: bool = True
    """Every step's observations and rewards are checked for NaN. Training runs the check in the env wrapper, on
    the device, and reports once per rollout, before the update reads it (`defer_nan_check`); rsl-rl's own check
    (a host sync per step) runs where a runner is built from `to_rsl_rl_dict` alone."""
    torch_compile_mode: str | None = None
    """rsl-rl compiles the models with torch.compile in this mode ("default", "max-autotune-no-cudagraphs");
    None: eager."""
    float32_matmul_precision: str = "highest"
    """torch.set_float32_matmul_precision for the training process, one of MATMUL_PRECISIONS: "high" lets float32
    matrix products (the policy's inference and the update) run on TF32 tensor cores, "highest" keeps full float32."""


MATMUL_PRECISIONS = ("highest", "high", "medium")


def set_matmul_precision(cfg: RunnerCommonCfg) -> None:
    """Apply the runner config's float32 matmul precision to this process (before the runner is built)."""
    import torch

    check_matmul_precision(cfg)
    torch.set_float32_matmul_precision(cfg.float32_matmul_precision)


def check_matmul_precision(cfg: RunnerCommonCfg) -> None:
    if cfg.float32_matmul_precision not in MATMUL_PRECISIONS:
        raise ConfigError(f"float32_matmul_precision: '{cfg.float32_matmul_precision}' is not one of "
                          f"{MATMUL_PRECISIONS}")


@configclass
class PpoRunnerCfg(RunnerCommonCfg):
    obs_groups: dict[str, list[str]] = field(default_factory=lambda: {"actor": ["policy"], "critic": ["critic"]})
    algorithm: PpoAlgorithmCfg = field(default_factory=PpoAlgorithmCfg)
    actor: MlpModelCfg = field(default_factory=lambda: MlpModelCfg(distribution_cfg=DistributionCfg()))
    critic: MlpModelCfg = field(default_factory=MlpModelCfg)
    init_policy_task: str | None = None
    """Fine-tuning: the registered task whose shipped policy the actor starts from when `train.py` is given no
    --init_policy (a distilled student's weights included: its student becomes the actor); the critic is fresh.
    None: the actor starts at random."""
    critic_warmup_iterations: int = 0
    """A run that starts from a trained actor (--init_policy, or `init_policy_task`) first trains only the critic
    for this many iterations, the actor's weights held: a fresh critic's advantages are noise, and PPO updates
    on them took a distilled student from 2% to 70% falls within 10 iterations (H200, measured). So does a run that
    resumes with reward normalisation from a checkpoint trained without it (its critic's returns change scale)."""
    critic_warmup_learning_rate: float = 1.0e-3
    """The learning rate of the warm-up; PPO then starts at `algorithm.learning_rate`. A fine-tuning run starts
    its actor small (Adam's first steps move every weight by about the learning rate), but a critic trained at
    that rate does not learn in a warm-up (recurrent student: value loss 0.60 after 50 iterations at 1e-5, 0.12
    at 1e-3; H200)."""


def make_recurrent(cfg: PpoRunnerCfg, rnn_type: str = "lstm", rnn_hidden_dim: int = 256,
                   rnn_num_layers: int = 1) -> None:
    """Turn the actor and critic of `cfg` into RnnModelCfg with the same MLP settings (in place)."""
    for name in ("actor", "critic"):
        mlp = getattr(cfg, name)
        mlp_fields = {f.name: getattr(mlp, f.name) for f in dataclasses.fields(MlpModelCfg) if f.name != "class_name"}
        setattr(cfg, name, RnnModelCfg(**mlp_fields, rnn_type=rnn_type, rnn_hidden_dim=rnn_hidden_dim,
                                       rnn_num_layers=rnn_num_layers))
    # rsl-rl's PPO raises on symmetry augmentation with recurrent models: train without the mirrored samples
    cfg.algorithm.symmetry_cfg = None


@configclass
class DistillationAlgorithmCfg:
    """rsl-rl's Distillation (DAgger-style behaviour cloning of a teacher's actions), through agile's subclass
    that adds an optional left-right mirror loss (rsl-rl refuses its symmetry extension for distillation)."""

    class_name: str = "Distillation"
    """rsl-rl's Distillation, or a class derived from it; `mirror_loss_coeff` > 0 puts agile's mirror loss in front."""
    num_learning_epochs: int = 5
    gradient_length: int = 15
    """Steps of the rollout between gradient steps (truncated backpropagation through time for an RNN)."""
    learning_rate: float = 1.0e-3
    max_grad_norm: float | None = 1.0
    loss_type: str = "mse"
    mirror_loss_coeff: float = 0.0
    """Weight of |student(mirrored obs) - mirrored student(obs)|², for a non-recurrent student
    (`agile.rl.algorithms.distillation.MirrorLoss`); 0: none."""
    mirror_func: str | None = None
    """e.g. "agile.rl_env.mdp.symmetry:lr_mirror"; needed when mirror_loss_coeff > 0."""


@configclass
class DistillationRunnerCfg(RunnerCommonCfg):
    """A student trained to act as a teacher policy does, the teacher seeing the privileged group "teacher".

    `teacher` is the architecture of the teacher task's actor (`teacher_task`), so that its checkpoint or its
    TorchScript export loads into it; the teacher is chosen at training time (`train.py --teacher PATH`)."""

    obs_groups: dict[str, list[str]] = field(default_factory=lambda: {"student": ["policy"],
                                                                      "teacher": ["teacher"]})
    teacher_task: str = ""
    """The registered task whose trained policy is the teacher (its `policy` group is this task's `teacher`)."""
    algorithm: DistillationAlgorithmCfg = field(default_factory=DistillationAlgorithmCfg)
    student: MlpModelCfg = field(default_factory=lambda: MlpModelCfg(distribution_cfg=DistributionCfg(init_std=0.1)))
    teacher: MlpModelCfg = field(default_factory=lambda: MlpModelCfg(distribution_cfg=DistributionCfg()))


RunnerCfg = PpoRunnerCfg | DistillationRunnerCfg


def is_distillation(cfg: RunnerCfg) -> bool:
    return isinstance(cfg, DistillationRunnerCfg)


def policy_obs_set(cfg: RunnerCfg) -> str:
    """The observation set of the model that acts (and is exported): rsl-rl's "actor", or "student"."""
    return "student" if is_distillation(cfg) else "actor"


def policy_model_cfg(cfg: RunnerCfg) -> MlpModelCfg:
    """The config of the model that acts: the actor, or the student."""
    return cfg.student if is_distillation(cfg) else cfg.actor


def policy_state_key(cfg: RunnerCfg) -> str:
    """Its weights' key in an rsl-rl checkpoint."""
    return f"{policy_obs_set(cfg)}_state_dict"


RUNNER_ONLY_KEYS = ("experiment_name", "seed", "max_iterations", "teacher_task", "init_policy_task",
                    "critic_warmup_iterations", "critic_warmup_learning_rate", "float32_matmul_precision")


def to_rsl_rl_dict(cfg: RunnerCfg) -> dict:
    """The train_cfg dict of `rsl_rl.runners.OnPolicyRunner` (keys of ours that it does not know removed; the
    algorithm's extensions composed into its class, `agile.rl.extensions`)."""
    from agile.rl.extensions import compose_algorithm

    if is_distillation(cfg):
        if cfg.algorithm.mirror_loss_coeff > 0.0 and cfg.algorithm.mirror_func is None:
            raise ConfigError("algorithm.mirror_loss_coeff > 0 needs algorithm.mirror_func")
        if cfg.algorithm.mirror_loss_coeff > 0.0 and isinstance(cfg.student, RnnModelCfg):
            raise ConfigError("algorithm.mirror_loss_coeff: the mirror loss is for non-recurrent students "
                              "(a recurrent student's output depends on its hidden state, not mirrored)")
    for model in (policy_model_cfg(cfg), cfg.teacher if is_distillation(cfg) else cfg.critic):
        # rsl-rl builds an LSTM for any rnn_type other than "gru", so a typo would silently train an LSTM
        if isinstance(model, RnnModelCfg) and model.rnn_type not in RNN_TYPES:
            raise ConfigError(f"rnn_type '{model.rnn_type}' is not one of {RNN_TYPES}")
    check_matmul_precision(cfg)
    d = to_dict(cfg)
    for key in RUNNER_ONLY_KEYS:
        d.pop(key, None)
    compose_algorithm(with_current_names(d["algorithm"]))
    for model in ("student", "teacher") if is_distillation(cfg) else ("actor", "critic"):
        d[model]["class_name"] = current_name(d[model]["class_name"])
        if d[model].get("distribution_cfg") is None:
            d[model].pop("distribution_cfg", None)
        else:
            d[model]["distribution_cfg"]["class_name"] = current_name(d[model]["distribution_cfg"]["class_name"])
    return d
