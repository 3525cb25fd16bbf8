"""What every command shares: task/device arguments, config overrides, log folders, one-line failures."""

from __future__ import annotations

import argparse
import logging
import os
import pickle
import sys
from datetime import datetime
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
"""The source checkout agile runs from (with `pip install -e .`); an installed package's is site-packages."""

TRUST_FLAG = "--trust_checkpoint"
"""`agile.rl.checkpoints.TRUST_FLAG`, named here so that --help does not import the simulator."""
CPU_DEFAULT_NUM_ENVS = 4
EXIT_USAGE = 2
"""Exit code of a script refusing its arguments (argparse's own)."""
VERBOSE = False
"""Set by `parse`: whether Warp's module loads, rsl-rl's model printout and library warnings are shown."""

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


def fail(message: str):
    """One line on stderr and exit code 2: what a script says to arguments it cannot use."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(EXIT_USAGE)


def new_parser(description: str) -> argparse.ArgumentParser:
    return argparse.ArgumentParser(description=description, formatter_class=HelpFormatter)


def add_recipe_arg(parser: argparse.ArgumentParser) -> None:
    from agile.run.recipes import RECIPES

    listed = "; ".join(f"{name}: {' '.join(overrides)}" for name, overrides in RECIPES.items())
    parser.add_argument("--recipe", choices=sorted(RECIPES), default=None,
                        help=f"runner settings that train faster, as overrides before the ones given ({listed})")


def parse(parser: argparse.ArgumentParser, argv=None):
    """Parse, check the counts (before anything is built), and set how much the libraries print; a --recipe's
    overrides go before the ones given (which win)."""
    global VERBOSE
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
                fail(f"--{name} must be at least 1, got {value}")
    check_paths(args)
    VERBOSE = bool(getattr(args, "verbose", False))
    configure_output(VERBOSE)
    return args


def check_paths(args) -> None:
    """Refuse a checkpoint, teacher or initial policy that does not exist before anything heavy is imported (a
    multi-agent --init_policy is GROUP=PATH; a multi-agent --checkpoint may be a run folder)."""
    for name in ("checkpoint", "teacher"):
        path = getattr(args, name, None)
        if isinstance(path, str) and not os.path.exists(path):
            fail(f"--{name} file not found: {path}")
    for spec in getattr(args, "init_policy", None) or []:
        path = spec.split("=", 1)[1] if "=" in spec and not os.path.exists(spec) else spec
        if not os.path.exists(path):
            fail(f"--init_policy file not found: {path}")


def configure_output(verbose: bool) -> None:
    """Quiet by default: Warp's output (agile.utils.output, whose switch AGILE_VERBOSE --verbose sets) and the
    deprecation and future warnings of the libraries underneath are for whoever debugs them."""
    import warnings

    from agile.utils import output

    if verbose:
        os.environ[output.VERBOSE_ENV] = "1"
    output.configure_warp_output()
    if not output.verbose():
        for category in (FutureWarning, DeprecationWarning):
            warnings.filterwarnings("ignore", category=category)
        # torch's ONNX exporter warns, for every export, that torchvision's operators are not registered; torch's
        # own logging set-up, at its import, resets its loggers' levels: import it first
        import torch  # noqa: F401

        logging.getLogger("torch.onnx").setLevel(logging.ERROR)


def quiet_stdout():
    """A context that swallows what a library prints (rsl-rl prints its whole actor and critic) unless --verbose."""
    import contextlib
    import io

    return contextlib.nullcontext() if VERBOSE else contextlib.redirect_stdout(io.StringIO())


def git_repos() -> list[str]:
    """The repositories whose state rsl-rl stores with a run: this checkout, when it is one (rsl-rl's default,
    its own installed package, is not a repository and only prints that it is not)."""
    return [str(REPO_ROOT)] if (REPO_ROOT / ".git").exists() else []


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
                        help="stand-up tasks: collect the fallen-state dataset again instead "
                             "of loading the disk cache (the new collection replaces it)")
    parser.add_argument("overrides", nargs="*", help=OVERRIDE_HELP)


def add_checkpoint_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(TRUST_FLAG, action="store_true",
                        help="load checkpoints with full unpickling, which runs any code inside the file: only for "
                             "files you trust (by default only tensors and plain containers are loaded)")


def read_checkpoint(path: str, trust: bool) -> dict:
    """A checkpoint's contents, loaded before the env is built so that a bad file is reported at once."""
    from agile.rl.checkpoints import UnreadableCheckpointError, UntrustedCheckpointError, load_checkpoint

    if not os.path.isfile(path):
        fail(f"checkpoint not found: {path}")
    try:
        return load_checkpoint(path, "cpu", trust=trust)
    except (UntrustedCheckpointError, UnreadableCheckpointError) as err:
        fail(str(err))


