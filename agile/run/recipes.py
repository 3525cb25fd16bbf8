"""Named sets of runner settings that train faster than the registered ones, given as config overrides
(`agile train --recipe fast`, also `agile time_to_policy` and `agile benchmark`); the overrides written after them
on the command line win. The task definitions (terms, weights, ranges) are AGILE's either way; a recipe changes how
PPO updates, never what is learned from. Figures in docs/benchmarks.md. No imports: `--help` stays light."""

RECIPES: dict[str, tuple[str, ...]] = {
    # the PPO update as one CUDA graph per mini-batch step, TF32 matrix products, bf16 forward passes (the update
    # 0.171 -> 0.054 s for G1 at 4,096 envs on an H100), and twice AGILE's KL target for the adaptive learning rate:
    # Velocity-T1-v0 from scratch met its criteria in 276 s on one H100 with it (warm kernel cache), 119 s on four
    # (`--gpus 4 agent.num_steps_per_env=6`); Velocity-G1-History-v0 in 270 s on one with the same batch as 8,192
    # envs x 12 steps (`--num_envs 8192 agent.num_steps_per_env=12`: iterations 0.30 s instead of 0.42)
    "fast": ("agent.algorithm.captured_update=true",
             "agent.float32_matmul_precision=high",
             "agent.algorithm.use_mixed_precision=true",
             "agent.algorithm.desired_kl=0.02"),
}
