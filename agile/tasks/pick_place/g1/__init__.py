"""PickPlace-G1-v0 (AGILE FEB26: G1-PickPlace-Tracking-v0; both IDs registered), its debug variant and its recording
variant."""

from agile.tasks.registration import register_task

# issue 42's figures: 256 envs x 8 s, upper-body joint error < 0.1 rad, the cube lifted in > 80% of episodes and at
# the goal (within 5 cm) at the end in > 60%, falls < 5% (the catalogue's default for tasks without a velocity command)
EVAL = dict(eval_criteria={"reference/joint_pos_error_rad": 0.1},
            eval_minima={"reference/object_lifted": 0.8, "reference/object_at_goal": 0.6},
            eval_settings={"num_envs": 256, "episode_length_s": 8.0})
for task_id in ("PickPlace-G1-v0", "G1-PickPlace-Tracking-v0"):
    register_task(task_id, f"{__name__}.pick_place_env_cfg:pick_place_env_cfg",
                  f"{__name__}.agents.rsl_rl_cfg:g1_pick_place_ppo_runner_cfg", shipped_policy="PickPlace-G1-v0",
                  **EVAL)
register_task("PickPlace-G1-Debug-v0", f"{__name__}.pick_place_debug_env_cfg:pick_place_debug_env_cfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_pick_place_ppo_runner_cfg", kind="debug",
              shipped_policy="PickPlace-G1-v0")
register_task("PickPlace-G1-Record-v0", f"{__name__}.pick_place_record_env_cfg:pick_place_record_env_cfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_pick_place_ppo_runner_cfg", kind="record",
              shipped_policy="PickPlace-G1-v0", robot_type="unitree_g1_dex3",
              task_description="pick up the cube and put it down at the goal",
              color_palettes={"table": "agile.assets.tabletop:TABLE_PALETTE_RGB",
                              "object": "agile.assets.tabletop:CUBE_PALETTE_RGB"})
