"""Teacher-student distillation on rsl-rl's own `Distillation` algorithm and `DistillationRunner`.

Two additions, both outside rsl-rl's code:
- a mirror loss for non-recurrent students (AGILE's history student): rsl-rl refuses its symmetry extension
  for distillation, so `MirrorLoss` here adds |student(mirror(obs)) - mirror(student(obs))|² itself (switched on by
  the config's `mirror_loss_coeff` > 0: `agile.rl.extensions`);
- a teacher from a TorchScript export (`load_teacher`), not only from a PPO checkpoint: an exported MLP policy
  holds the same normaliser and MLP weights as the actor it came from, so they load into the teacher model.
"""

from __future__ import annotations

import torch
import torch.nn as nn
from rsl_rl.utils import resolve_callable

from agile.rl.checkpoints import load_checkpoint, restore_runner
from agile.rl.rsl_rl_adapter import distillation_teacher


class MirrorLoss:
    """rsl-rl's Distillation with a mirror loss (`mirror_loss_coeff` > 0, `mirror_func(env, obs, actions) -> ([obs;
    mirrored], [actions; mirrored])`, e.g. agile.rl_env.mdp.symmetry:lr_mirror). A mixin: in front of rsl-rl's
    Distillation (`agile.rl.extensions` puts it there when the config's `mirror_loss_coeff` > 0)."""

    mirror_loss_coeff: float = 0.0
    mirror_func = None
    env = None

    @classmethod
    def construct_algorithm(cls, obs, env, cfg: dict, device: str):
        # rsl-rl passes every algorithm key to the constructor: take ours out first (in place: the runner keeps
        # `cfg`, and rsl-rl writes the resolved observation groups into it)
        coeff = cfg["algorithm"].pop("mirror_loss_coeff")
        func = cfg["algorithm"].pop("mirror_func", None)
        alg = super().construct_algorithm(obs, env, cfg, device)
        if alg.student.is_recurrent:
            raise ValueError("the mirror loss needs a non-recurrent student")
        alg.mirror_loss_coeff = coeff
        alg.mirror_func = resolve_callable(func)
        alg.env = env
        return alg

    def _mirror_loss(self, observations, actions: torch.Tensor) -> torch.Tensor:
        """|student(mirrored obs) - mirrored student actions|², the student's own actions held fixed."""
        n = actions.shape[0]
        mirrored_obs, mirrored_actions = self.mirror_func(self.env, observations, actions.detach())
        return nn.functional.mse_loss(self.student(mirrored_obs[n:]), mirrored_actions[n:])

    def update(self) -> dict[str, float]:
        # rsl-rl's update (non-recurrent student: no hidden state to carry), with the mirror loss added
        self.num_updates += 1
        # the losses are summed on the device and read once per update, not once per batch
        behavior_sum = torch.zeros((), device=self.device)
        mirror_sum = torch.zeros((), device=self.device)
        loss = 0.0
        count = 0
        for _ in range(self.num_learning_epochs):
            for batch in self.storage.generator():
                actions = self.student(batch.observations)
                behavior_loss = self.loss_fn(actions, batch.privileged_actions)
                mirror_loss = self._mirror_loss(batch.observations, actions)
                loss = loss + behavior_loss + self.mirror_loss_coeff * mirror_loss
                behavior_sum += behavior_loss.detach()
                mirror_sum += mirror_loss.detach()
                count += 1
                if count % self.gradient_length == 0:
                    self.optimizer.zero_grad()
                    loss.backward()
                    if self.is_multi_gpu:
                        self.reduce_parameters()
                    if self.max_grad_norm:
                        nn.utils.clip_grad_norm_(self.student.parameters(), self.max_grad_norm)
                    self.optimizer.step()
                    loss = 0.0
        self.student.update_normalization(self.storage.observations.flatten(0, 1))
        self.storage.clear()
        return {"behavior": behavior_sum.item() / count, "mirror": mirror_sum.item() / count}


def load_teacher_weights(algorithm, state_dict: dict[str, torch.Tensor], source: str) -> None:
    """Load an exported policy's weights into a distillation's teacher: every exported weight must have its place and
    every teacher weight but the action distribution's (not exported) must be given."""
    teacher = distillation_teacher(algorithm)
    expected = set(teacher.state_dict())
    given = set(state_dict)
    missing = sorted(k for k in expected - given if not k.startswith("distribution."))
    unexpected = sorted(given - expected)
    if missing or unexpected:
        raise ValueError(f"teacher {source} does not match the teacher model (agent.teacher): missing "
                         f"{missing}, unexpected {unexpected}")
    teacher.load_state_dict(state_dict, strict=False)
    algorithm.teacher_loaded = True


def is_torchscript(path: str) -> bool:
    """TorchScript archives hold their code; rsl-rl checkpoints are pickled dicts of tensors."""
    import zipfile

    if not zipfile.is_zipfile(path):
        return False
    with zipfile.ZipFile(path) as archive:
        return any(name.split("/")[1:2] == ["code"] for name in archive.namelist())


def load_teacher(runner, path: str, trust: bool = False) -> None:
    """The teacher of a distillation runner from `path`: a PPO checkpoint of the teacher task (its actor) or
    that actor's TorchScript export (train.py writes exported/policy.pt; agile ships one per teacher)."""
    if is_torchscript(path):
        module = torch.jit.load(path, map_location="cpu")
        load_teacher_weights(runner.alg, dict(module.state_dict()), path)
        return
    checkpoint = load_checkpoint(path, "cpu", trust=trust)
    if "actor_state_dict" not in checkpoint:
        raise ValueError(f"teacher {path} is neither a TorchScript policy nor a PPO checkpoint (it has "
                         f"{sorted(checkpoint)})")
    restore_runner(runner, checkpoint, load_cfg={"teacher": True, "iteration": False})
