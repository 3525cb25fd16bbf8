"""The multi-agent tasks' runners, each group with its robot's velocity task's PPO settings."""

from agile.marl.rsl_rl import AgentGroupCfg, MultiAgentRunnerCfg
from agile.tasks.velocity.g1.agents.rsl_rl_cfg import g1_velocity_history_ppo_runner_cfg
from agile.tasks.velocity.go1.agents.rsl_rl_cfg import go1_velocity_ppo_runner_cfg
from agile.tasks.velocity.t1.agents.rsl_rl_cfg import t1_velocity_ppo_runner_cfg


def multi_rate_velocity_runner_cfg() -> MultiAgentRunnerCfg:
    """MultiRate-G1-T1-Velocity-v0: each robot trained by its own PPO ("normal" groups)."""
    # 0.48 s per rollout: 24 steps of the 50 Hz G1 (its velocity task's rollout) and 12 of the 25 Hz T1
    return MultiAgentRunnerCfg(
        experiment_name="multi_rate_g1_t1_velocity", max_iterations=3000, save_interval=250, rollout_s=0.48,
        groups={"g1": AgentGroupCfg(agents=["g1"], mode="normal", runner=g1_velocity_history_ppo_runner_cfg()),
                "t1": AgentGroupCfg(agents=["t1"], mode="normal", runner=t1_velocity_ppo_runner_cfg())})


def shared_go1_velocity_runner_cfg() -> MultiAgentRunnerCfg:
    """Shared-Go1-Velocity-v0: both Go1s through one policy ("shared": one PPO on their batched samples), with the
    Go1 velocity task's settings (its mirror augmentation included); 0.48 s per rollout, its 24 steps at 50 Hz."""
    return MultiAgentRunnerCfg(
        experiment_name="shared_go1_velocity", max_iterations=3000, save_interval=250, rollout_s=0.48,
        groups={"go1": AgentGroupCfg(agents=["go1_a", "go1_b"], mode="shared", runner=go1_velocity_ppo_runner_cfg())})
