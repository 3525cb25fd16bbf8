"""PickPlace-G1-v0 (AGILE FEB26: G1-PickPlace-Tracking-v0; both IDs registered) and its debug variant."""

from agile.tasks.registration import register_task

for task_id in ("PickPlace-G1-v0", "G1-PickPlace-Tracking-v0"):
    register_task(task_id, f"{__name__}.pick_place_env_cfg:pick_place_env_cfg",
                  f"{__name__}.agents.rsl_rl_cfg:g1_pick_place_ppo_runner_cfg")
register_task("PickPlace-G1-Debug-v0", f"{__name__}.pick_place_debug_env_cfg:pick_place_debug_env_cfg",
              "agile.tasks.debug.agents.rsl_rl_cfg:debug_ppo_runner_cfg", kind="debug")
