"""Where a policy settles for fixed values of a command that measures its own error (`CommandTerm.command_error`:
HeightTracking-G1's height command), one value per env:

    agile eval --task HeightTracking-G1-v0 --checkpoint model.pt --num_envs 256 --episode_length_s 15 \\
        --sweep_command 0.1 0.3 0.5 0.7 0.92 --out heights.json

Each env holds one of the values (env i: value i mod values) for all its episodes; the value the command measures
(the tracked point's height) is averaged per env over its episodes' steps from `settled_after_s` on. Per value: the
fall rate and episodes, the mean absolute and signed error of those per-env means, their 10/50/90th percentiles and
every env's (sorted): a policy that holds a few postures rather than the commanded value shows as clusters. And the
reward balance where the envs settle: each reward term's mean per step over the same steps (weighted, before the
step's dt), so that what a posture earns and what it is charged can be read per value (`reward_terms_table`), and
the posture itself: each joint's mean position over those steps.
"""

from __future__ import annotations

import torch

from agile.errors import AgileError
from agile.run.rollout_metrics import evaluate_per_env, summarise

SETTLED_AFTER_S = 5.0
"""Episode time after which the reached value counts: a fallen start has got up, a new value has been reached."""


def swept_command(env):
    """(name, term) of the task's one command with a single value and its own error measure."""
    terms = {name: term for name, term in env.command_manager.terms.items()
             if term.command_error() is not None and term.command.shape[1] == 1}
    if len(terms) != 1:
        raise AgileError(f"--sweep_command holds a command of one value that measures its own error; this task has "
                         f"{sorted(terms) or 'none'} (commands: {env.command_manager.active_terms})")
    return next(iter(terms.items()))


class SettledValues:
    """An evaluation recorder: per env, the sums of the command's measured value, of each reward term and of the
    policy's robot's joint positions, and their count, over the steps at or after `after_s` of episode time."""

    def __init__(self, term, env, after_s: float):
        self.term, self.after_s = term, after_s
        self.sum = torch.zeros(env.num_envs, device=env.device)
        self.count = torch.zeros(env.num_envs, device=env.device)
        self.reward_sums = {name: torch.zeros(env.num_envs, device=env.device) for name in env.reward_manager.weights}
        self.robot = env.scene[env.action_manager.policy_entity_name()]
        self.joint_pos_sums = torch.zeros_like(self.robot.joint_pos)

    def record(self, env, time_s: float) -> None:
        late = (env.episode_length_buf * env.step_dt >= self.after_s).float()
        self.sum += self.term.command_error().measured * late
        self.count += late
        for name, reward in env.reward_manager.step_reward.items():
            self.reward_sums[name] += reward * late
        self.joint_pos_sums += self.robot.joint_pos * late.unsqueeze(1)

    def per_env(self) -> torch.Tensor:
        """(N,) the mean measured value, NaN for an env without a counted step."""
        return torch.where(self.count > 0, self.sum / self.count.clamp(min=1.0), torch.nan)

    def reward_per_step(self, mask: torch.Tensor) -> dict[str, float]:
        """{term: its mean per step} over the counted steps of the envs in `mask`; the sum as "total"."""
        steps = self.count[mask].sum().clamp(min=1.0)
        per_term = {name: float(sums[mask].sum() / steps) for name, sums in self.reward_sums.items()}
        return {"total": sum(per_term.values()), **per_term}

    def joint_pos(self, mask: torch.Tensor) -> dict[str, float]:
        """{joint: its mean position [rad]} over the counted steps of the envs in `mask` (the settled posture)."""
        steps = self.count[mask].sum().clamp(min=1.0)
        means = self.joint_pos_sums[mask].sum(dim=0) / steps
        return {name: float(value) for name, value in zip(self.robot.joint_names, means)}


