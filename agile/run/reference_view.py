"""A kinematic copy of the robot at its command's reference pose, drawn beside the robot in rendered videos.

The copy lives in a render-only Newton model: one world holding the env's world template (every entity, as the
task builds it) plus one more instance of the tracked articulation, over the same ground or terrain. Each frame
the env's world is copied body by body from the simulation (what is drawn is what was simulated), and the copy's
bodies come from forward kinematics of the reference root pose and joint angles (`CommandTerm.reference_pose`).
The simulation never sees the copy: no contacts, no effect on the rollout.
"""

from __future__ import annotations

REFERENCE_COLOR = (0.95, 0.55, 0.15)
"""Orange: the reference copy must not be mistaken for the robot."""
REFERENCE_OFFSET_M = (0.75, 0.75, 0.0)
"""Where the copy stands from the reference root, world frame: about 1.06 m to the right as the video camera sees
it (it looks along (-1, 1, 0)), so the two bodies do not overlap in the image."""


def reference_command(env) -> str:
    """The name of the env's one command term with a whole-body reference pose (ValueError if none or several
    have one)."""
    names = [name for name, term in env.command_manager.terms.items() if term.reference_pose() is not None]
    if len(names) != 1:
        found = f"several ({names})" if names else "none"
        raise ValueError(f"a reference view needs one command term with a reference pose "
                         f"(CommandTerm.reference_pose, e.g. a motion command); this task has {found}")
    return names[0]


class ReferenceScene:
    """The render-only model of one env's world plus the reference copy; `update(env)` poses both for a frame."""

    def __init__(self, env, env_index: int = 0, offset_m=REFERENCE_OFFSET_M):
        import torch
        import warp as wp

        from agile.sim.entities.model_import import build_articulation, new_builder
        from agile.sim.scene import build_world_template
        from agile.sim.simulation import terrain_heightfield

        sim = env.sim
        self.command_name = reference_command(env)
        pose = env.command_manager.get_term(self.command_name).reference_pose()
        gravity = sim.cfg.gravity_mps2
        articulation_cfg = sim.scene_cfg.entities[pose.asset_name]
        if articulation_cfg.fixed_base:
            raise ValueError(f"a reference copy of '{pose.asset_name}' needs a free root; it has a fixed base")
        template, _, _ = build_world_template(sim.scene_cfg, gravity)
        self.world_body_count = template.body_count
        """Bodies of one env's world: copied from the simulation each frame."""
        if sim.model.body_count != self.world_body_count * env.num_envs:
            raise ValueError("the simulation's worlds do not match the scene's world template")
        copy, _, _ = build_articulation(articulation_cfg, gravity)
        coords_start, first_shape = len(template.joint_q), template.shape_count
        template.add_builder(copy)
        for shape in range(first_shape, template.shape_count):
            template.shape_color[shape] = REFERENCE_COLOR
        self.reference_bodies = slice(self.world_body_count, template.body_count)
        """The copy's bodies in the render state's `body_q`, in the robot's body order."""
        world = new_builder(gravity)
        world.replicate(template, copy_count=1)
        if sim.terrain is None:
            world.add_ground_plane()
        else:
            world.add_shape_heightfield(heightfield=terrain_heightfield(sim.terrain), label="terrain")
        self.model = world.finalize(device=sim.model.device)
        self.state = self.model.state()
        self.joint_q = wp.clone(self.model.joint_q)
        self.joint_qd = wp.zeros_like(self.model.joint_qd)  # poses only: the camera does not see velocities
        # a torch view of the copy's coordinates (7 root, then the joints): the reference is written into it
        self.reference_q = wp.to_torch(self.joint_q)[coords_start:coords_start + len(copy.joint_q)]
        self.reference_articulation = wp.array([self.model.articulation_count - 1], dtype=wp.int32,
                                               device=self.model.device)
        self.offset_m = torch.tensor(offset_m, dtype=torch.float32, device=self.reference_q.device)
        self.env_index = env_index

    def reference_root_pos_w(self, env):
        """(3,) where the copy's root is drawn [m]: the reference root position plus the offset."""
        pose = env.command_manager.get_term(self.command_name).reference_pose()
        return pose.root_pose_w[self.env_index, :3].to(self.offset_m.device) + self.offset_m

    def update(self, env) -> None:
        """The env's world as simulated now, and the copy at the command's current reference pose."""
        import newton
        import torch
        import warp as wp

        n = self.world_body_count
        wp.copy(self.state.body_q, env.sim.state.body_q, dest_offset=0, src_offset=self.env_index * n, count=n)
        pose = env.command_manager.get_term(self.command_name).reference_pose()
        root_pose_w = pose.root_pose_w[self.env_index].to(self.offset_m.device)
        joint_pos = pose.joint_pos[self.env_index].to(self.offset_m.device)
        self.reference_q.copy_(torch.cat([root_pose_w[:3] + self.offset_m, root_pose_w[3:7], joint_pos]))
        # FK of the copy only: the env's bodies were just copied as simulated
        newton.eval_fk(self.model, self.joint_q, self.joint_qd, self.state, indices=self.reference_articulation)
