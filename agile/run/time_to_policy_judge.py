"""How `agile time_to_policy` judges a checkpoint: against the task's criteria (`target` "criteria"), or against its
ship bar (`target` "shippable": the training's mean terrain level, the falls on the start rows and with spawns over
every terrain row, as the shipped velocity policies show them; `ship_bar` of the task's registration)."""

from __future__ import annotations

from pathlib import Path

from agile.errors import AgileError
from agile.run import task_setup
from agile.run.time_to_policy_plots import CURVE_METRICS

TARGETS = ("criteria", "shippable")
"""What a checkpoint must meet: the task's criteria (or --criterion's), or its ship bar."""
ALL_ROWS_OVERRIDE = "env.scene.max_init_terrain_level=null"
"""Spawns over every terrain row (the registered start rows are the first ones)."""


def all_checkpoints(log_root: str) -> list[tuple[int, Path]]:
    """(iteration, path) of every model_<it>.pt of the run under log_root, in order."""
    return sorted((int(p.stem.split("_")[1]), p) for p in Path(log_root).glob("*/*/model_*.pt"))


def newest_checkpoint(log_root: str) -> tuple[int, Path] | None:
    """(iteration, path) of the newest model_<it>.pt of the run under log_root, or None."""
    found = all_checkpoints(log_root)
    return found[-1] if found else None


def recorded_wall_s(checkpoint: str) -> float:
    """The training wall time a checkpoint records (`infos["wall_s"]`); AgileError where it records none."""
    return recorded_point(checkpoint)[1]


def recorded_point(checkpoint: str) -> tuple[int, float]:
    """(the iteration a checkpoint was written at, the training wall time it records); AgileError where it records
    no wall time."""
    from agile.rl.checkpoints import load_checkpoint

    contents = load_checkpoint(checkpoint)
    wall_s = (contents.get("infos") or {}).get("wall_s")
    if wall_s is None:
        raise AgileError(f"resume: {checkpoint} records no training wall time (infos['wall_s']; an older "
                         f"agile train wrote none): the time to policy cannot count on from it")
    return int(contents["iter"]), float(wall_s)


def evaluator(task: str, overrides: list[str], device: str, num_envs: int | None = None,
              episode_length_s: float | None = None, seed: int | None = None, eval_overrides=()):
    """A function (checkpoint path -> eval.py's metrics) over one env in the task's evaluation setting (the catalogue's
    env count and episode length unless given, `overrides` as trained, then the setting's own and `eval_overrides`,
    pushes off), built once. With `seed`, every evaluation starts from it: each checkpoint meets the same starts and
    commands."""
    import torch

    import agile.tasks
    from agile.rl.checkpoints import load_checkpoint
    from agile.run.rollout_metrics import evaluate
    from agile.run.eval_all import disable_interval_events
    from agile.run.policy import inference_cfg, load_policy
    from agile.tasks.catalogue import task_entry
    from agile.utils.config import apply_overrides

    settings = task_entry(task).eval_settings
    env_cfg, agent_cfg = agile.tasks.load_cfgs(task)
    apply_overrides({"env": env_cfg, "agent": agent_cfg}, [*overrides, *settings.get("overrides", []), *eval_overrides])
    env_cfg.num_envs = num_envs or settings["num_envs"]
    env_cfg.episode_length_s = episode_length_s or settings["episode_length_s"]
    env_cfg = inference_cfg(env_cfg)
    disable_interval_events(env_cfg)
    env = task_setup.make_env(task=task, env_cfg=env_cfg, device=device)

    def run(path: Path) -> dict:
        policy = load_policy(load_checkpoint(str(path)), env, agent_cfg)
        if seed is not None:
            torch.manual_seed(seed)
        return evaluate(env, policy, settings["num_episodes"])

    return run


