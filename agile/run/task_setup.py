"""A task as the commands load it: its configs with overrides applied, the device, its env, its shipped policy, the
checkpoints and run folders of its training. Library functions: keyword arguments, return values, and
`agile.errors.AgileError` (the message naming the field and its valid values) for input they refuse."""

from __future__ import annotations

import logging
import os
import pickle
import tempfile
import typing
from datetime import datetime
from pathlib import Path

from agile.errors import AgileError

REPO_ROOT = Path(__file__).resolve().parents[2]
"""The source checkout agile runs from (with `pip install -e .`); an installed package's is site-packages."""
CPU_DEFAULT_NUM_ENVS = 4
"""The env count on a CPU when none is asked for: enough to run a policy, few enough to build in seconds."""
VERBOSE = False
"""Set by `configure_output`: whether Warp's module loads, rsl-rl's model printout and library warnings are shown."""


class TaskConfigs(typing.NamedTuple):
    """What `load_task` returns: the configs to build and train with, and the device they run on."""
    env_cfg: object
    agent_cfg: object
    device: str


class ShippedPolicy(typing.NamedTuple):
    """What `shipped_policy` returns: the file (None: agile ships none for the task, or none for its config) and
    the overrides to run it with (its training conditions before the caller's, which win)."""
    path: str | None
    overrides: list[str]


def configure_output(verbose: bool) -> None:
    """Quiet by default: Warp's output (agile.utils.output, whose switch AGILE_VERBOSE `verbose` sets) and the
    deprecation and future warnings of the libraries underneath are for whoever debugs them."""
    import warnings

    from agile.utils import output

    global VERBOSE
    VERBOSE = verbose
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
    """A context that swallows what a library prints (rsl-rl prints its whole actor and critic) unless verbose."""
    import contextlib
    import io

    return contextlib.nullcontext() if VERBOSE else contextlib.redirect_stdout(io.StringIO())


def check_task(task: str) -> None:
    """Raise `agile.tasks.UnknownTaskError` (an AgileError listing the registered tasks) unless `task` is one."""
    import agile.tasks

    agile.tasks.task_spec(task)


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


def load_task(*, task: str, num_envs: int | None = None, device: str | None = None, seed: int | None = None,
              rnn: str | None = None, overrides: typing.Sequence[str] = (), trainer: str = "rsl_rl") -> TaskConfigs:
    """The task's env and agent configs with `overrides` ("env.<path>=<value>", "agent.<path>=<value>") applied and
    checked, and the device (cuda:0 when a GPU is present and `device` is None). `num_envs` None: the task's on a GPU,
    `CPU_DEFAULT_NUM_ENVS` on a CPU. `rnn` ("lstm" or "gru"): a recurrent actor and critic, sized by the overrides.
    `trainer`: whose agent config (`agile.tasks.load_cfgs`)."""
    import agile.tasks
    from agile.rl import make_recurrent
    from agile.utils.config import apply_overrides

    if num_envs is not None and num_envs < 1:
        raise AgileError(f"num_envs must be at least 1, got {num_envs}")
    if rnn not in (None, "lstm", "gru"):
        raise AgileError(f"rnn must be one of 'lstm', 'gru' (or None), got {rnn!r}")
    trainers = ["rsl_rl", *agile.tasks.task_spec(task).trainer_cfgs]
    if trainer not in trainers:
        raise AgileError(f"trainer {trainer!r}: task {task} has a config for {', '.join(trainers)}")
    env_cfg, agent_cfg = agile.tasks.load_cfgs(task, trainer)
    device, fallback = resolve_device(device)
    if num_envs is not None:
        env_cfg.num_envs = num_envs
    elif device == "cpu":
        env_cfg.num_envs = min(env_cfg.num_envs, CPU_DEFAULT_NUM_ENVS)
    if fallback is not None:  # the count it runs with: the one asked for, or the small default
        small = " (a small count on a CPU; --num_envs to choose)" if num_envs is None else ""
        print(f"[agile] {fallback}: running on CPU with {plural(env_cfg.num_envs, 'env')}{small}")
    if seed is not None:
        env_cfg.seed = seed
        agent_cfg.seed = seed
    if rnn is not None:  # before the overrides, so that they can set the RNN's size
        make_recurrent(agent_cfg, rnn_type=rnn)
    apply_overrides({"env": env_cfg, "agent": agent_cfg}, list(overrides))
    return TaskConfigs(env_cfg, agent_cfg, device)


def check_overrides(*, task: str, overrides: typing.Sequence[str]) -> None:
    """Raise the ConfigError (an AgileError) naming the field that one of `overrides` gets wrong, as `agile train`
    would on reading them: for a command that starts the training as a process of its own, before it does (none
    given: nothing to read, and no config loaded)."""
    if overrides:
        load_task(task=task, device="cpu", num_envs=1, overrides=overrides)


def check_writable(path: str, field: str) -> None:
    """Refuse (AgileError naming `field`) a path that cannot be written: under a file, or in a folder that exists
    and may not be written (a folder still to make is made by the command, under the nearest one that exists)."""
    target = os.path.abspath(path)
    existing = target
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if existing != target and not os.path.isdir(existing):
        raise AgileError(f"{field} {path}: {existing} is a file, not a folder")
    folder = existing if os.path.isdir(existing) else os.path.dirname(existing)
    try:  # a file made and removed at once: what the OS allows (permissions, a read-only or virtual file system)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        raise AgileError(f"{field} {path}: {folder} cannot be written ({err.strerror})") from err


