"""UR5e-type arm: generated from its DH table (dh.toml) by visuomotor-make-arm; its
:class:`~models.robot_model.RobotModel` is read from that table."""

from pathlib import Path

from models.dh_arm import dh_robot_model, read_table

TABLE = read_table(Path(__file__).with_name("dh.toml"))
MODEL = dh_robot_model(TABLE)