def check_target(task: str, target: str, criteria: dict | None) -> None:
    """AgileError naming the field for a target the task cannot be judged by."""
    from agile.tasks.catalogue import catalogue, task_entry

    if target not in TARGETS:
        raise AgileError(f"target must be one of {', '.join(TARGETS)}, got {target!r}")
    if target == "shippable":
        if criteria:
            raise AgileError("criteria and target shippable: give one (the ship bar holds the task's criteria)")
        if not task_entry(task).ship_bar:
            with_bar = [e.task for e in catalogue() if e.ship_bar]
            raise AgileError(f"target shippable: {task} has no ship bar (ship_bar in its registration); tasks with "
                             f"one: {', '.join(with_bar)}")


def criteria_of(task: str, target: str, criteria: dict | None) -> tuple[dict, dict]:
    """(maxima, minima) a checkpoint must meet: the task's criteria from the catalogue, or the maxima `criteria`
    gives (no minima then); for "shippable", the task's criteria with the ship bar's (the stricter fall rate, the
    all-rows fall rate, the mean terrain level as a minimum)."""
    from agile.tasks.catalogue import task_entry

    if criteria:
        return dict(criteria), {}
    entry = task_entry(task)
    maxima, minima = dict(entry.criteria), dict(entry.minima)
    if target == "shippable":
        bar = entry.ship_bar
        maxima["fall_rate"] = min(maxima.get("fall_rate", bar["fall_rate"]), bar["fall_rate"])
        maxima["all_rows_fall_rate"] = bar["all_rows_fall_rate"]
        minima["mean_terrain_level"] = bar["mean_terrain_level"]
    return maxima, minima


def mean_terrain_level(path: Path) -> float | None:
    """The training's mean terrain level when it wrote the checkpoint (its env state), None where it holds none."""
    from agile.rl.checkpoints import load_checkpoint

    env_state = (load_checkpoint(str(path)).get("infos") or {}).get("env_state") or {}
    levels = env_state.get("terrain_levels")
    return None if levels is None else float(levels.float().mean())


CLIMB_CHECKPOINTS = 10
"""The newest checkpoints a climb's pace is fitted over (500 iterations at the default --save_interval)."""


def climb(rows: list[dict], bar_level: float) -> dict | None:
    """The training's pace up the terrain over its newest CLIMB_CHECKPOINTS checkpoints (`rows` or `levels` of a
    CheckpointJudge): rows per 100 s of training wall time (a least-squares line through their mean terrain levels
    and wall times); below `bar_level` and climbing, also the wall time at which the newest level would reach it at
    that pace. None with fewer than two checkpoints that hold a level."""
    points = [(r["wall_s"], r["mean_terrain_level"]) for r in rows if r.get("mean_terrain_level") is not None]
    points = points[-CLIMB_CHECKPOINTS:]
    if len(points) < 2 or points[0][0] == points[-1][0]:
        return None
    mean_s = sum(s for s, _ in points) / len(points)
    mean_level = sum(level for _, level in points) / len(points)
    rows_per_s = sum((s - mean_s) * (level - mean_level) for s, level in points) / \
        sum((s - mean_s) ** 2 for s, _ in points)
    (first_s, _), (last_s, last_level) = points[0], points[-1]
    pace = {"rows_per_100s": round(100.0 * rows_per_s, 3), "from_wall_s": first_s, "to_wall_s": last_s,
            "mean_terrain_level": round(last_level, 3)}
    if last_level < bar_level and rows_per_s > 0:
        pace["bar_at_wall_s"] = round(last_s + (bar_level - last_level) / rows_per_s, 1)
    return pace


def climb_in_words(pace: dict, bar_level: float) -> str:
    """The pace of `climb` in words: the rows per 100 s and, where given, when the bar would be reached."""
    words = f"{pace['rows_per_100s']:g} rows per 100 s over the checkpoints from {pace['from_wall_s']:g} s"
    if "bar_at_wall_s" in pace:
        words += f": at this pace level {bar_level:g} at about {pace['bar_at_wall_s']:.0f} s of training"
    return words


