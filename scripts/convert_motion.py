"""Convert a retargeted motion CSV (the public "AMASS retargeted for G1" layout: per frame root position, root
quaternion xyzw, 29 joint angles) into a motion file for MotionTracking-G1-v0 (docs/motion_tracking.md).

    python scripts/convert_motion.py --input dance.csv --input_fps 30 --output dance.npz
    python scripts/train.py --task MotionTracking-G1-v0 env.commands.motion.motion_file=dance.npz

The joints are matched to the robot's by name (`--joint_names` gives the CSV's column order when it is not the
G1 URDF order), the motion is resampled to the task's control rate, velocities come from finite differences and
the body poses and velocities from the forward kinematics of the task's robot model.
"""

from __future__ import annotations

import sys

from agile.errors import AgileError
from agile.run.arguments import command, new_parser

from agile.assets.unitree_g1 import g1_beyondmimic_actuators, g1_robot_cfg
from agile.motion import save_motion
from agile.motion.convert import G1_CSV_JOINT_NAMES, convert_csv


@command
def main(argv=None) -> None:
    parser = new_parser(__doc__)
    parser.add_argument("--input", required=True, help="the motion CSV")
    parser.add_argument("--input_fps", type=float, required=True, help="the CSV's frame rate [Hz]")
    parser.add_argument("--output", required=True, help="the motion file to write (.npz)")
    parser.add_argument("--output_fps", type=float, default=50.0,
                        help="the tracking task's control rate [Hz] (physics 200 Hz / decimation 4)")
    parser.add_argument("--frame_range", type=int, nargs=2, default=None, metavar=("FIRST", "LAST"),
                        help="keep only these CSV frames (inclusive, from 0)")
    parser.add_argument("--joint_names", nargs="+", default=G1_CSV_JOINT_NAMES,
                        help="the CSV's joint columns, in order (default: the G1 29-DoF URDF order)")
    args = parser.parse_args(argv)
    if args.input_fps <= 0 or args.output_fps <= 0:
        raise AgileError("--input_fps and --output_fps must be positive")
    try:
        motion = convert_csv(args.input, args.input_fps, args.output_fps, g1_robot_cfg(g1_beyondmimic_actuators()),
                             csv_joint_names=args.joint_names,
                             frame_range=tuple(args.frame_range) if args.frame_range else None)
    except (OSError, ValueError) as err:
        raise AgileError(str(err)) from err
    save_motion(args.output, motion)
    print(f"{args.output}: {motion.num_frames} frames at {motion.fps:g} fps ({motion.duration_s:.2f} s), "
          f"{len(motion.joint_names)} joints, {len(motion.body_names)} bodies")


if __name__ == "__main__":
    sys.exit(main())
