"""A LEAPP bundle run by LEAPP's own runtime (`leapp.InferenceManager`), and every reach into LEAPP's internals, in
one place, for the LEAPP version it was written for.

Why a reach: LEAPP 0.7.2 builds each ONNX node's `InferenceSession` with ONNX Runtime's default options, which give
it an intra-op pool of one thread per core whose workers spin between runs. A deployed policy runs once per
control period (0.1-0.2 ms of a 20 ms period at 50 Hz), so those workers spin for the rest of it: measured
2026-12-02 on a 2-core AMD EPYC, the Velocity-G1-History-v0 bundle alone at 50 Hz kept 1.05 cores busy; with one
thread and no spinning, 0.06 cores, and each run took 0.13 ms instead of 0.21 ms. On a robot's computer that core is
the SDK's and the DDS stack's (beside `agile sim_robot` on 2 cores, it delayed commands by up to 115 ms and a walk
ended in a fault). LEAPP takes no options for them, so `_single_threaded_inference_sessions` builds them as LEAPP's
`SimplifiedONNXProgram._ensure_session` does, with one thread and no spinning, in place of its own.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import yaml

from agile.errors import AgileError
from agile.utils.output import quiet_python_output

LEAPP_VERSION = "0.7.2"
"""The leapp version whose internals `_single_threaded_inference_sessions` reaches (pyproject.toml pins it)."""


def control_loop_options():
    """ONNX Runtime options for a policy run once per control period: one intra-op thread that does not spin."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.add_session_config_entry("session.intra_op.allow_spinning", "0")
    return options


def control_loop_inference_session(path: str):
    """An ONNX Runtime `InferenceSession` of `path` (a policy.onnx) with `control_loop_options`, on the CPU."""
    import onnxruntime as ort

    return ort.InferenceSession(path, control_loop_options(), providers=["CPUExecutionProvider"])


def _single_threaded_inference_sessions(manager) -> dict:
    """Give each of the manager's ONNX nodes an `InferenceSession` with one intra-op thread that does not spin; returns them by
    node name. Reads and sets
    `SimplifiedONNXProgram`'s `_source_dir`, `_source_filename`, `_get_providers`, `_load_warp_runtime`, and the
    members `_ensure_session` fills (`_session`, `_input_names`, `_output_metas`, `_active_provider`)."""
    import onnxruntime as ort
    from leapp.backends.export_backend import SimplifiedONNXProgram

    installed = importlib.metadata.version("leapp")
    if installed != LEAPP_VERSION:
        raise AgileError(f"agile.deploy.leapp_runtime builds LEAPP {LEAPP_VERSION}'s ONNX InferenceSessions (its "
                         f"SimplifiedONNXProgram's members); leapp {installed} is installed: "
                         f"pip install leapp=={LEAPP_VERSION}")
    inference_sessions = {}
    for name, node in manager.nodes.items():
        program = node.model
        if not isinstance(program, SimplifiedONNXProgram):
            continue
        model_path = str(Path(program._source_dir) / program._source_filename)
        options = control_loop_options()
        program._load_warp_runtime(options, model_path)
        options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_BASIC  # as LEAPP: its note on ALL
        inference_session = ort.InferenceSession(model_path, options, providers=program._get_providers())
        program._session = inference_session
        program._input_names = [i.name for i in inference_session.get_inputs()]
        program._output_metas = list(inference_session.get_outputs())
        program._active_provider = inference_session.get_providers()[0]
        inference_sessions[name] = inference_session
    return inference_sessions


class BundleRuntime:
    """A LEAPP bundle run by LEAPP's own runtime (`leapp.InferenceManager`), from raw state by input name: what
    `BundlePolicy` (MuJoCo) and `agile.deploy` (a robot's SDK) share. `inputs` are the raw inputs the bundle reads
    (`joint_pos`, `joint_vel`, `root_quat_w` (x, y, z, w), `root_lin_vel_b`, `root_ang_vel_b`, `command`), `target_joints`
    the joints of its position targets; the runtime feeds the last action, histories and hidden state back, from the
    bundle's initial values after reset()."""

    def __init__(self, path: str):
        import torch

        try:
            from leapp import InferenceManager
        except ImportError:
            raise AgileError("--bundle needs the leapp package: pip install 'agile[leapp]'")

        self.torch = torch
        bundle = yaml.safe_load(Path(path).read_text())
        self.node = bundle["pipeline"]["configs"]["task"]
        model = bundle["models"][self.node]
        self.inputs = {i["name"]: i for i in model["inputs"] if i["name"] in bundle["pipeline"]["inputs"][self.node]}
        target = next(o for o in model["outputs"] if o.get("kind") == "target/joint/position")
        self.target_name = f"{self.node}/{target['name']}"
        self.target_joints = list(target["element_names"][-1])
        gains = {o.get("kind"): f"{self.node}/{o['name']}" for o in model["outputs"] if o.get("kind") in ("kp", "kd")}
        self.kp_name, self.kd_name = gains.get("kp"), gains.get("kd")
        with quiet_python_output():  # LEAPP's runtime warns on every machine without CUDA
            self.manager = InferenceManager(path)
        self.inference_sessions = _single_threaded_inference_sessions(self.manager)
        """The ONNX Runtime InferenceSessions LEAPP runs, by node name (one intra-op thread each, no spinning)."""

    def check_joints(self, joint_names: list[str]) -> None:
        """Raise ValueError unless the bundle's joint inputs are `joint_names`, in that order."""
        for name in ("joint_pos", "joint_vel"):
            if name in self.inputs and self.inputs[name]["element_names"][-1] != joint_names:
                raise ValueError(f"bundle input {name}: its joints are not the robot's, in the robot's order")

    def reset(self) -> None:
        self.manager.reset()

    def run(self, raw: dict) -> dict:
        """`raw`: name -> a float sequence for every name in `inputs`. Returns the outputs by name (`target_name`,
        `kp_name`, `kd_name`) as float64 arrays of the action joints."""
        # torch tensors: LEAPP's reset() zeroes its input buffers in place, which numpy arrays would have replaced
        feeds = {f"{self.node}/{name}": self.torch.from_numpy(np.asarray(raw[name], dtype=np.float32)[None])
                 for name in self.inputs}
        outputs = self.manager.run_policy(feeds)
        return {name: np.asarray(value, dtype=np.float64)[0] for name, value in outputs.items()
                if name in (self.target_name, self.kp_name, self.kd_name)}

    def targets_and_gains(self, raw: dict) -> tuple:
        """(targets [rad] of `target_joints`, kp or None, kd or None): the bundle's outputs for `raw`."""
        outputs = self.run(raw)
        return outputs[self.target_name], outputs.get(self.kp_name), outputs.get(self.kd_name)
