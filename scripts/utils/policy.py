"""The scripts' policy loading: agile.run.policy, with a checkpoint of the wrong kind reported in one line."""

from __future__ import annotations

from agile.run.policy import PolicyMismatchError, inference_cfg  # noqa: F401 (the scripts import it from here)
from agile.run import policy as run_policy

from utils import cli


def load_runner(checkpoint: dict, env, agent_cfg):
    try:
        return run_policy.load_runner(checkpoint, env, agent_cfg, verbose=cli.VERBOSE)
    except PolicyMismatchError as err:
        cli.fail(str(err))


def load_policy(checkpoint: dict, env, agent_cfg):
    try:
        return run_policy.load_policy(checkpoint, env, agent_cfg, verbose=cli.VERBOSE)
    except PolicyMismatchError as err:
        cli.fail(str(err))
