"""One env step recorded as a CUDA graph: torch term math and Warp physics in one graph, replayed per step."""

from __future__ import annotations

from collections.abc import Callable

import torch
import warp as wp
from tensordict import TensorDict

from agile.utils.heap import no_collection_while_capturing


def clone_outputs(outputs):
    """Copies of a step's outputs (tensors, TensorDicts, and tuples, lists and dicts of them): a replay
    overwrites the graph's own output buffers."""
    if isinstance(outputs, (torch.Tensor, TensorDict)):
        return outputs.clone()
    if isinstance(outputs, dict):
        return {k: clone_outputs(v) for k, v in outputs.items()}
    if isinstance(outputs, (tuple, list)):
        return type(outputs)(clone_outputs(v) for v in outputs)
    return outputs


class CapturedStep:
    """Runs `step_fn(*inputs, physics_graph=...)` eagerly a few times (lazy allocations, first-call branches),
    then records it once as a CUDA graph and replays that graph with each new input copied into its buffers.

    `step_fn` gets `physics_graph=False` while it is being recorded: the physics loop must then launch its
    kernels one by one into the recording instead of replaying its own graph. Shapes must never change and
    the function must not synchronise with the host.
    """

    WARMUP_CALLS = 3

    def __init__(self, sim, step_fn: Callable):
        self.sim = sim
        self.step_fn = step_fn
        self.graph: torch.cuda.CUDAGraph | None = None
        self._eager_calls = 0
        self._inputs: tuple[torch.Tensor, ...] = ()
        self._outputs = None

    def __call__(self, *inputs: torch.Tensor):
        if self.graph is None and self._eager_calls < self.WARMUP_CALLS:
            self._eager_calls += 1
            return self.step_fn(*inputs, physics_graph=True)
        if self.graph is None:
            self._capture(inputs)
        else:
            for buffer, value in zip(self._inputs, inputs):
                buffer.copy_(value)
        self.graph.replay()
        return clone_outputs(self._outputs)

    def _capture(self, inputs: tuple[torch.Tensor, ...]) -> None:
        self._inputs = tuple(x.clone() for x in inputs)
        # torch records on Warp's stream (Simulation made it torch's current stream), and Warp is told that this
        # stream object is capturing, so its conditional loops become graph nodes
        wp_stream = wp.get_stream(self.sim.wp_device)
        graph = torch.cuda.CUDAGraph()
        with no_collection_while_capturing(), torch.cuda.graph(graph, stream=wp.stream_to_torch(wp_stream),
                                                               capture_error_mode="thread_local"):
            wp.capture_begin(device=self.sim.wp_device, stream=wp_stream, external=True)
            try:
                self._outputs = self.step_fn(*self._inputs, physics_graph=False)
            finally:
                wp.capture_end(device=self.sim.wp_device, stream=wp_stream)
        self.graph = graph
