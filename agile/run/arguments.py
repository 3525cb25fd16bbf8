"""The command layer every `agile` command shares: its parser, the task/device arguments, the checks made before
anything heavy is imported, and the one place where a refused input becomes one line and exit code 2.

Only the commands (each module's `main`, `agile/cli.py`, `scripts/`) use this module: the library functions of
`agile.run` take keyword arguments and raise `agile.errors.AgileError`."""

from __future__ import annotations

import argparse
import functools
import os
import sys

from agile.errors import AgileError
from agile.run import task_setup

TRUST_FLAG = "--trust_checkpoint"
"""`agile.rl.checkpoints.TRUST_FLAG`, named here so that --help does not import the simulator."""
CPU_DEFAULT_NUM_ENVS = 4
"""The env count on a CPU when --num_envs is not given (`agile.run.task_setup.CPU_DEFAULT_NUM_ENVS`)."""
EXIT_USAGE = 2
"""Exit code of a command refusing its arguments (argparse's own)."""
EXIT_INTERRUPTED = 130
"""Exit code after Ctrl-C (128 + SIGINT, what a shell reports)."""

OVERRIDE_HELP = ("config overrides as path=value, any field of the env or agent config: a number "
                 "env.rewards.track_lin_vel_xy_exp.weight=2.0, a string agent.actor.activation=relu, a list "
                 "(a quoted Python literal) 'agent.actor.hidden_dims=[128, 128]', None env.scene.terrain=null")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """--help keeps the description's line breaks and shows each option's default where it has one that its help
    does not already name (no "(default: None)" after "(default: the task's)")."""

    def _get_help_string(self, action):
        help_text = action.help or ""
        if "(default" in help_text or action.default in (None, False, argparse.SUPPRESS) or not action.option_strings:
            return help_text
        return help_text + " (default: %(default)s)"


def command(main):
    """A command's `main(argv)`: an `AgileError` it raises is printed as one line on stderr and ends it with exit code
    2 (as argparse ends on a bad option), Ctrl-C with one line and 130, and a closed pipe (`agile ... | head`)
    quietly."""

    @functools.wraps(main)
    def run(argv=None):
        try:
            result = main(argv)
            sys.stdout.flush()  # a closed pipe fails here, not in the interpreter's flush at exit
            return result
        except AgileError as err:
            print(f"error: {err}", file=sys.stderr)
            raise SystemExit(EXIT_USAGE) from None
        except KeyboardInterrupt:
            print("\n[agile] interrupted", file=sys.stderr)
            raise SystemExit(EXIT_INTERRUPTED) from None
        except BrokenPipeError:
            # the reader left (`| head`): what is still buffered for stdout goes nowhere, instead of failing again
            # when the interpreter flushes it at exit
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0

    return run


def new_parser(description: str) -> argparse.ArgumentParser:
    return argparse.ArgumentParser(description=description, formatter_class=HelpFormatter)


def add_recipe_arg(parser: argparse.ArgumentParser) -> None:
    from agile.run.recipes import RECIPES

    listed = "; ".join(f"{name}: {' '.join(overrides)}" for name, overrides in RECIPES.items())
    parser.add_argument("--recipe", choices=sorted(RECIPES), default=None,
                        help=f"runner settings that train faster, as overrides before the ones given ({listed})")


def parse(parser: argparse.ArgumentParser, argv=None):
    """Parse, check the counts and the paths (before anything is built), and set how much the libraries print; a
    --recipe's overrides go before the ones given (which win)."""
    # intermixed: overrides may come before, between or after the options (`--max_iterations 3 agent.x=1` after an
    # `env.y=2` is what a command line built in parts looks like; plain parse_args refuses the second group)
    args = parser.parse_intermixed_args(argv)
    if getattr(args, "recipe", None) is not None:
        from agile.run.recipes import RECIPES

        args.overrides = [*RECIPES[args.recipe], *args.overrides]
    for name in ("num_envs", "num_steps", "num_episodes", "max_iterations"):
        values = getattr(args, name, None)
        for value in values if isinstance(values, list) else [values]:  # benchmark.py takes several env counts
            if value is not None and value < 1:
                raise AgileError(f"--{name} must be at least 1, got {value}")
    check_paths(args)
    task_setup.configure_output(verbose=bool(getattr(args, "verbose", False)))
    return args


