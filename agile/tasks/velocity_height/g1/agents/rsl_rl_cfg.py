"""AGILE's Velocity-Height-G1 runners: the privileged teacher by PPO, two students distilled from it (§5), and
the history policy trained by PPO directly."""

from agile.rl import (DistillationAlgorithmCfg, DistillationRunnerCfg, DistributionCfg, MlpModelCfg,
                      PpoRunnerCfg, RnnModelCfg)
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg

TEACHER_TASK = "Velocity-Height-G1-Teacher-v0"


def _ppo_runner_cfg(experiment_name: str) -> PpoRunnerCfg:
    """AGILE G1VelocityHeightPpoRunnerCfg: the G1 velocity runner with entropy 0.01, 30k iterations."""
    return velocity_ppo_runner_cfg(experiment_name=experiment_name, max_iterations=30_000, entropy_coef=0.01)


def g1_velocity_height_teacher_ppo_runner_cfg() -> PpoRunnerCfg:
    return _ppo_runner_cfg("velocity_height_g1_teacher")


def g1_velocity_height_history_ppo_runner_cfg() -> PpoRunnerCfg:
    return _ppo_runner_cfg("velocity_height_g1_history")


def _teacher_model_cfg() -> MlpModelCfg:
    """The teacher's actor, as the teacher runner builds it, so that its checkpoint or export loads."""
    return _ppo_runner_cfg("teacher").actor


def _distillation_runner_cfg(experiment_name: str, student: MlpModelCfg,
                             algorithm: DistillationAlgorithmCfg) -> DistillationRunnerCfg:
    """AGILE G1VelocityHeightDistillation*RunnerCfg: 10k iterations, 5 epochs, lr 1e-3, grad norm 1, MSE."""
    return DistillationRunnerCfg(
        experiment_name=experiment_name, num_steps_per_env=24, max_iterations=10_000, save_interval=250,
        teacher_task=TEACHER_TASK, algorithm=algorithm, student=student,
        teacher=_teacher_model_cfg())


def _recurrent_student_model_cfg() -> RnnModelCfg:
    """AGILE's recurrent student: LSTM (256) then MLP [256, 256, 128], action noise 0.1."""
    return RnnModelCfg(hidden_dims=[256, 256, 128], activation="elu", obs_normalization=True,
                       distribution_cfg=DistributionCfg(init_std=0.1), rnn_type="lstm", rnn_hidden_dim=256,
                       rnn_num_layers=1)


def _history_student_model_cfg() -> MlpModelCfg:
    """AGILE's history student: MLP [512, 256, 128] on 5 steps of history, action noise 0.1."""
    return MlpModelCfg(hidden_dims=[512, 256, 128], activation="elu", obs_normalization=True,
                       distribution_cfg=DistributionCfg(init_std=0.1))


def g1_velocity_height_recurrent_student_runner_cfg() -> DistillationRunnerCfg:
    """Truncated backpropagation through 15 steps (5 × 24 = 120 steps per update, 8 gradient steps)."""
    return _distillation_runner_cfg("velocity_height_g1_student_recurrent", _recurrent_student_model_cfg(),
                                    DistillationAlgorithmCfg(num_learning_epochs=5, gradient_length=15))


def g1_velocity_height_history_student_runner_cfg() -> DistillationRunnerCfg:
    """With AGILE's mirror loss (coefficient 0.1)."""
    algorithm = DistillationAlgorithmCfg(num_learning_epochs=5, gradient_length=15, mirror_loss_coeff=0.1,
                                         mirror_func="agile.rl_env.mdp.symmetry:lr_mirror")
    return _distillation_runner_cfg("velocity_height_g1_student_history", _history_student_model_cfg(), algorithm)


def _finetune_runner_cfg(experiment_name: str, student_task: str, student: MlpModelCfg) -> PpoRunnerCfg:
    """AGILE's `StudentFinetuneRecurrent`: PPO on a distilled student, its actor the student's architecture and
    weights (`init_policy_task`: the shipped student, or `train.py --init_policy` a student's checkpoint), a
    fresh privileged critic. Distillation imitates the teacher's actions but never sees the failure terms, and
    the students end 1.5-2% of their episodes by a foot or knee distance where the teacher ends 0.5%: PPO
    trains on the termination penalty itself. Measured on the H200, each of these kept the students from
    falling apart in PPO's first updates: the critic learns alone for the first 50 iterations, at 1e-3 (value
    loss 0.12 by then; 0.60 at 1e-5); PPO's learning rate then starts at 1e-5, not 1e-3 (Adam's first steps
    move every weight by about the learning rate whatever its gradient: at 1e-3 the first update after the
    warm-up took the episodes ended by a knee or foot distance from 6% to 75%), and the adaptive schedule
    raises it while the policy's KL stays under its target; no entropy bonus widens the student's small action noise (0.1; at 0.01 it was
    0.14 in 60 iterations): this refines a deterministic policy near the distilled one, it does not explore."""
    cfg = _ppo_runner_cfg(experiment_name)
    cfg.actor = student
    cfg.init_policy_task = student_task
    cfg.critic_warmup_iterations = 50
    cfg.algorithm.learning_rate = 1.0e-5
    cfg.algorithm.entropy_coef = 0.0
    cfg.max_iterations = 2_000
    if isinstance(student, RnnModelCfg):  # rsl-rl's PPO refuses mirrored samples with recurrent models
        cfg.algorithm.symmetry_cfg = None
    else:
        # the mirror loss of the history student's distillation, not mirrored samples: a mirrored sample keeps the
        # original's log-probability, and at action noise 0.1 the distilled student's small asymmetries put its
        # ratio far from 1 (surrogate loss 0.17-0.30 with the actor held in the warm-up, H200)
        cfg.algorithm.symmetry_cfg = {"use_data_augmentation": False, "use_mirror_loss": True,
                                      "mirror_loss_coeff": 0.1,
                                      "data_augmentation_func": "agile.rl_env.mdp.symmetry:lr_mirror"}
    return cfg


def g1_velocity_height_recurrent_finetune_runner_cfg() -> PpoRunnerCfg:
    return _finetune_runner_cfg("velocity_height_g1_student_recurrent_finetune",
                                "Velocity-Height-G1-Student-Recurrent-v0", _recurrent_student_model_cfg())


def g1_velocity_height_history_finetune_runner_cfg() -> PpoRunnerCfg:
    return _finetune_runner_cfg("velocity_height_g1_student_history_finetune",
                                "Velocity-Height-G1-Student-History-v0", _history_student_model_cfg())
