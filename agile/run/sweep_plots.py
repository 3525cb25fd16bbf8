"""Pictures of `agile eval`'s sweeps, drawn from their JSON (`agile eval --plot_sweep SWEEP.json` redraws one):

- a fixed-command grid (`--sweep_lin_vel_x` [x `--sweep_base_height`], the JSON's "cells"): one heat map per metric;
- a held command value per env (`--sweep_command`, the JSON's "values"): where the envs settle against what was
  commanded (every env, and the 10/50/90th percentiles), and the reward balance there (the total and the terms that
  differ most across the values).

Each is written next to its JSON (.png). Needs matplotlib (pip install 'agile[plot]').
"""

from __future__ import annotations

import importlib.util
import json
import os


def plot_sweep(json_path: str) -> str | None:
    """Draw the sweep of `json_path` next to it; the PNG's path, or None (and how to draw it later) without
    matplotlib."""
    if importlib.util.find_spec("matplotlib") is None:
        print(f"[agile] no plot: matplotlib is missing (pip install 'agile[plot]', then "
              f"agile eval --plot_sweep {json_path})")
        return None
    with open(json_path) as f:
        result = json.load(f)
    png = os.path.splitext(json_path)[0] + ".png"
    title = (f"{result['task']}: {result['num_envs']} envs, {result['episodes_per_env']} x "
             f"{result['episode_length_s']:g} s episodes")
    if "cells" in result:
        sweep_heat_map(result["cells"], png, title)
    elif "values" in result:
        command_sweep_plot(result["values"], png, f"{title}, {os.path.basename(result['checkpoint'])}")
    else:
        raise ValueError(f"{json_path}: not a sweep of agile eval (no 'cells' or 'values'; keys {sorted(result)})")
    print(f"[agile] plot: {png}")
    return png


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def sweep_heat_map(rows: list, path: str, title: str) -> None:
    """A PNG with one heat map per metric over (vx, height) (or a row of vx without a height command)."""
    import numpy as np

    plt = _pyplot()
    height = "base_height_error_m" in rows[0]
    vxs = sorted({r["command"][0] for r in rows})
    hs = sorted({r["command"][3] for r in rows}) if height else [0.0]
    metrics = ["fall_rate", "lin_vel_error_mps"] + (["base_height_error_m"] if height else [])
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.5 * len(metrics), 3.6), squeeze=False)
    for ax, metric in zip(axes[0], metrics):
        grid = np.full((len(hs), len(vxs)), np.nan)
        for r in rows:
            grid[hs.index(r["command"][3]) if height else 0, vxs.index(r["command"][0])] = r[metric]
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xticks(range(len(vxs)), [f"{v:+.2f}" for v in vxs])
        ax.set_yticks(range(len(hs)), [f"{h:.2f}" for h in hs] if height else [""])
        ax.set_xlabel("commanded vx [m/s]")
        ax.set_ylabel("commanded base height [m]" if height else "")
        for (i, j), value in np.ndenumerate(grid):
            ax.text(j, i, f"{value:.3f}", ha="center", va="center", color="w", fontsize=7)
        ax.set_title(metric)
        fig.colorbar(image, ax=ax)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def command_sweep_plot(rows: list, path: str, title: str, num_terms: int = 6) -> None:
    """Two panels over the commanded value: where each env settled (dots; p10-p90 bar and median) against the
    diagonal of a perfect tracker, and each shown reward term's mean per step where the envs settled."""
    from agile.run.command_sweep import reward_terms_shown, swept_unit  # here: they import torch, which --help need not

    plt = _pyplot()
    unit = swept_unit(rows)
    settled = [r for r in rows if f"reached_{unit}_per_env" in r]
    if not settled:
        raise ValueError("the sweep has no settled values to plot (every env fell or none was counted)")
    commands = [r["command"] for r in settled]
    fig, (reached_ax, reward_ax) = plt.subplots(1, 2, figsize=(12, 4.6))
    for r in settled:
        per_env = r[f"reached_{unit}_per_env"]
        reached_ax.scatter([r["command"]] * len(per_env), per_env, s=8, alpha=0.35, color="tab:blue")
    p10, p50, p90 = zip(*(r[f"reached_{unit}_p10_p50_p90"] for r in settled))
    reached_ax.errorbar(commands, p50, yerr=[[m - lo for m, lo in zip(p50, p10)], [hi - m for m, hi in zip(p50, p90)]],
                        fmt="o-", color="tab:red", capsize=3, label="median, p10-p90")
    low, high = min(commands + list(p10)), max(commands + list(p90))
    reached_ax.plot([low, high], [low, high], "k--", lw=1, label="reached = commanded")
    reached_ax.set_xlabel(f"commanded {unit}")
    reached_ax.set_ylabel(f"reached {unit} (per env, settled)")
    reached_ax.legend(loc="upper left", fontsize=8)
    reached_ax.grid(alpha=0.3)
    if "reward_per_step" in settled[0]:
        for name in reward_terms_shown(settled, num_terms):
            reward_ax.plot(commands, [r["reward_per_step"][name] for r in settled], "o-",
                           lw=2.5 if name == "total" else 1.2, label=name)
        reward_ax.axhline(0.0, color="k", lw=0.8)
        reward_ax.set_xlabel(f"commanded {unit}")
        reward_ax.set_ylabel("reward per step where settled (weighted, before dt)")
        reward_ax.legend(fontsize=7, ncol=2)
        reward_ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
