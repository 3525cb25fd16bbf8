"""Each robot trained by its own PPO (NORMAL groups), with its velocity task's settings."""

from agile.marl.rsl_rl import AgentGroupCfg, MultiAgentRunnerCfg
from agile.tasks.velocity.g1.agents.rsl_rl_cfg import g1_velocity_history_ppo_runner_cfg
from agile.tasks.velocity.t1.agents.rsl_rl_cfg import t1_velocity_ppo_runner_cfg


def multi_rate_velocity_runner_cfg() -> MultiAgentRunnerCfg:
    # 0.48 s per rollout: 24 steps of the 50 Hz G1 (its velocity task's rollout) and 12 of the 25 Hz T1
    return MultiAgentRunnerCfg(
        experiment_name="multi_rate_g1_t1_velocity", max_iterations=3000, save_interval=250, rollout_s=0.48,
        groups={"g1": AgentGroupCfg(agents=["g1"], mode="normal", runner=g1_velocity_history_ppo_runner_cfg()),
                "t1": AgentGroupCfg(agents=["t1"], mode="normal", runner=t1_velocity_ppo_runner_cfg())})