class CheckpointJudge:
    """Evaluates checkpoints against the criteria (each evaluation env built at its first use) and keeps the rows.
    A checkpoint's wall time is when the training wrote it, counted from `start_epoch` (time.time()), plus
    `wall_s_before` (the runs a resumed training continues)."""

    def __init__(self, options, criteria: dict, minima: dict, device: str, start_epoch: float,
                 wall_s_before: float = 0.0):
        self.options, self.criteria, self.minima, self.device = options, criteria, minima, device
        self.start_epoch, self.wall_s_before = start_epoch, wall_s_before
        self.evaluators: dict[str, object] = {}
        self.rows: list[dict] = []
        self.levels: list[dict] = []
        """The terrain level of each checkpoint as the training wrote it (`note_level`), before any is judged."""

    def evaluate(self, name: str, path: Path, overrides: tuple = ()) -> dict:
        if name not in self.evaluators:
            options = self.options
            self.evaluators[name] = evaluator(options.task, list(options.overrides), self.device,
                                              options.eval_num_envs, options.eval_episode_length_s,
                                              eval_overrides=overrides)
        return self.evaluators[name](path)

    def shippable_metrics(self, iteration: int, path: Path) -> tuple[dict, list[str]]:
        """(metrics, missed) against the ship bar: the terrain level, then the start rows' evaluation where it reaches
        the bar, then the all-rows falls where the start rows meet the criteria; each step only where the one before
        passed (an evaluation is the cost), and `missed` names the step that failed, not those it spared."""
        from agile.tasks.catalogue import missed_criteria

        noted = [row["mean_terrain_level"] for row in self.levels if row["iteration"] == iteration]  # while training
        metrics = {"mean_terrain_level": noted[0] if noted else mean_terrain_level(path)}
        missed = missed_criteria(metrics, {}, self.minima)
        if missed:
            return metrics, missed
        metrics.update(self.evaluate("start rows", path))
        all_rows = {"all_rows_fall_rate": self.criteria["all_rows_fall_rate"]}
        missed = missed_criteria(metrics, {k: v for k, v in self.criteria.items() if k not in all_rows}, {})
        if missed:
            return metrics, missed
        metrics["all_rows_fall_rate"] = self.evaluate("all rows", path, (ALL_ROWS_OVERRIDE,))["fall_rate"]
        return metrics, missed_criteria(metrics, all_rows, {})

    def written_s(self, path: Path) -> float:
        """When the training wrote the checkpoint, in training wall time."""
        return self.wall_s_before + path.stat().st_mtime - self.start_epoch

    def note_level(self, iteration: int, path: Path) -> None:
        """Keep (and print) a new checkpoint's terrain level and the climb so far, while the training runs; a file
        not yet whole is skipped (the next checkpoint is noted instead)."""
        from agile.rl.checkpoints import UnreadableCheckpointError

        try:
            level = mean_terrain_level(path)
        except UnreadableCheckpointError:
            return
        if level is None:
            return
        self.levels.append({"iteration": iteration, "wall_s": round(self.written_s(path), 1),
                            "mean_terrain_level": level})
        bar = self.minima["mean_terrain_level"]
        pace = climb(self.levels, bar)
        print(f"[agile] {self.levels[-1]['wall_s']:7.1f} s, iteration {iteration}: mean terrain level {level:.3f}"
              + (f" ({climb_in_words(pace, bar)})" if pace else ""), flush=True)

    def __call__(self, iteration: int, path: Path) -> dict:
        from agile.tasks.catalogue import missed_criteria

        written_s = self.written_s(path)
        if self.options.target == "shippable":
            metrics, missed = self.shippable_metrics(iteration, path)
        else:
            metrics = self.evaluate("start rows", path)
            missed = missed_criteria(metrics, self.criteria, self.minima)
        row = {"iteration": iteration, "wall_s": round(written_s, 1), "met": not missed, "missed": missed,
               **{k: metrics[k] for k in CURVE_METRICS if metrics.get(k) is not None},
               "episodes": metrics.get("episodes")}
        if metrics.get("error_by_command"):  # which commands a missed error comes from (yaw rate by turn rate, ...)
            row["error_by_command"] = metrics["error_by_command"]
        self.rows.append(row)
        print(f"[agile] {row['wall_s']:7.1f} s, iteration {iteration}: "
              + ", ".join(f"{k} {row[k]:.3f}" for k in CURVE_METRICS if k in row)
              + (" -> criteria met" if not missed else ""), flush=True)
        return row
