"""The curve of a time-to-policy run (`agile.run.time_to_policy`): its evaluations against wall time, one line per
seed, and its verdict in words."""

from __future__ import annotations

import textwrap

CURVE_METRICS = ("fall_rate", "lin_vel_error_mps", "ang_vel_error_radps", "base_height_error_m",
                 "all_rows_fall_rate", "mean_terrain_level")
"""The metrics each evaluation row keeps and the curve draws, those the task measures (the last two: a ship bar's)."""


def seed_name(seed: int | None) -> str:
    """A run's seed in words: "seed 3", or "the task's seed" for a run given none."""
    return "the task's seed" if seed is None else f"seed {seed}"


def outcome(result: dict) -> str:
    """The run's verdict in words, for the plot's title."""
    if result["time_to_policy_s"] is not None:
        return f"time to policy {result['time_to_policy_s']:.0f} s (iteration {result['iteration_at_criteria']})"
    code = result.get("training_exit_code")  # None: stopped at the budget; 0: its iterations done
    if code is None:
        return f"criteria not met within {result['budget_s']:.0f} s"
    if code == 0:
        return f"criteria not met by the training's last iteration (within {result['budget_s']:.0f} s)"
    return f"criteria not met: the training failed (exit code {code})"


def first_iteration_wall_s(result: dict) -> float | None:
    """Where the run's first iteration lies on the curve's time axis: a resumed run's wall times count on from its
    checkpoint's (`wall_s_before`), its own start-up after them."""
    if result["first_iteration_s"] is None:
        return None
    return result.get("wall_s_before", 0.0) + result["first_iteration_s"]


def later_legs_wall_s(result: dict) -> list[float]:
    """Where each leg after the first (a --batch_schedule switch) started on the curve's time axis."""
    return [result.get("wall_s_before", 0.0) + leg["started_s"] for leg in result.get("legs", [])[1:]]


def plot(results: list[dict], path: str, title: str) -> bool:
    """The curve of each evaluated metric against wall time into `path`, one line per run (seed); False (no file)
    when no checkpoint was evaluated (none written within the budget)."""
    metrics = [m for m in CURVE_METRICS if any(m in row for r in results for row in r["evaluations"])]
    if not metrics:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 3.4), squeeze=False)
    for ax, metric in zip(axes[0], metrics):
        for result in results:
            rows = [r for r in result["evaluations"] if metric in r]
            line, = ax.plot([r["wall_s"] for r in rows], [r[metric] for r in rows], marker="o", ms=3,
                            label=f"{seed_name(result['seed'])}: {outcome(result)}")
            first_s = first_iteration_wall_s(result)
            if first_s is not None:
                ax.axvline(first_s, color=line.get_color(), ls=":")
            for leg_s in later_legs_wall_s(result):
                ax.axvline(leg_s, color=line.get_color(), ls="--")
        if metric in results[0]["criteria"]:
            ax.axhline(results[0]["criteria"][metric], color="r", label="maximum")
        if metric in results[0].get("minima", {}):
            ax.axhline(results[0]["minima"][metric], color="g", label="minimum")
        ax.set_xlabel("training wall time [s]")
        ax.set_title(metric)
    axes[0][0].legend(fontsize=6)
    legs = "; dashed: a new batch shape" if any(later_legs_wall_s(r) for r in results) else ""
    words = f"{title} ({results[0]['gpus']} GPU(s); dotted: first iteration{legs})"
    fig.suptitle(textwrap.fill(words, width=int(58 * len(metrics))), fontsize=9)  # the title fits one panel
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True
