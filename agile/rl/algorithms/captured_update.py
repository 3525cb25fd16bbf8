"""The sync-free PPO update whose mini-batch step runs as one CUDA graph: the same math, a few graph launches per update
instead of a few thousand kernel launches from Python.

An update of AGILE's PPO settings takes 20 mini-batch steps (5 epochs x 4 mini-batches), each a forward and backward
pass of actor and critic over the mirrored batch, the clipped losses, gradient clipping and a fused Adam step: about
a thousand small kernels, most of them shorter than the time Python takes to launch them. Here each update captures
its first mini-batch step into a CUDA graph (the step reads its mini-batch from fixed buffers, into which each
mini-batch is copied) and replays it for that and every later mini-batch. The sync-free update already keeps the step
free of host synchronisation (the learning rate adapted on the device, the losses summed there), which capture needs.

The graph is kept across updates and captured again only when something it baked in changes (`graph_is_current`): a
setting the step reads as a Python number (the entropy coefficient an annealing schedule lowers, the clip range),
which parameters learn (the actor held during a critic warm-up), the optimizer's state tensors (a resumed
checkpoint). What changes between updates in tensors the graph reads keeps the tensors it captured: the observation
normalisers' std (rsl-rl assigns a new tensor when they learn a rollout) is copied into the captured one, which goes
back into the normaliser, before each replay (`rebind_buffers`). Capturing once matters for memory as much as time:
captured afresh at every update, a training held on to about 0.85 GB of each update's graph memory and ran out of
an H100's 80 GB at iteration 89 (measured in a time-to-policy run). The first update runs eagerly: it creates the
optimizer's state and the autograd and cuBLAS workspaces that capture must not allocate for the first time.

The rollout must be collected without an autograd record (under `torch.inference_mode()`, as rsl-rl's runner
collects it): an acting pass with one keeps the parameters' gradient accumulators made on the default stream
alive, and a captured backward that reaches them makes that stream wait on the capture, which CUDA refuses
(`cudaErrorStreamCaptureImplicit`: the first GPU test, whose rollout kept an autograd record; the runner's
benchmark, under inference mode, captured its updates).

Across several GPUs (`--distributed`) the graph holds the gradients' all-reduce and the KL's (NCCL collectives can
be captured; the first, eager update creates the communicator): every rank captures at the same update, since the
settings that trigger a capture are the same on every rank, and each replay meets the other ranks' replays in the
collectives, as eager steps do. Switch it on with `agent.algorithm.captured_update=true` (`agile.rl.extensions`; it
is the sync-free update, captured: `sync_free_update` may be on too). On a CPU it updates as the sync-free update
does.
"""

from __future__ import annotations

from itertools import chain

import torch
from rsl_rl.storage import RolloutStorage

from agile.rl.algorithms.sync_free_update import LOSS_SUMS, SyncFreeUpdate
from agile.utils.heap import no_collection_while_capturing


