"""The robot as plain MuJoCo runs it, from an IO descriptor alone: its model built like the training import, with
MuJoCo's own solver iterations or training's (`build_model`), and the descriptor's joints in that model (`Robot`:
index maps, the actuator model). Used by `agile sim2mujoco` and by the policies it runs (`mujoco_policy`); nothing of
the training framework is used."""

from __future__ import annotations

import numpy as np


def rotate_inverse(quat_wxyz: np.ndarray, v: np.ndarray) -> np.ndarray:
    w, x, y, z = quat_wxyz
    rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                    [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                    [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return rot.T @ v


SOLVER_SETTINGS = ("mujoco", "training")
"""`build_model`'s solver: MuJoCo's own iterations, or training's cap from the descriptor."""


def build_model(descriptor: dict, mjcf: str, solver: str = "mujoco"):
    """The MuJoCo model of `mjcf` as the descriptor's training imported it. `solver`: "mujoco" takes MuJoCo's default
    iterations (100, line search 50; also over a file's own, such as the G1 MJX file's 5 and 8); "training" takes
    training's cap from the descriptor (`solver`: 10, 20), which buys batched throughput with unconverged contacts.
    Capped, the Go1's contacts blow up within five steps of a walk (the trunk flung at 3,300 m/s), so a policy is
    checked against a converged solver by default."""
    import mujoco

    if solver not in SOLVER_SETTINGS:
        raise ValueError(f"solver must be one of {', '.join(SOLVER_SETTINGS)}, got {solver!r}")

    spec = mujoco.MjSpec.from_file(mjcf)
    # like the training import: robot colliders on, no self-collision, friction cones (condim 3)
    for geom in spec.geoms:
        if geom.group == 2:  # Menagerie visual geoms
            continue
        if descriptor.get("enable_all_colliders") or geom.contype != 0:
            geom.contype, geom.conaffinity, geom.condim = 1, 0, 3
    spec.worldbody.add_geom(name="agile_floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            contype=0, conaffinity=1, condim=3)
    spec.option.timestep = descriptor["physics_dt_s"]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    if solver == "training":
        spec.option.iterations = descriptor["solver"]["iterations"]
        spec.option.ls_iterations = descriptor["solver"]["ls_iterations"]
    else:  # a new spec's options are MuJoCo's defaults
        defaults = mujoco.MjSpec().option
        spec.option.iterations, spec.option.ls_iterations = defaults.iterations, defaults.ls_iterations
    model = spec.compile()
    model.actuator_gainprm[:] = 0.0  # torques come from the descriptor's actuator model (qfrc_applied)
    model.actuator_biasprm[:] = 0.0
    return model


class Robot:
    """Index maps and actuator model of the descriptor's joints in a MuJoCo model."""

    def __init__(self, descriptor: dict, model):
        self.d = descriptor
        names = descriptor["joint_names"]
        self.qpos_adr = np.array([model.joint(n).qposadr[0] for n in names])
        self.dof_adr = np.array([model.joint(n).dofadr[0] for n in names])
        self.index = {n: i for i, n in enumerate(names)}
        self.default_q = np.array(descriptor["default_joint_pos"])
        self.kp = np.array(descriptor["stiffness"])
        self.kd = np.array(descriptor["damping"])
        self.effort_limit = np.array(descriptor["effort_limit"])
        self.velocity_limit = np.array(descriptor["velocity_limit"])
        self.saturation = np.full(len(names), np.inf)
        for group in descriptor["actuators"].values():
            if "saturation_effort" in group:
                self.saturation[[self.index[n] for n in group["joint_names"]]] = group["saturation_effort"]
        self.root_com_b = model.body_ipos[int(model.jnt_bodyid[0])].copy()  # of the free joint's body
        model.dof_armature[self.dof_adr] = descriptor["armature"]
        model.dof_frictionloss[self.dof_adr] = descriptor["friction"]
        self.target = self.default_q.copy()

    def root_lin_vel_b(self, data) -> np.ndarray:
        """The root body's centre-of-mass velocity in its frame: training's (Isaac Lab's) root_lin_vel_b.
        MuJoCo's free-joint velocity is the frame origin's (world frame) with the angular part in the body
        frame, so v_com_b = R^T v_origin + w_b x r_com_b."""
        return rotate_inverse(data.qpos[3:7], data.qvel[0:3]) + np.cross(data.qvel[3:6], self.root_com_b)

    def torque(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """PD on the targets, clipped by the DC-motor torque-speed line and the effort limit."""
        return self.clip_torque(self.kp * (self.target - q) - self.kd * qd, qd)

    def clip_torque(self, tau: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """`tau` within what the motors give at joint speeds `qd`: the DC-motor torque-speed line, the effort limit."""
        finite = np.isfinite(self.saturation)
        corner = np.where(finite, self.velocity_limit * (1 + self.effort_limit / np.where(finite, self.saturation, 1)),
                          np.inf)
        speed = np.clip(qd, -corner, corner)
        sat = np.where(finite, self.saturation, 0.0)
        tau_max = np.where(finite, np.minimum(sat * (1 - speed / self.velocity_limit), self.effort_limit),
                           self.effort_limit)
        tau_min = np.where(finite, np.maximum(sat * (-1 - speed / self.velocity_limit), -self.effort_limit),
                           -self.effort_limit)
        return np.clip(tau, tau_min, tau_max)
