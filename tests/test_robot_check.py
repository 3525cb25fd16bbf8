"""`agile robot check` (issue 67): the three robots' model files pass; a small MJCF with one fault at a time fails,
naming the joint, body or actuator at fault; a file that cannot be read is refused."""

from __future__ import annotations

import pytest
from commands import run_main

from agile.assets.booster_t1 import INIT_JOINT_POS as T1_POSE
from agile.assets.files import asset_file
from agile.assets.robot_check import check_robot
from agile.assets.unitree_g1 import INIT_JOINT_POS as G1_POSE
from agile.assets.unitree_go1 import GO1_COLLIDER_CLASSES, GO1_MODEL_FILE, INIT_JOINT_POS as GO1_POSE
from agile.cli import main as cli_main


def agile(*args: str) -> tuple[int, str, str]:
    return run_main(cli_main, *args)


def pose_args(pose: dict[str, float]) -> list[str]:
    return ["--joint_pos", *(f"{expr}={value}" for expr, value in pose.items())]


@pytest.mark.parametrize("model_file, pose, classes, feet, height_m", [
    (GO1_MODEL_FILE, GO1_POSE, GO1_COLLIDER_CLASSES, ["FL_calf", "FR_calf", "RL_calf", "RR_calf"], 0.30),
    (asset_file("unitree_g1/g1_mjx.xml"), G1_POSE, ("collision", "foot_box", "foot_capsule"),
     ["left_ankle_roll_link", "right_ankle_roll_link"], 0.76),
    (asset_file("booster_t1/t1.xml"), T1_POSE, ("collision",), ["left_foot_link", "right_foot_link"], 0.68),
], ids=["go1", "g1", "t1"])
def test_shipped_robots_pass(model_file, pose, classes, feet, height_m):
    code, out, err = agile("robot", "check", model_file, *pose_args(pose), "--collider_classes", *classes)
    assert code == 0, out + err
    assert "no problem found" in out and "problem:" not in out
    report = check_robot(model_file=model_file, joint_pos=pose, collider_classes=classes)
    assert sorted(report.feet_candidates) == feet
    # the robot definitions' spawn heights were set by hand: the check finds the same within 1.5 cm
    assert report.default_base_height_m == pytest.approx(height_m, abs=0.015)
    assert report.floating_base and all(a.effort_limit_nm for a in report.actuators)


def test_dropped_collider_classes_are_named():
    """Menagerie's G1 puts its feet in classes Newton does not take as colliders by default: the check says so, and
    its feet candidates are then the knees."""
    report = check_robot(model_file=asset_file("unitree_g1/g1_mjx.xml"))
    assert any("foot_box" in note and "foot_capsule" in note for note in report.notes), report.notes
    assert "left_ankle_roll_link" not in report.feet_candidates


PROBE = """<mujoco model="probe">
  <worldbody>
    <body name="base" pos="0 0 0.5">
      {root}
      <inertial pos="0 0 0" mass="{base_mass}" diaginertia="{base_ixx} 0.1 0.1"/>
      <geom type="box" size="0.2 0.1 0.05"/>
      <body name="left_leg" pos="0 0.15 -0.05">
        <joint name="left_hip" axis="0 1 0" {left_range}/>
        <inertial pos="0 0 -0.1" mass="1" diaginertia="0.01 0.01 0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
      </body>
      <body name="right_leg" pos="0 {right_y} -0.05">
        <joint name="right_hip" axis="0 1 0" range="-1 1"/>
        <inertial pos="0 0 -0.1" mass="1" diaginertia="0.01 0.01 0.01"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="left_motor" joint="left_hip" {left_force}/>
    <motor name="right_motor" joint="right_hip" forcerange="-20 20"/>
  </actuator>
</mujoco>
"""
SOUND = dict(root="<freejoint/>", base_mass="5", base_ixx="0.1", left_range='range="-1 1"', right_y="-0.15",
             left_force='forcerange="-20 20"')
