"""What an evaluation tallies on the device as it runs, for its breakdowns: a tracking error by the commanded value
(velocity by commanded speed, yaw rate by commanded |yaw rate|, height by commanded height) and the outcomes by the
kind of episode each env started (pick-and-place by trajectory; on a terrain grid by the cell it spawned on), and
when in their episodes the falls happen."""

from __future__ import annotations

import math

SPEED_BIN_EDGES_MPS = (0.05, 0.25, 0.5, 0.75, 1.0)
"""Bins of the commanded planar speed |(vx, vy)| for the velocity error by command: [0, 0.05) is standing still."""
HEIGHT_BIN_EDGES_M = (0.45, 0.5, 0.55, 0.6, 0.65, 0.7)
"""Bins of the commanded base height for the height error by command."""
YAW_RATE_BIN_EDGES_RADPS = (0.05, 0.25, 0.5, 0.75, 1.0)
"""Bins of the commanded |yaw rate| for the yaw-rate error by command: [0, 0.05) is holding the heading still."""


class ErrorByCommand:
    """A tracking error summed per bin of a commanded value over the steps alive, on the device (no host sync
    per step): the error as a function of what was asked. Kept per env too, so that each bin's mean comes with its
    standard error over the envs (each env's episodes draw their own commands and start states: the envs are the
    independent samples, an env's steps are not)."""

    def __init__(self, edges: tuple[float, ...], device):
        import torch

        self.edges = edges
        self.edges_t = torch.tensor(edges, device=device)
        self.error_sum_per_env = None
        """(bins, N): the error summed per bin and env (made at the first `add`, when N is known)."""
        self.steps_per_env = None

    def add(self, commanded, error, alive) -> None:
        import torch

        if self.error_sum_per_env is None:
            self.env_ids = torch.arange(len(commanded), device=self.edges_t.device)
            self.error_sum_per_env = torch.zeros(len(self.edges) + 1, len(commanded), device=self.edges_t.device)
            self.steps_per_env = torch.zeros_like(self.error_sum_per_env)
        bins = torch.bucketize(commanded, self.edges_t, right=True)
        self.error_sum_per_env.index_put_((bins, self.env_ids), error * alive, accumulate=True)
        self.steps_per_env.index_put_((bins, self.env_ids), alive, accumulate=True)

    def rows(self) -> list[dict]:
        """[{"command": [low, high], "error": mean, "error_se": its standard error, "steps": n, "envs": k}] for the
        bins that saw a step (high None: open). The standard error is the ratio estimator's over the k envs with steps
        in the bin, sqrt(k / (k - 1) * sum_i (e_i - mean * n_i)^2) / sum_i n_i (e_i, n_i: env i's error sum and steps
        there); None with fewer than two envs."""
        if self.error_sum_per_env is None:
            return []
        bounds = [0.0, *self.edges, None]
        rows = []
        per_env = zip(self.error_sum_per_env.cpu().double(), self.steps_per_env.cpu().double())
        for i, (errors, steps) in enumerate(per_env):
            total = float(steps.sum())
            if total == 0:
                continue
            mean = float(errors.sum()) / total
            envs = int((steps > 0).sum())
            spread = float(((errors - mean * steps) ** 2).sum())
            se = (envs / (envs - 1) * spread) ** 0.5 / total if envs > 1 else None
            rows.append({"command": [bounds[i], bounds[i + 1]], "error": mean, "error_se": se, "steps": int(total),
                         "envs": envs})
        return rows


def error_by_command_tables(error_by_command: dict[str, list[dict]]) -> str:
    """`ErrorByCommand.rows()` under their "<error>_by_<command>" keys, as markdown tables: the mean error per bin of
    the commanded value, its standard error over the envs (where the rows have it) and the bin's share of the steps."""
    tables = []
    for key, rows in error_by_command.items():
        if not rows:
            continue
        error_name, _, command_name = key.partition("_by_")
        total = sum(row["steps"] for row in rows)
        bins = [f"{low:g}-{'' if high is None else f'{high:g}'}" for low, high in (row["command"] for row in rows)]
        lines = [f"| {command_name} | " + " | ".join(bins) + " |", "|---" * (len(rows) + 1) + "|",
                 f"| {error_name} | " + " | ".join(f"{row['error']:.3f}" for row in rows) + " |"]
        if any(row.get("error_se") is not None for row in rows):  # JSON written before it was kept has none
            lines.append("| standard error | " + " | ".join(
                "-" if row.get("error_se") is None else f"{row['error_se']:.3f}" for row in rows) + " |")
        lines.append("| share of steps | " + " | ".join(f"{row['steps'] / total:.0%}" for row in rows) + " |")
        tables.append("\n".join(lines))
    return "\n\n".join(tables)