def parse_number_items(items: list[str], message: str) -> dict[str, float]:
    """{name: number} of NAME=NUMBER items, split at the last "=" (a name may be a regex holding one); AgileError with
    `message` (its "{item}" the item) for an item without a name or a number."""
    parsed = {}
    for item in items:
        name, sep, value = item.rpartition("=")
        try:
            parsed[name] = float(value)
        except ValueError:
            sep = ""
        if not sep or not name:
            raise AgileError(message.format(item=item))
    return parsed


def given_overrides(args) -> list[str]:
    """The overrides given on the command line, without the --recipe's that `parse` put before them (for a library
    function that takes the recipe and applies it itself)."""
    from agile.run.recipes import RECIPES

    return list(args.overrides[len(RECIPES[args.recipe]):] if getattr(args, "recipe", None) else args.overrides)


def check_paths(args) -> None:
    """Refuse a checkpoint, teacher or initial policy that does not exist, and an output path that cannot be written,
    before anything heavy is imported (a multi-agent --init_policy is GROUP=PATH; a multi-agent --checkpoint may be
    a run folder)."""
    for name in ("checkpoint", "teacher"):
        path = getattr(args, name, None)
        if isinstance(path, str) and not os.path.exists(path):
            raise AgileError(f"--{name} file not found: {path}")
    for spec in getattr(args, "init_policy", None) or []:
        path = spec.split("=", 1)[1] if "=" in spec and not os.path.exists(spec) else spec
        if not os.path.exists(path):
            raise AgileError(f"--init_policy file not found: {path}")
    for name in ("out", "usd", "video", "log_root"):
        path = getattr(args, name, None)
        if isinstance(path, str):
            task_setup.check_writable(path, f"--{name}")


def add_common_args(parser: argparse.ArgumentParser, task_required: bool = True) -> None:
    """--task and the arguments every env-building command takes. `task_required` False: the command checks
    --task itself (it has a mode that builds no env)."""
    parser.add_argument("--task", required=task_required, help="registered task ID, e.g. Velocity-T1-v0")
    parser.add_argument("--num_envs", type=int, default=None,
                        help=f"parallel envs (default: the task's on GPU, {CPU_DEFAULT_NUM_ENVS} on CPU)")
    parser.add_argument("--device", default=None, help="cuda:0 or cpu (default: cuda:0 when a GPU is present)")
    parser.add_argument("--seed", type=int, default=None, help="random seed")
    parser.add_argument("--rnn", choices=("lstm", "gru"), default=None,
                        help="recurrent actor and critic (rsl-rl's RNNModel) instead of the task's MLPs, sized by "
                             "agent.actor.rnn_hidden_dim=... etc.; needed again to play, eval or export the checkpoint")
    parser.add_argument("--verbose", action="store_true",
                        help="show Warp's kernel loads, rsl-rl's model printout and library warnings")
    parser.add_argument("--no_cache", action="store_true",
                        help="tasks that build a dataset when their env starts (stand-up: fallen states): collect it "
                             "again instead of loading the disk cache (the new collection replaces it)")
    parser.add_argument("overrides", nargs="*", help=OVERRIDE_HELP)


def add_checkpoint_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(TRUST_FLAG, action="store_true",
                        help="load checkpoints with full unpickling, which runs any code inside the file: only for "
                             "files you trust (by default only tensors and plain containers are loaded)")


def task_options(args, **changes) -> dict:
    """The keyword arguments of `agile.run.task_setup.load_task` from the common arguments (`changes` replace some)."""
    options = {"task": args.task, "num_envs": args.num_envs, "device": args.device, "seed": args.seed,
               "rnn": getattr(args, "rnn", None), "overrides": list(args.overrides)}
    options.update(changes)
    return options
