"""PickPlace-G1-v0 (AGILE FEB26: G1-PickPlace-Tracking-v0; both IDs registered), its debug variant and its recording
variant."""

from agile.tasks.registration import register_task

for task_id in ("PickPlace-G1-v0", "G1-PickPlace-Tracking-v0"):
    register_task(task_id, f"{__name__}.pick_place_env_cfg:pick_place_env_cfg",
                  f"{__name__}.agents.rsl_rl_cfg:g1_pick_place_ppo_runner_cfg")
register_task("PickPlace-G1-Debug-v0", f"{__name__}.pick_place_debug_env_cfg:pick_place_debug_env_cfg",
              "agile.tasks.debug.agents.rsl_rl_cfg:debug_ppo_runner_cfg", kind="debug")
register_task("PickPlace-G1-Record-v0", f"{__name__}.pick_place_record_env_cfg:pick_place_record_env_cfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_pick_place_ppo_runner_cfg", kind="record",
              shipped_policy="PickPlace-G1-v0", robot_type="unitree_g1_dex3",
              task_description="pick up the cube and put it down at the goal")
