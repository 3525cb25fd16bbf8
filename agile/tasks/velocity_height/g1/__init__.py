"""Velocity-Height-G1: walk at a commanded velocity and base height (0.4-0.72 m). A privileged teacher is
trained by PPO; the students, which see only what the robot measures, learn from it by distillation."""

from agile.tasks.registration import register_task

ENV_CFGS = f"{__name__}.velocity_height_env_cfg"
AGENT_CFGS = f"{__name__}.agents.rsl_rl_cfg"
TEACHER_ENV_CFG = "teacher_env_cfg"
TASKS = {  # id: (env cfg function, runner cfg function)
    "Velocity-Height-G1-v0": (TEACHER_ENV_CFG, "g1_velocity_height_teacher_ppo_runner_cfg"),
    "Velocity-Height-G1-Teacher-v0": (TEACHER_ENV_CFG, "g1_velocity_height_teacher_ppo_runner_cfg"),
    "Velocity-Height-G1-Student-Recurrent-v0": ("recurrent_student_env_cfg",
                                                "g1_velocity_height_recurrent_student_runner_cfg"),
    "Velocity-Height-G1-Student-History-v0": ("history_student_env_cfg",
                                              "g1_velocity_height_history_student_runner_cfg"),
    "Velocity-Height-G1-History-v0": ("history_env_cfg", "g1_velocity_height_history_ppo_runner_cfg"),
    # the distilled students trained further by PPO (AGILE's StudentFinetuneRecurrent)
    "Velocity-Height-G1-Student-Recurrent-Finetune-v0": ("recurrent_student_finetune_env_cfg",
                                                         "g1_velocity_height_recurrent_finetune_runner_cfg"),
    "Velocity-Height-G1-Student-History-Finetune-v0": ("history_student_finetune_env_cfg",
                                                       "g1_velocity_height_history_finetune_runner_cfg"),
}

DISTILLED = ("Velocity-Height-G1-Student-Recurrent-v0", "Velocity-Height-G1-Student-History-v0")
"""The students that learn from the teacher by distillation (the finetune tasks train them further by PPO)."""
TEACHER_CRITERIA = {"fall_rate": 0.05, "lin_vel_error_mps": 0.15, "base_height_error_m": 0.05}
"""What the teacher must reach (over 20 s episodes, pushes off); eval_all.py checks it."""
STUDENT_CRITERIA = {metric: 1.25 * maximum for metric, maximum in TEACHER_CRITERIA.items()}
"""A student must come within 25% of what the teacher must reach."""

for task_id, (env_cfg, runner_cfg) in TASKS.items():
    # the teacher's two IDs share the policy shipped as Velocity-Height-G1-Teacher-v0.pt
    register_task(task_id, f"{ENV_CFGS}:{env_cfg}", f"{AGENT_CFGS}:{runner_cfg}",
                  shipped_policy="Velocity-Height-G1-Teacher-v0" if env_cfg == TEACHER_ENV_CFG else task_id,
                  eval_criteria=STUDENT_CRITERIA if "Student" in task_id else TEACHER_CRITERIA,
                  kind="distilled" if task_id in DISTILLED else "trainable")
