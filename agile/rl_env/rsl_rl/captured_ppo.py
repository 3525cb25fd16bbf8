"""SyncFreePPO whose mini-batch step runs as one CUDA graph: the same math, a few graph launches per update instead
of a few thousand kernel launches from Python.

An update of AGILE's PPO settings takes 20 mini-batch steps (5 epochs x 4 mini-batches), each a forward and backward
pass of actor and critic over the mirrored batch, the clipped losses, gradient clipping and a fused Adam step: about
a thousand small kernels, most of them shorter than the time Python takes to launch them. Here each update captures
its first mini-batch step into a CUDA graph (the step reads its mini-batch from fixed buffers, into which each
mini-batch is copied) and replays it for that and every later mini-batch. SyncFreePPO already keeps the step free
of host synchronisation (the learning rate adapted on the device, the losses summed there), which capture needs.

The graph is captured afresh at every update, so whatever changes between updates reaches it: the observation
normalisers (rsl-rl replaces their std tensor when it learns a rollout), an annealed entropy coefficient, the
actor held during a critic warm-up, a resumed optimizer state. The first update runs eagerly: it creates the
optimizer's state and the autograd and cuBLAS workspaces that capture must not allocate for the first time.

The rollout must be collected without an autograd record (under `torch.inference_mode()`, as rsl-rl's runner
collects it): an acting pass with one keeps the parameters' gradient accumulators made on the default stream
alive, and a captured backward that reaches them makes that stream wait on the capture, which CUDA refuses
(`cudaErrorStreamCaptureImplicit`: the first GPU test, whose rollout kept an autograd record; the runner's
benchmark, under inference mode, captured its updates).

Select it with `agent.algorithm.class_name=agile.rl_env.rsl_rl.captured_ppo:CapturedPPO`. On a CPU, or across
several GPUs (the gradients' all-reduce is not captured), it updates as SyncFreePPO does.
"""

from __future__ import annotations

from itertools import chain

import torch
from rsl_rl.storage import RolloutStorage

from agile.rl_env.rsl_rl.sync_free_ppo import SyncFreePPO


class CapturedPPO(SyncFreePPO):
    def __init__(self, *args, device: str = "cpu", **kwargs):
        super().__init__(*args, device=device, **kwargs)
        self.captures = torch.device(self.device).type == "cuda" and not self.is_multi_gpu
        """Whether updates replay a captured mini-batch step (else each step runs eagerly, as in SyncFreePPO)."""
        if self.captures:  # a graph replays Adam's step only if its step count lives on the device
            self.optimizer = torch.optim.Adam(chain(self.actor.parameters(), self.critic.parameters()),
                                              lr=self.learning_rate_t, fused=True, capturable=True)
            self.stream = torch.cuda.Stream(torch.device(self.device))
            """The side stream of the steps, the first eager update's included (what capture sees first there was
            created there: cuBLAS's workspace, autograd's state)."""
        self.updates_done = 0
        self.mini_batch = None
        """The fixed buffers the captured step reads (a RolloutStorage.Batch), made at the first captured update."""
        self.graph = None
        """The newest update's captured step."""
        self.sums = torch.zeros(4, device=self.device)
        """value, surrogate, entropy and symmetry losses summed over an update's mini-batches (written by the graph)."""

    def update(self) -> dict[str, float]:
        if not self.captures:
            return super().update()
        self.sums.zero_()
        self.stream.wait_stream(torch.cuda.current_stream())  # the rollout written
        with torch.cuda.stream(self.stream):
            if self.updates_done == 0:  # eager: it creates what capture must not allocate for the first time
                for batch in self.storage.mini_batch_generator(self.num_mini_batches, self.num_learning_epochs):
                    self.mini_batch_step(batch, self.sums)
            else:
                self._replay_captured_steps()
        torch.cuda.current_stream().wait_stream(self.stream)
        self.updates_done += 1
        losses = self.finish_update(self.sums)
        self.optimizer.zero_grad(set_to_none=True)  # the gradients lived in the graph's memory, freed with it
        return losses

    def _replay_captured_steps(self) -> None:
        """Capture the first mini-batch's step (capture records, it does not run), replay it for every mini-batch."""
        graph = None
        for batch in self.storage.mini_batch_generator(self.num_mini_batches, self.num_learning_epochs):
            self._load_mini_batch(batch)
            if graph is None:
                # captured on self.stream by the graph's own calls: the torch.cuda.graph context would also empty the
                # allocator's cache at every update, handing the rollout's memory back to CUDA
                graph = torch.cuda.CUDAGraph()
                graph.capture_begin()
                try:
                    self.mini_batch_step(self._fixed_batch(), self.sums)
                finally:
                    graph.capture_end()
            graph.replay()
        # kept until the next update captures its own: its memory is released only once its replays have run
        self.graph = graph

    def _load_mini_batch(self, batch: RolloutStorage.Batch) -> None:
        """Copy a mini-batch into the fixed buffers (allocated from the first one)."""
        fields = ("actions", "values", "advantages", "returns", "old_actions_log_prob")
        if self.mini_batch is None:
            self.mini_batch = RolloutStorage.Batch(
                observations=batch.observations.clone(), **{name: getattr(batch, name).clone() for name in fields},
                old_distribution_params=tuple(p.clone() for p in batch.old_distribution_params))
            return
        self.mini_batch.observations.update_(batch.observations)
        for name in fields:
            getattr(self.mini_batch, name).copy_(getattr(batch, name))
        for fixed, param in zip(self.mini_batch.old_distribution_params, batch.old_distribution_params):
            fixed.copy_(param)

    def _fixed_batch(self) -> RolloutStorage.Batch:
        """A Batch over the fixed buffers: the step reassigns a batch's fields (advantage normalisation, the
        mirrored samples), so it gets its own object each time, never the buffers' holder."""
        fixed = self.mini_batch
        return RolloutStorage.Batch(observations=fixed.observations, actions=fixed.actions, values=fixed.values,
                                    advantages=fixed.advantages, returns=fixed.returns,
                                    old_actions_log_prob=fixed.old_actions_log_prob,
                                    old_distribution_params=fixed.old_distribution_params)
