"""The IO descriptor file (`io_descriptor.yaml` beside an exported policy): its format version, writing and reading.

Everything a deployment needs to rebuild a policy's inputs and apply its outputs without this framework
(`agile.export.io_descriptor` builds it from the env and agent config). Here, below both, so that what reads an
exported policy inside an env (the frozen-policy action term) never imports the export code.
"""

from __future__ import annotations

import yaml

COMMAND_ELEMENTS = ("lin_vel_x", "lin_vel_y", "ang_vel_z", "base_height")
"""A velocity (and height) command's elements in order: a `generated_commands` term of dim n holds the first n."""
IO_DESCRIPTOR_VERSION = 2  # 2: the "policy" section (model input/output names, recurrent hidden state)


def write_io_descriptor(path: str, descriptor: dict) -> None:
    with open(path, "w") as f:
        yaml.safe_dump(descriptor, f, sort_keys=False)


def read_io_descriptor(path: str) -> dict:
    with open(path) as f:
        descriptor = yaml.safe_load(f)
    if descriptor.get("version") != IO_DESCRIPTOR_VERSION:
        raise ValueError(f"{path}: IO descriptor version {descriptor.get('version')}, expected {IO_DESCRIPTOR_VERSION}")
    return descriptor