def plural(count: int, noun: str) -> str:
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def shipped_policy(*, task: str, overrides: typing.Sequence[str] = ()) -> ShippedPolicy:
    """The policy agile ships for `task` and the overrides to run it with: where it was trained on other conditions
    than the task's current config (agile/data/policy/conditions.yaml), those conditions go before `overrides` (which
    still win), so that it runs in the env it learned in. A task that ships one policy per value of a config field
    (per motion) reads that field after `overrides`."""
    import agile.tasks

    spec = agile.tasks.task_spec(task)
    env_cfg = None
    if spec.shipped_policy_per is not None:
        env_cfg = load_task(task=task, device="cpu", num_envs=1, overrides=overrides).env_cfg
    path = agile.tasks.pretrained_policy(task, env_cfg)
    if path is None:
        if spec.shipped_policy_per is not None:
            name = spec.shipped_policy or task
            shipped = sorted(p.stem.split(".", 1)[1] for p in agile.tasks.PRETRAINED_DIR.glob(f"{name}.*.pt"))
            print(f"[agile] agile ships {task} policies for {spec.shipped_policy_per} = one of {shipped} only; give "
                  "a checkpoint for another")
        return ShippedPolicy(None, list(overrides))
    trained_on, conditions = agile.tasks.pretrained_policy_conditions(task)
    if conditions:
        print(f"[agile] shipped policy: trained on {trained_on}; running it there ({len(conditions)} overrides from "
              f"{agile.tasks.PRETRAINED_CONDITIONS.name}). Train on the task as registered for a policy of the full "
              "task.")
    return ShippedPolicy(str(path), [*conditions, *overrides])


def policy_to_run(*, task: str, checkpoint: str | None, overrides: typing.Sequence[str] = ()) -> ShippedPolicy:
    """The checkpoint to run and the overrides to run it with: `checkpoint` with `overrides` as given, or without
    one the shipped policy (`shipped_policy`); AgileError where there is neither."""
    if checkpoint is not None:
        return ShippedPolicy(str(checkpoint), list(overrides))
    shipped = shipped_policy(task=task, overrides=overrides)
    if shipped.path is None:
        raise AgileError(f"no checkpoint given and agile ships no policy for {task}")
    return shipped


def make_env(*, task: str, env_cfg, device: str, collect_datasets_anew: bool = False):
    """The task's env as training builds it (`agile.run.env.build_env`): a ManagerBasedRLEnv, or a MultiAgentEnv for a
    multi-agent config. `collect_datasets_anew`: a task whose env builds a dataset at its start (its task spec's
    `startup_dataset`) collects it again instead of loading the disk cache."""
    import agile.tasks
    from agile.run.env import build_env

    if collect_datasets_anew and agile.tasks.task_spec(task).startup_dataset is None:
        with_dataset = [t for t in agile.tasks.registered_tasks() if agile.tasks.task_spec(t).startup_dataset]
        raise AgileError(f"collect_datasets_anew (--no_cache): {task} builds no dataset at its start; the tasks that "
                         f"do: {', '.join(with_dataset)}")
    print(f"[agile] building {task}: {plural(env_cfg.num_envs, 'env')} on {device} (the first run on a machine "
          "compiles the Warp kernels, a minute or two)", flush=True)
    try:
        return build_env(task, env_cfg, device, use_cache=not collect_datasets_anew)
    except ValueError as err:  # a config the env cannot be built from (ConfigError is one)
        raise AgileError(str(err)) from err


def read_checkpoint(path: str, trust: bool = False) -> dict:
    """A checkpoint's contents, loaded on the CPU before the env is built so that a bad file is reported at once.
    `trust`: full unpickling (runs code inside the file), else only tensors and plain containers."""
    from agile.rl.checkpoints import UnreadableCheckpointError, UntrustedCheckpointError, load_checkpoint

    if not os.path.isfile(path):
        raise AgileError(f"checkpoint not found: {path}")
    try:
        return load_checkpoint(path, "cpu", trust=trust)
    except (UntrustedCheckpointError, UnreadableCheckpointError) as err:
        raise AgileError(str(err)) from err


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


def load_runner(checkpoint: dict, env, agent_cfg):
    """`agile.run.policy.load_runner` (a checkpoint of the wrong kind: AgileError)."""
    from agile.run import policy

    try:
        return policy.load_runner(checkpoint, env, agent_cfg, verbose=VERBOSE)
    except policy.PolicyMismatchError as err:
        raise AgileError(str(err)) from err


def load_policy(checkpoint: dict, env, agent_cfg):
    """`agile.run.policy.load_policy` (a checkpoint of the wrong kind: AgileError)."""
    from agile.run import policy

    try:
        return policy.load_policy(checkpoint, env, agent_cfg, verbose=VERBOSE)
    except policy.PolicyMismatchError as err:
        raise AgileError(str(err)) from err


def git_repos() -> list[str]:
    """The repositories whose state rsl-rl stores with a run: this checkout, when it is one (rsl-rl's default,
    its own installed package, is not a repository and only prints that it is not)."""
    return [str(REPO_ROOT)] if (REPO_ROOT / ".git").exists() else []


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
        raise AgileError(f"no checkpoint found under {exp_dir}")
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
    raise AgileError(f"no checkpoint under {runs[-1]} can be read")


def dump_configs(log_dir: str, env_cfg, agent_cfg) -> None:
    import yaml

    from agile.utils.config import to_dict

    params = Path(log_dir) / "params"
    params.mkdir(parents=True, exist_ok=True)
    (params / "env.yaml").write_text(yaml.safe_dump(to_dict(env_cfg), sort_keys=False))
    (params / "agent.yaml").write_text(yaml.safe_dump(to_dict(agent_cfg), sort_keys=False))