FAULTS = {  # fault: (the probe's fields changed, what the output must name)
    "no_limits": (dict(left_range=""), "joint left_hip: no position limits"),
    "zero_mass": (dict(base_mass="0"), "body base: mass 0 kg"),
    "negative_mass": (dict(base_mass="-1"), "body base: mass 0 kg"),  # Newton's importer reads a negative mass as 0
    "negative_inertia": (dict(base_ixx="-0.1"), "body base: inertia not positive definite"),
    "fixed_base": (dict(root=""), "body base: no floating base"),
    "self_collision": (dict(right_y="0.17"), "bodies left_leg and right_leg: their colliders overlap"),
    "no_effort_limit": (dict(left_force=""), "actuator left_motor: no effort limit"),
}


def probe(tmp_path, **fields) -> str:
    path = tmp_path / "probe.xml"
    path.write_text(PROBE.format(**{**SOUND, **fields}))
    return str(path)


def test_sound_probe_passes(tmp_path):
    code, out, err = agile("robot", "check", probe(tmp_path))
    assert code == 0 and "no problem found" in out, out + err
    assert "feet candidates (colliders within 0.02 m of the lowest point): left_leg, right_leg" in out


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_each_fault_is_named(tmp_path, fault):
    fields, expected = FAULTS[fault]
    code, out, err = agile("robot", "check", probe(tmp_path, **fields))
    assert code == 1, out + err
    problems = [line.strip().removeprefix("problem: ") for line in out.splitlines() if "problem:" in line]
    assert len(problems) == 1 and problems[0].startswith(expected), out


@pytest.mark.parametrize("args, message", [
    (["/nonexistent/robot.xml"], "model file not found: /nonexistent/robot.xml"),
    (["robot.obj"], "unsupported model file 'robot.obj'"),
    (["{probe}", "--joint_pos", "left_hip"], "--joint_pos takes REGEX=RAD items, got 'left_hip'"),
    (["{probe}", "--joint_pos", "knee=0.3"], "--joint_pos knee matches no joint; the joints: left_hip, right_hip"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, args, message):
    (tmp_path / "robot.obj").write_text("v 0 0 0\n")
    args = [probe(tmp_path) if a == "{probe}" else str(tmp_path / a) if a == "robot.obj" else a for a in args]
    code, out, err = agile("robot", "check", *args)
    assert code == 2 and err.strip().startswith("error: ") and len(err.strip().splitlines()) == 1, err
    assert message.replace("robot.obj", str(tmp_path / "robot.obj")) in err, err


def test_unreadable_model_is_exit_2(tmp_path):
    path = tmp_path / "broken.xml"
    path.write_text("<mujoco><worldbody><body name='a'>")
    code, out, err = agile("robot", "check", str(path))
    assert code == 2 and "Newton could not import" in err and len(err.strip().splitlines()) == 1, err


URDF_PROBE = """<robot name="probe">
  <link name="base"><inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision></link>
  <link name="leg"><inertial><origin xyz="0 0 -0.1"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.15"/><geometry><cylinder radius="0.03" length="0.3"/></geometry></collision></link>
  <joint name="hip" type="revolute"><parent link="base"/><child link="leg"/><origin xyz="0 0.15 -0.05"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="20" velocity="10"/></joint>
  <link name="leg2"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="spin" type="continuous"><parent link="base"/><child link="leg2"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def test_urdf_through_newtons_importer(tmp_path):
    """A URDF's continuous joint has neither position nor effort limits: both named; its limited joint is not."""
    path = tmp_path / "probe.urdf"
    path.write_text(URDF_PROBE)
    code, out, err = agile("robot", "check", str(path))
    assert code == 1, out + err
    problems = [line.strip().removeprefix("problem: ") for line in out.splitlines() if "problem:" in line]
    assert [p.split(":")[0] for p in problems] == ["joint spin", "actuator spin"], out
    assert "hip   [-1, 1]  0  20  10  0" in out and "feet candidates (colliders within 0.02 m of the lowest point): leg" in out
