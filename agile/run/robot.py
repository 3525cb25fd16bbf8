"""Robot model files.

    agile robot check path/to/robot.xml                     # MJCF, URDF or USD
    agile robot check go1.xml --joint_pos '.*_thigh_joint=0.9' '.*_calf_joint=-1.8'

`check` imports the file through Newton's importers, as a task's scene does, and prints what a robot definition
needs: the joints with their ranges, armature and limits, the bodies with their masses and inertias, the actuators
with their effort limits, the base height at the default pose and the feet candidates; then the problems that break
training (a joint without limits, a mass or inertia that is not positive, no floating base, colliders overlapping
at the default pose, an actuator without an effort limit), each naming its joint, body or actuator.
Exit status: 0 when no problem was found, 1 when some were, 2 for a file that cannot be read.
"""

from __future__ import annotations

from agile.run import arguments

EXIT_PROBLEMS = 1
"""Exit code of `agile robot check` when it found problems (2 stays a refused input)."""


@arguments.command
def main(argv=None) -> int:
    parser = arguments.new_parser(__doc__)
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    check = sub.add_parser("check", help="report a model file's joints, bodies, actuators and problems (exit 1 when "
                           "it has problems)", formatter_class=arguments.HelpFormatter)
    check.add_argument("model_file", help="MJCF (.xml), URDF (.urdf) or USD (.usd, .usda, .usdc, .usdz)")
    check.add_argument("--joint_pos", nargs="*", default=[], metavar="REGEX=RAD",
                       help="the default pose, as a robot definition's init_joint_pos (other joints at 0, clamped "
                            "into their ranges)")
    check.add_argument("--collider_classes", nargs="*", default=["collision"], metavar="CLASS",
                       help="MJCF classes whose geoms collide (a robot definition's mjcf_collider_classes)")
    check.add_argument("--verbose", action="store_true", help="show Warp's kernel loads and library warnings")
    args = parser.parse_args(argv)
    joint_pos = arguments.parse_number_items(args.joint_pos, "--joint_pos takes REGEX=RAD items, got '{item}'")
    from agile.run import task_setup

    task_setup.configure_output(verbose=args.verbose)
    from agile.assets.robot_check import check_robot, format_report

    report = check_robot(model_file=args.model_file, joint_pos=joint_pos,
                         collider_classes=tuple(args.collider_classes))
    print(format_report(report))
    return EXIT_PROBLEMS if report.problems else 0