def command_sweep(env, policy, num_episodes: int, values: list[float],
                  settled_after_s: float = SETTLED_AFTER_S) -> list[dict]:
    name, term = swept_command(env)
    if env.num_envs < len(values):
        raise AgileError(f"--sweep_command has {len(values)} values: use at least that many envs (--num_envs)")
    episode_s = env.max_episode_length * env.step_dt
    if episode_s <= settled_after_s:
        raise AgileError(f"--episode_length_s must exceed {settled_after_s:g} s (the reached value counts from then "
                         f"on), got {episode_s:g}")
    unit_name = term.command_error().command_name  # "height_m"
    value_index = torch.arange(env.num_envs, device=env.device) % len(values)  # of each env
    term.set_fixed_command(torch.tensor(values, device=env.device)[value_index].unsqueeze(1))
    settled = SettledValues(term, env, settled_after_s)
    result = evaluate_per_env(env, policy, num_episodes, recorders=[settled])
    reached_per_env = settled.per_env()
    rows = []
    for i, value in enumerate(values):
        mask = value_index == i
        reached = reached_per_env[mask]
        reached = reached[~torch.isnan(reached)].sort().values
        row = {"command": value, "num_envs": int(mask.sum()),
               **{k: v for k, v in summarise(result["sums"], env.step_dt, mask=mask).items()
                  if k in ("episodes", "falls", "fall_rate")}}
        if len(reached):
            error = reached - value
            percentiles = torch.quantile(reached, torch.tensor([0.1, 0.5, 0.9], device=reached.device))
            row.update({f"mean_abs_error_{unit_name}": float(error.abs().mean()),
                        f"mean_signed_error_{unit_name}": float(error.mean()),
                        f"reached_{unit_name}_p10_p50_p90": [round(float(p), 4) for p in percentiles],
                        f"reached_{unit_name}_per_env": [round(float(r), 3) for r in reached],
                        "reward_per_step": {k: round(v, 4) for k, v in settled.reward_per_step(mask).items()},
                        "joint_pos_rad": {k: round(v, 3) for k, v in settled.joint_pos(mask).items()}})
        rows.append(row)
    print(f"[agile] {name}: the value reached from {settled_after_s:g} s of each episode on, per env")
    return rows


def swept_unit(rows: list) -> str:
    """The swept value's name with its unit ("height_m"), read off the rows' keys; "" when no value settled."""
    return next((k[len("mean_abs_error_"):] for row in rows for k in row if k.startswith("mean_abs_error_")), "")


def sweep_table(rows: list) -> str:
    """The sweep as a Markdown table."""
    unit_name = swept_unit(rows)
    lines = [f"| {unit_name} commanded | fall rate | mean abs error | mean signed error | reached p10 / p50 / p90 |",
             "|---|---|---|---|---|"]
    for row in rows:
        if f"mean_abs_error_{unit_name}" not in row:
            lines.append(f"| {row['command']:.3f} | {row['fall_rate']:.3f} | - | - | - |")
            continue
        p10, p50, p90 = row[f"reached_{unit_name}_p10_p50_p90"]
        lines.append(f"| {row['command']:.3f} | {row['fall_rate']:.3f} | {row[f'mean_abs_error_{unit_name}']:.3f} | "
                     f"{row[f'mean_signed_error_{unit_name}']:+.3f} | {p10:.3f} / {p50:.3f} / {p90:.3f} |")
    return "\n".join(lines)


def reward_terms_shown(rows: list, num_terms: int) -> list[str]:
    """"total" and the `num_terms` reward terms whose mean per step varies most across the rows' values (what tells
    the settled postures apart)."""
    terms = [name for name in rows[0]["reward_per_step"] if name != "total"]
    spread = {name: max(r["reward_per_step"][name] for r in rows) - min(r["reward_per_step"][name] for r in rows)
              for name in terms}
    return ["total", *sorted(terms, key=lambda name: -spread[name])[:num_terms]]


def reward_terms_table(rows: list, num_terms: int = 10) -> str:
    """The reward balance per value as a Markdown table: the total and the `num_terms` terms that differ most."""
    rows = [row for row in rows if "reward_per_step" in row]
    if not rows:
        return ""
    shown = reward_terms_shown(rows, num_terms)
    lines = ["| commanded | " + " | ".join(shown) + " |", "|---|" + "---|" * len(shown)]
    for row in rows:
        lines.append(f"| {row['command']:.3f} | " + " | ".join(f"{row['reward_per_step'][n]:+.3f}" for n in shown)
                     + " |")
    return "\n".join(lines)