def overrides_not_repeated(trained: list[str], roots: dict) -> list[str]:
    """The overrides a checkpoint was trained with (`trained`) under `roots` ({"env": env_cfg, "agent": agent_cfg},
    the configs this command runs with, its own overrides applied) that those configs do not hold, each as
    "<override> (here: <the value here>)". One whose value is already the config's (given again, or the task's
    default since) is not named. The last override of a path counts, as when they are applied."""
    from agile.utils.config import ConfigError, get_by_path, same_setting, split_override

    missing = []
    for path, text in dict(map(split_override, trained)).items():
        root, _, rest = path.partition(".")
        if root not in roots:
            continue
        try:
            here = get_by_path(roots[root], rest, root_name=root)
        except ConfigError:
            missing.append(f"{path}={text} (here: no such field)")
            continue
        if not same_setting(here, text):
            missing.append(f"{path}={text} (here: {here!r})")
    return missing


def warn_overrides_not_repeated(contents: dict, roots: dict, purpose: str) -> None:
    """Say which of the overrides the checkpoint was trained with the configs of this command do not hold
    (checkpoints written before they were recorded, and shipped actor files, hold none: nothing to say)."""
    trained = (contents.get("infos") or {}).get("overrides")
    if not trained:
        return
    missing = overrides_not_repeated(list(trained), roots)
    if missing:
        print(f"[agile] warning: the checkpoint was trained with {len(missing)} override(s) that this command does "
              f"not hold: {'; '.join(missing)}. Add them to {purpose}.", flush=True)


def resolve_device(requested: str | None) -> tuple[str, str | None]:
    """(the device, why it is the CPU where the user did not ask for it, else None)."""
    import warp as wp

    if requested is None:
        if wp.is_cuda_available():
            return "cuda:0", None
        return "cpu", "no GPU found"
    if requested.startswith("cuda") and not wp.is_cuda_available():
        return "cpu", f"{requested} requested but no GPU found"
    return requested, None


def shipped_policy(args) -> str | None:
    """The policy agile ships for args.task, used when no --checkpoint is given. Where it was trained on
    other conditions than the task's current config, those conditions go before the user's overrides
    (which still win), so that it runs in the env it learned in."""
    import agile.tasks

    env_cfg = None
    per_field = agile.tasks.task_spec(args.task).kwargs.get("shipped_policy_per")
    if per_field is not None:  # one shipped policy per value of a config field (per motion): read it after overrides
        env_cfg = load_task(args)[0]
    path = agile.tasks.pretrained_policy(args.task, env_cfg)
    if path is None:
        if per_field is not None:
            name = agile.tasks.task_spec(args.task).kwargs.get("shipped_policy", args.task)
            shipped = sorted(p.stem for p in agile.tasks.PRETRAINED_DIR.glob(f"{name}.*.pt"))
            print(f"[agile] agile ships {args.task} policies for {per_field} = one of "
                  f"{[s.split('.', 1)[1] for s in shipped]} only; give --checkpoint for another")
        return None
    trained_on, overrides = agile.tasks.pretrained_policy_conditions(args.task)
    if overrides:
        print(f"[agile] shipped policy: trained on {trained_on}; running it there ({len(overrides)} overrides from "
              f"{agile.tasks.PRETRAINED_CONDITIONS.name}). Train on the task as registered for a policy of the full "
              "task.")
        args.overrides = [*overrides, *args.overrides]
    return str(path)


