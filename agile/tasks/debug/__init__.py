"""Debug tasks, run by hand in the browser GUI (`kind: debug` in their registration)."""

from agile.tasks.registration import register_task

for task_id, cfg in (("Debug-G1-v0", "g1_debug_env_cfg"), ("Debug-T1-v0", "t1_debug_env_cfg"),
                     ("Debug-G1-Object-v0", "g1_object_debug_env_cfg")):
    register_task(task_id, f"{__name__}.debug_env_cfg:{cfg}", f"{__name__}.agents.rsl_rl_cfg:debug_ppo_runner_cfg",
                  kind="debug")
