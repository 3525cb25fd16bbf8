"""Plot learning curves from RSL-RL tensorboard logs (needs matplotlib: pip install matplotlib).

    agile plot_learning_curve logs/rsl_rl/velocity_t1/2026-11-24_05-26-34     # -> <run>/learning_curve.png
    agile plot_learning_curve logs/rsl_rl/velocity_t1/run_a logs/rsl_rl/velocity_t1/run_b --out ab.png
    agile plot_learning_curve --run "G1=logs/.../first_run,logs/.../its_resumption" --out docs/curve.png
    agile plot_learning_curve RUN --tag Curriculum/terrain_levels --tag Loss/behavior

A run is a run folder (any task: PPO, distillation; a multi-agent run's folder gives one curve per agent group,
from its group subfolders) or event files. A run given as several (comma-separated, with --run LABEL=...) is
joined in order, e.g. a run and its resumption: each replaces the earlier ones from its first iteration on.
Without --tag, the panels are the default tags the first run logged. From Python:
`plot_learning_curve(runs=[...], labelled=[...], out=..., tags=[...])` returns the PNG's path.
"""

from __future__ import annotations

import os
from pathlib import Path

from agile.run.arguments import command
from agile.run import arguments
from agile.errors import AgileError

DEFAULT_TAGS = ["Train/mean_episode_length", "Train/mean_reward", "Episode_Reward/track_lin_vel_xy_exp",
                "Loss/behavior", "Curriculum/terrain_levels"]
"""The panels drawn by default, those of them a run logged (Loss/behavior: distillation)."""
AXIS_LABELS = {"Train/mean_episode_length": "mean episode length [steps]", "Train/mean_reward": "mean reward",
               "Episode_Reward/track_lin_vel_xy_exp": "linear velocity tracking reward",
               "Loss/behavior": "distillation loss (student vs teacher)",
               "Curriculum/terrain_levels": "mean terrain level (row)"}
EVENTS_GLOB = "events.out.tfevents.*"


def join_resumed(pieces: list[list[tuple[int, float]]]) -> tuple[list[int], list[float]]:
    """One curve from a run and its resumptions, each a list of (iteration, value). A resumption restarts
    from a saved checkpoint, so it replaces the earlier pieces from its first iteration on (the iterations
    they logged after that checkpoint belong to a branch that no longer leads anywhere)."""
    points: list[tuple[int, float]] = []
    for piece in map(sorted, pieces):
        if piece:
            points = [point for point in points if point[0] < piece[0][0]] + piece
    return [step for step, _ in points], [value for _, value in points]


def event_files(path: str) -> list[str]:
    """The event files of a path: the file itself, or those directly in a run folder (in name order: the
    writer names them by start time)."""
    if os.path.isfile(path):
        return [path]
    if not os.path.isdir(path):
        raise AgileError(f"no such run folder or event file: {path}")
    return sorted(str(p) for p in Path(path).glob(EVENTS_GLOB))


def curves_of(label: str | None, paths: list[str]) -> list[tuple[str, list[str]]]:
    """(label, event files) for each curve that `paths` (a run and its resumptions) give: one, or one per agent
    group where the folders hold no event files of their own but group subfolders do (a multi-agent run)."""
    files = [f for path in paths for f in event_files(path)]
    if files:
        return [(label or Path(paths[0]).name, files)]
    groups = sorted({p.parent.name for path in paths if os.path.isdir(path)
                     for p in Path(path).glob(f"*/{EVENTS_GLOB}")})
    if not groups:
        raise AgileError(f"no tensorboard event files in {', '.join(paths)} (nor in its agent-group subfolders)")
    label = label or Path(paths[0]).name
    return [(f"{label}/{group}", [f for path in paths for f in event_files(os.path.join(path, group))
                                  if os.path.isdir(os.path.join(path, group))]) for group in groups]


