"""Debug tasks, run by hand in the browser GUI (`kind: debug` in their registration)."""

import gymnasium as gym

for task_id, cfg in (("Debug-G1-v0", "g1_debug_env_cfg"), ("Debug-T1-v0", "t1_debug_env_cfg"),
                     ("Debug-G1-Object-v0", "g1_object_debug_env_cfg")):
    gym.register(
        id=task_id,
        entry_point="agile.rl_env.env:ManagerBasedRLEnv",
        disable_env_checker=True,
        order_enforce=False,
        kwargs={
            "task_name": task_id,
            "kind": "debug",
            "env_cfg_entry_point": f"{__name__}.debug_env_cfg:{cfg}",
            "rsl_rl_cfg_entry_point": f"{__name__}.agents.rsl_rl_ppo_cfg:debug_ppo_runner_cfg",
        },
    )
