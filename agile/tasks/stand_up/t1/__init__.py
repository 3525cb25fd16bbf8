from agile.tasks.registration import register_task

EVAL_OVERRIDES = ["env.scene.max_init_terrain_level=3", "env.events.reset_base.params.standing_ratio=0.0"]
"""Issue 17's setting: every episode starts from a fallen state (none standing) on terrain rows 0-3 (without the
curriculum, which evaluation removes, each env stays on its row). eval.py also removes the training-only lift."""

# the reset event collects the fallen-state dataset (or loads it from its disk cache) when the env is built
register_task("StandUp-T1-v0", f"{__name__}.stand_up_env_cfg:T1StandUpEnvCfg",
              f"{__name__}.agents.rsl_rl_cfg:t1_stand_up_ppo_runner_cfg",
              # issue 17: stands up (trunk above 0.55 m at the time-out) in > 90% of 10 s episodes. Criteria are
              # maxima: the failure share; the episodes a termination ends are failures in it too, so the fall rate
              # is held to the same 10% (not the default 5%, stricter than the issue)
              eval_criteria={"fall_rate": 0.10, "not_standing_at_time_out": 0.10},
              eval_settings={"episode_length_s": 10.0, "overrides": EVAL_OVERRIDES},
              startup_dataset="agile.tasks.stand_up.fallen_states.startup:collect_fallen_states_anew")