def read_run(files: list[str]) -> dict[str, tuple[list[int], list[float]]]:
    """{tag: (iterations, values)} of every scalar in a run's event files, resumptions joined."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    pieces: dict[str, list] = {}
    for path in files:
        events = EventAccumulator(path, size_guidance={"scalars": 0})
        events.Reload()
        for tag in events.Tags()["scalars"]:
            pieces.setdefault(tag, []).append([(event.step, event.value) for event in events.Scalars(tag)])
    return {tag: join_resumed(tag_pieces) for tag, tag_pieces in pieces.items()}


def curves_of_runs(runs=(), labelled=()) -> list[tuple[str, list[str]]]:
    """(label, event files) of every curve: one per run folder or event file in `runs` (labelled by its name), and
    one per "LABEL=path[,path...]" in `labelled` (a run joined from its pieces: a run and its resumptions)."""
    curves = [curve for folder in runs for curve in curves_of(None, [folder])]
    for run in labelled:
        label, _, paths = run.partition("=")
        if not paths:
            raise AgileError(f"--run takes LABEL=path[,path...], got '{run}'")
        curves += curves_of(label, paths.split(","))
    if not curves:
        raise AgileError("give a run folder (or --run LABEL=path[,path...])")
    return curves


def plot_learning_curve(*, runs=(), labelled=(), out: str | None = None, tags=None, title: str = "") -> Path:
    """Draw the learning curves of `runs` (run folders or event files, one curve each) and `labelled` runs
    ("LABEL=path[,path...]", a run joined from a run and its resumptions), one panel per tensorboard scalar of `tags`
    (default: those of DEFAULT_TAGS the first run logged), into the PNG `out` (default: learning_curve.png in the
    first run's folder); returns its path. Raises AgileError for a run without event files, tags no run logged, or
    matplotlib missing."""
    curves = curves_of_runs(runs, labelled)
    try:
        import matplotlib
    except ImportError:
        raise AgileError("plotting needs matplotlib, an optional extra: pip install -e \".[plot]\"")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    scalars = {label: read_run(files) for label, files in curves}
    first = scalars[curves[0][0]]
    tags = list(tags or [tag for tag in DEFAULT_TAGS if tag in first])
    if not tags:
        raise AgileError(f"{curves[0][0]} logged none of {DEFAULT_TAGS}; choose with --tag from: {sorted(first)}")
    fig, axes = plt.subplots(1, len(tags), figsize=(5 * len(tags), 4), squeeze=False)
    for ax, tag in zip(axes[0], tags):
        for label, run_scalars in scalars.items():
            if tag not in run_scalars:
                print(f"[agile] {label} did not log '{tag}': not in that panel")
                continue
            ax.plot(*run_scalars[tag], label=label)
        ax.set_xlabel("iteration")
        ax.xaxis.set_major_locator(MaxNLocator(5, integer=True))  # five-digit iterations stay apart
        ax.set_ylabel(AXIS_LABELS.get(tag, tag))
    if not any(ax.lines for ax in axes[0]):
        plt.close(fig)
        raise AgileError(f"no run logged {tags}; the first run's scalars: {sorted(first)}")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    first_path = runs[0] if runs else labelled[0].partition("=")[2].split(",")[0]
    out = out or os.path.join(first_path if os.path.isdir(first_path) else os.path.dirname(first_path),
                              "learning_curve.png")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print(f"wrote {out}")
    return Path(out)


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("runs", nargs="*", help="run folders or event files, one curve each (label: the name)")
    parser.add_argument("--run", action="append", default=None, help="LABEL=path[,path...]: a labelled run, "
                        "joined from a run and its resumptions")
    parser.add_argument("--out", default=None, help="PNG file (default: learning_curve.png in the first run folder)")
    parser.add_argument("--tag", action="append", default=None,
                        help=f"tensorboard scalar to plot, one panel each (default: those of {', '.join(DEFAULT_TAGS)} "
                             "that the first run logged)")
    parser.add_argument("--title", default="")
    args = arguments.parse(parser, argv)
    plot_learning_curve(runs=args.runs, labelled=args.run or (), out=args.out, tags=args.tag, title=args.title)


if __name__ == "__main__":
    main()