class CapturedUpdate(SyncFreeUpdate):
    """The sync-free update, its mini-batch step captured and replayed (see the module). A mixin: in front of rsl-rl's
    PPO."""

    def __init__(self, *args, device: str = "cpu", **kwargs):
        super().__init__(*args, device=device, **kwargs)
        self.captures = torch.device(self.device).type == "cuda"
        """Whether updates replay a captured mini-batch step (else each step runs eagerly, as the sync-free update
        does)."""
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
        """The captured mini-batch step, replayed by every update while `graph_is_current()`."""
        self.captured_key = None
        """`graph_key()` at the capture."""
        self.captured_state: list[torch.Tensor] = []
        """The optimizer's state tensors at the capture (held: no new tensor can take their place)."""
        self.captured_buffers: list[tuple[torch.nn.Module, str, torch.Tensor]] = []
        """(module, buffer name, the tensor the graph reads) of every buffer of actor and critic at capture."""
        self.captures_made = 0
        self.sums = torch.zeros(LOSS_SUMS, device=self.device)
        """The losses summed over an update's mini-batches (written by the graph; `sync_free_update.LOSS_SUMS`)."""

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
        return self.finish_update(self.sums)

    def graph_key(self) -> tuple:
        """The settings the captured step baked in: every setting of the algorithm (and of its symmetry term) held
        as a Python number, string or flag, except the learning rate's mirror for the log (the step reads the
        device tensor) and the counters; and which parameters learn."""
        bookkeeping = {"learning_rate", "updates_done", "captures_made"}
        settings = [(k, v) for k, v in vars(self).items()
                    if isinstance(v, (bool, int, float, str)) and k not in bookkeeping]
        if self.symmetry is not None:
            settings += [("symmetry." + k, v) for k, v in vars(self.symmetry).items()
                         if isinstance(v, (bool, int, float, str))]
        return tuple(settings), tuple(p.requires_grad for group in self.optimizer.param_groups for p in group["params"])

    def optimizer_state(self) -> list[torch.Tensor]:
        """The optimizer's state tensors (moments, step counts): a resumed checkpoint replaces them."""
        return [t for group in self.optimizer.param_groups for p in group["params"]
                for t in self.optimizer.state.get(p, {}).values() if torch.is_tensor(t)]

    def graph_is_current(self) -> bool:
        """Whether the captured graph still does this update's step: same settings, the same optimizer state
        tensors (compared as objects, held since the capture, so that no new tensor can take an old one's place)."""
        state = self.optimizer_state()
        return (self.graph is not None and self.graph_key() == self.captured_key
                and len(state) == len(self.captured_state) and all(a is b for a, b in zip(state, self.captured_state)))

    def rebind_buffers(self) -> None:
        """Put the tensors the graph captured back into actor and critic, with the values of the ones that
        replaced them since (the normalisers' std): the graph reads the captured tensors' memory."""
        for module, name, captured in self.captured_buffers:
            current = getattr(module, name)
            if current is not captured:
                captured.copy_(current)
                setattr(module, name, captured)

    def _replay_captured_steps(self) -> None:
        """Replay the captured mini-batch step for every mini-batch, capturing it first where there is no graph or
        what it baked in changed (`graph_is_current`; capture records, it does not run)."""
        if self.graph is not None and not self.graph_is_current():
            self.release_graph()
        if self.graph is not None:
            self.rebind_buffers()
        for batch in self.storage.mini_batch_generator(self.num_mini_batches, self.num_learning_epochs):
            self._load_mini_batch(batch)
            if self.graph is None:
                self._capture()
            self.graph.replay()

    def _capture(self) -> None:
        # captured on self.stream by the graph's own calls: the torch.cuda.graph context would also empty the
        # allocator's cache, handing the rollout's memory back to CUDA
        self._ranks_meet()
        graph = torch.cuda.CUDAGraph()
        with no_collection_while_capturing():
            graph.capture_begin()
            try:
                self.mini_batch_step(self._fixed_batch(), self.sums)
            finally:
                graph.capture_end()
        self._ranks_meet()
        self.graph, self.captured_key, self.captured_state = graph, self.graph_key(), self.optimizer_state()
        self.captured_buffers = self.model_buffers()
        if self.captures_made == 0:
            print(f"[agile] PPO update: the mini-batch step runs as a CUDA graph on {self.device}", flush=True)
        self.captures_made += 1

    def release_graph(self) -> None:
        """Drop the captured step (the next update captures again). Across GPUs, before
        `torch.distributed.destroy_process_group()`: NCCL's communicator is not destroyed while a graph holding its
        kernels lives (the destroy hung on both ranks of a two-H100 training; pytorch/pytorch#115388)."""
        if self.graph is not None:
            torch.cuda.synchronize()
            self.graph = None  # its memory is released once nothing made in it is held any more
            self.optimizer.zero_grad(set_to_none=True)  # the gradients lived in that memory

    def _ranks_meet(self) -> None:
        """Across GPUs, every rank's GPU idle and every rank here before a capture starts and after it ends: no rank
        runs NCCL kernels that wait on a peer while that peer captures or instantiates its graph (a deadlock
        reported with captured collectives elsewhere). Nothing to do on one GPU."""
        if self.is_multi_gpu:
            torch.cuda.synchronize()
            torch.distributed.barrier()
            torch.cuda.synchronize()

    def model_buffers(self) -> list[tuple[torch.nn.Module, str, torch.Tensor]]:
        """(module, buffer name, tensor) of every buffer of actor and critic, as they are now."""
        buffers = []
        for model in (self.actor, self.critic):
            for path, tensor in model.named_buffers():
                module_path, _, name = path.rpartition(".")
                buffers.append((model.get_submodule(module_path), name, tensor))
        return buffers

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
