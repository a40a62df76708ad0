"""Write a Menagerie-style robot folder from an arm's DH table (standard or modified).

    .venv/bin/python scripts/make_arm.py models/ur5e/dh.toml --out models/ur5e
    .venv/bin/python scripts/make_arm.py my_arm.toml               # writes ./my_arm/

The table file (TOML or JSON; the format: docs/your-robot.md) gives the DH rows, the joint
ranges, the home pose, the link radii and the box reach targets are drawn from. The folder gets
``<robot>.xml`` (capsule links, position actuators joint1..jointN, sites base and tcp, the green
marker, keyframes home and ready), ``scene.xml`` (floor, light, the cameras cam_left and
cam_right placed so that the tcp over random joint vectors fills both images, overview, the
mocap target), ``README.md`` (the table and its source), the table and ``__init__.py`` (its
``MODEL``). The model is compiled before anything is written. A folder under ``models/`` plus
one ``RobotSpec`` in ``envs/robots.py`` makes it a robot of the project (docs/your-robot.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from envs.cli import common as cli
from envs.cli import options
from models import dh_arm, dh_mjcf


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = cli.parser(__doc__)
    p.add_argument("table", type=Path, help="the DH table file (.toml or .json)")
    options.OUT.add(p, default=None, note="the robot folder (default: ./<name>/)")
    return p.parse_args(argv)


def check_compiles(arm: dh_arm.DHArm) -> None:
    """Compile the scene in memory and compare its tcp with the DH chain at home; exit with one
    line if MuJoCo refuses it."""
    assets = {f"{arm.name}.xml": dh_mjcf.robot_xml(arm).encode()}
    try:
        model = mujoco.MjModel.from_xml_string(dh_mjcf.scene_xml(arm), assets)
    except ValueError as error:
        cli.fail(f"MuJoCo refuses the generated model of {arm.name}: {error}")
    data = mujoco.MjData(model)
    data.qpos[:] = arm.home
    mujoco.mj_kinematics(model, data)
    miss = float(np.linalg.norm(data.site("tcp").xpos - dh_arm.tcp_position(arm, arm.home)))
    if miss > 1e-9:
        cli.fail(f"the generated {arm.name}.xml misses the DH tcp by {miss:.3g} m at home")


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    try:
        arm = dh_arm.read_table(args.table)
    except dh_arm.DHTableError as error:
        cli.fail(str(error))
    folder = Path(arm.name) if args.out is None else args.out
    check_compiles(arm)
    table_name = f"dh{args.table.suffix}"
    written = dh_mjcf.write_folder(arm, folder, table_name, args.table.read_text())
    left = dh_mjcf.cameras(arm)[0]
    print(
        f"{arm.title}: {arm.n} joints ({arm.convention} DH), reach {dh_arm.reach(arm):.3f} m, "
        f"cameras fovy {left.fovy_deg:.1f}°"
    )
    print(f"wrote {', '.join(p.name for p in written)} to {folder}/")


#: Console entry point ``visuomotor-make-arm``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
