"""Plot learning curves from RSL-RL tensorboard event files (needs matplotlib: pip install matplotlib).

    python scripts/plot_learning_curve.py --run "G1=logs/.../events.out.tfevents.*" --out docs/curve.png
    python scripts/plot_learning_curve.py --run "G1=..." --tag Curriculum/terrain_levels --tag Train/mean_reward \
        --out t.png

A run given as several files (comma-separated) is joined in order, e.g. a run and its resumption: each file
replaces the earlier ones from its first iteration on.
"""

from __future__ import annotations

import argparse
from utils import cli

DEFAULT_TAGS = ["Train/mean_episode_length", "Train/mean_reward", "Episode_Reward/track_lin_vel_xy_exp"]
AXIS_LABELS = {"Train/mean_episode_length": "mean episode length [steps]", "Train/mean_reward": "mean reward",
               "Episode_Reward/track_lin_vel_xy_exp": "linear velocity tracking reward",
               "Curriculum/terrain_levels": "mean terrain level (row)"}


def join_resumed(pieces: list[list[tuple[int, float]]]) -> tuple[list[int], list[float]]:
    """One curve from a run and its resumptions, each a list of (iteration, value). A resumption restarts
    from a saved checkpoint, so it replaces the earlier pieces from its first iteration on (the iterations
    they logged after that checkpoint belong to a branch that no longer leads anywhere)."""
    points: list[tuple[int, float]] = []
    for piece in map(sorted, pieces):
        if piece:
            points = [point for point in points if point[0] < piece[0][0]] + piece
    return [step for step, _ in points], [value for _, value in points]


def read_scalars(files: list[str], tag: str) -> tuple[list[int], list[float]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    pieces = []
    for path in files:
        events = EventAccumulator(path, size_guidance={"scalars": 0})
        events.Reload()
        if tag in events.Tags()["scalars"]:
            pieces.append([(event.step, event.value) for event in events.Scalars(tag)])
    return join_resumed(pieces)


def main(argv=None) -> None:
    parser = cli.new_parser(__doc__)
    parser.add_argument("--run", action="append", required=True, help="LABEL=file[,file...]")
    parser.add_argument("--out", required=True, help="PNG file")
    parser.add_argument("--tag", action="append", default=None,
                        help=f"tensorboard scalar to plot, one panel each (default: {', '.join(DEFAULT_TAGS)})")
    parser.add_argument("--title", default="")
    args = cli.parse(parser, argv)
    tags = args.tag or DEFAULT_TAGS

    try:
        import matplotlib
    except ImportError:
        cli.fail("plotting needs matplotlib, an optional extra: pip install -e \".[plot]\"")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tags), figsize=(5 * len(tags), 4), squeeze=False)
    axes = axes[0]
    for run in args.run:
        label, _, files = run.partition("=")
        for ax, tag in zip(axes, tags):
            steps, values = read_scalars(files.split(","), tag)
            if not steps:
                cli.fail(f"no scalar '{tag}' in {files}")
            ax.plot(steps, values, label=label)
            ax.set_xlabel("PPO iteration")
            ax.set_ylabel(AXIS_LABELS.get(tag, tag))
    axes[0].legend()
    fig.suptitle(args.title)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