def load_task(args) -> tuple:
    """(env cfg, agent cfg, device) for the task, with CLI overrides applied and checked."""
    import agile.tasks
    from agile.rl import make_recurrent
    from agile.utils.config import ConfigError, apply_overrides

    try:
        env_cfg, agent_cfg = agile.tasks.load_cfgs(args.task)
    except KeyError as err:
        fail(err.args[0])
    device, fallback = resolve_device(args.device)
    if args.num_envs is not None:
        env_cfg.num_envs = args.num_envs
    elif device == "cpu":
        env_cfg.num_envs = min(env_cfg.num_envs, CPU_DEFAULT_NUM_ENVS)
    if fallback is not None:  # the count it runs with: the one given, or the small default
        given = "as --num_envs asks" if args.num_envs is not None else "a small count; --num_envs to choose"
        print(f"[agile] {fallback}: running on CPU with {env_cfg.num_envs} envs ({given})")
    if args.seed is not None:
        env_cfg.seed = args.seed
        agent_cfg.seed = args.seed
    rnn_type = getattr(args, "rnn", None)  # benchmark.py builds its own args, without --rnn
    if rnn_type is not None:  # before the overrides, so that they can set the RNN's size
        make_recurrent(agent_cfg, rnn_type=rnn_type)
    try:
        apply_overrides({"env": env_cfg, "agent": agent_cfg}, args.overrides)
    except ConfigError as err:
        fail(str(err))
    return env_cfg, agent_cfg, device


def make_env(task: str, env_cfg, device: str, use_cache: bool = True):
    """The task's env (`agile.run.env.build_env`; `use_cache=False`: a fallen-state dataset is collected anew); a
    config error ends the command in one line."""
    from agile.run.env import build_env
    from agile.utils.config import ConfigError

    print(f"[agile] building {task}: {env_cfg.num_envs} envs on {device} (the first run on a machine compiles "
          f"the Warp kernels, a minute or two)", flush=True)
    try:
        return build_env(task, env_cfg, device, use_cache=use_cache)
    except (ConfigError, ValueError) as err:
        fail(str(err))


def new_log_dir(log_root: str, experiment: str, run_name: str) -> str:
    stamp = datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    name = f"{stamp}_{run_name}" if run_name else stamp
    path = os.path.join(log_root, experiment, name)
    os.makedirs(path, exist_ok=True)
    return path


def latest_checkpoint(log_root: str, experiment: str) -> str:
    """model_<it>.pt with the highest iteration in the newest run folder of an experiment that can be read; a newer
    one that cannot (a write cut short by a crash) is skipped with a warning."""
    import torch

    exp_dir = Path(log_root) / experiment
    runs = sorted((p for p in exp_dir.glob("*") if p.is_dir() and list(p.glob("model_*.pt"))), key=lambda p: p.name)
    if not runs:
        fail(f"no checkpoint found under {exp_dir}")
    models = sorted(runs[-1].glob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1]), reverse=True)
    for path in models:
        try:
            torch.load(path, map_location="cpu", weights_only=True)
        except pickle.UnpicklingError:  # readable, but holds more than tensors: read_checkpoint says so
            return str(path)
        except Exception as err:  # noqa: BLE001 (any failure to read means: not this one)
            print(f"[agile] warning: skipping {path}, it cannot be read ({type(err).__name__}: {err})")
            continue
        return str(path)
    fail(f"no checkpoint under {runs[-1]} can be read")


def dump_configs(log_dir: str, env_cfg, agent_cfg) -> None:
    import yaml

    from agile.utils.config import to_dict

    params = Path(log_dir) / "params"
    params.mkdir(parents=True, exist_ok=True)
    (params / "env.yaml").write_text(yaml.safe_dump(to_dict(env_cfg), sort_keys=False))
    (params / "agent.yaml").write_text(yaml.safe_dump(to_dict(agent_cfg), sort_keys=False))


def load_runner(checkpoint: dict, env, agent_cfg):
    """`agile.run.policy.load_runner`, a checkpoint of the wrong kind reported in one line."""
    from agile.run import policy

    try:
        return policy.load_runner(checkpoint, env, agent_cfg, verbose=VERBOSE)
    except policy.PolicyMismatchError as err:
        fail(str(err))


def load_policy(checkpoint: dict, env, agent_cfg):
    """`agile.run.policy.load_policy`, a checkpoint of the wrong kind reported in one line."""
    from agile.run import policy

    try:
        return policy.load_policy(checkpoint, env, agent_cfg, verbose=VERBOSE)
    except policy.PolicyMismatchError as err:
        fail(str(err))