class FallsByTime:
    """Ended episodes and falls by the time into the episode at which they ended, in bins of `bin_s` seconds:
    whether falls cluster at one moment (every env starts together, so a moment of the episode is a moment of the
    run: something that happens to all envs at once) or spread over the episode."""

    def __init__(self, episode_length_s: float, bin_s: float, device):
        import torch

        self.bin_s = bin_s
        self.num_bins = max(1, math.ceil(episode_length_s / bin_s - 1e-9))
        self.ended = torch.zeros(self.num_bins, device=device)
        self.falls = torch.zeros(self.num_bins, device=device)

    def add(self, episode_time_s, done, terminated) -> None:
        bins = (episode_time_s / self.bin_s).long().clamp(0, self.num_bins - 1)
        self.ended.index_add_(0, bins, done.float())
        self.falls.index_add_(0, bins, terminated.float())

    def rows(self) -> list[dict]:
        """[{"time_s": [low, high], "ended": n, "falls": n}] for the bins in which an episode ended."""
        return [{"time_s": [i * self.bin_s, (i + 1) * self.bin_s], "ended": int(e), "falls": int(f)}
                for i, (e, f) in enumerate(zip(self.ended.tolist(), self.falls.tolist())) if e > 0]


class OutcomesByVariant:
    """Episodes, falls and the episode metrics summed per kind of episode, by the kind each episode started with:
    which kinds fail. `variants()` gives the kinds' names and each env's current kind ((N,) long indices): a
    command term's `episode_variants` (the trajectory it draws), or `spawn_cell_variants`."""

    def __init__(self, variants, metric_keys):
        import torch

        self.variants = variants
        self.names, ids = variants()
        self.start = ids.clone()  # each env's episode's kind, as drawn at its start
        zeros = lambda: torch.zeros(len(self.names), device=ids.device)  # noqa: E731
        self.episodes, self.falls = zeros(), zeros()
        self.metrics = {key: zeros() for key in metric_keys}

    def add(self, done, terminated, last_metrics: dict) -> None:
        """After a step: count the episodes that ended, then note the kinds the reset envs drew."""
        import torch

        self.episodes.index_add_(0, self.start, done.float())
        self.falls.index_add_(0, self.start, terminated.float())
        for key, value in last_metrics.items():
            self.metrics[key].index_add_(0, self.start, value * done)
        self.start.copy_(torch.where(done, self.variants()[1], self.start))

    def rows(self) -> list[dict]:
        """[{"variant", "episodes", "falls", "fall_rate", "episode_metrics"}] for the kinds that ended an episode."""
        episodes, falls = self.episodes.tolist(), self.falls.tolist()
        metrics = {key: value.tolist() for key, value in self.metrics.items()}
        return [{"variant": name, "episodes": int(episodes[i]), "falls": int(falls[i]),
                 "fall_rate": falls[i] / episodes[i],
                 "episode_metrics": {key: values[i] / episodes[i] for key, values in metrics.items()}}
                for i, name in enumerate(self.names) if episodes[i] > 0]


def spawn_cell_variants(sim):
    """The cells of a terrain grid as kinds of episode, "row <r> col <c> <sub-terrain>", each env's from the row and
    column it spawns on (cells of one row and type differ: their difficulty is drawn within the row's band). None
    for a world without a terrain grid."""
    terrain = sim.terrain
    if terrain is None:
        return None
    num_rows, num_cols = terrain.cell_types.shape
    names = [f"row {row} col {col} {terrain.type_names[int(terrain.cell_types[row, col])]}"
             for row in range(num_rows) for col in range(num_cols)]

    def variants():
        return names, sim.terrain_levels * num_cols + sim.terrain_types

    return variants
