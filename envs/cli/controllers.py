"""Building a controller for an env from a command-line spec (shared by the scripts)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from envs.harness.checkpoint import CHECKPOINT_FILE, OLD_CHECKPOINT_FILE, checkpoint_path
from learners.base import Controller
from learners.baselines.random_controller import RandomController

#: The controllers that need no file.
NAMED = ("random", "analytic", "jacobian", "exact-servo")
#: The floors of the grasp envs (PumaGrasp-v0), through the same cameras.
POSE_NAMED = ("pose_ik", "pose_jacobian")
SPECS = f"{' | '.join(NAMED)} | PATH.npz (a saved VisuomotorSOM) | RUN (a train.py run folder)"
#: The specs of the grasp envs.
POSE_SPECS = f"{' | '.join(POSE_NAMED)} | PATH.npz (a saved HierarchicalSOM) | RUN"


def controller_spec(text: str) -> str:
    """argparse type of ``--controller``: a name of ``NAMED``, an existing ``.npz`` map, or a run
    folder holding one (given as its map's path); anything else is a one-line usage error."""
    if text in NAMED or text in POSE_NAMED:
        return text
    path = Path(text)
    if path.is_dir():
        if not checkpoint_path(path).is_file():
            raise argparse.ArgumentTypeError(
                f"{text} is a folder without {CHECKPOINT_FILE}; pass a train.py run folder, a .npz "
                f"map or one of {', '.join(NAMED)}"
            )
        return str(checkpoint_path(path))
    if path.suffix == ".npz":
        if not path.is_file():
            raise argparse.ArgumentTypeError(f"{text} does not exist; train a map with train.py")
        return text
    if not path.exists() and ("/" in text or "\\" in text):
        raise argparse.ArgumentTypeError(
            f"{text} does not exist; pass a train.py run folder, a .npz map or one of "
            f"{', '.join(NAMED)}"
        )
    raise argparse.ArgumentTypeError(f"wants {SPECS}, got {text!r}")


def run_folder(text: str) -> Path:
    """argparse type of evaluate's ``--run``: a train.py run folder, or its checkpoint
    (``RUN/checkpoint.npz``) standing for the folder; anything else is a one-line usage error that
    says what to pass."""
    path = Path(text)
    if path.is_file() and path.name in (CHECKPOINT_FILE, OLD_CHECKPOINT_FILE):
        return path.parent
    if path.is_file():
        also = f", or evaluate this map with --controller {text}" * (path.suffix == ".npz")
        raise argparse.ArgumentTypeError(
            f"{text} is a file, not a train.py run folder; pass the run's folder (or its "
            f"{CHECKPOINT_FILE}){also}"
        )
    if not path.exists():
        raise argparse.ArgumentTypeError(
            f"{text} does not exist; pass the --out folder of a train.py run, or train one there "
            "first"
        )
    if not checkpoint_path(path).is_file():
        raise argparse.ArgumentTypeError(
            f"{text} holds no {CHECKPOINT_FILE}, so no train.py run; pass the --out folder of a "
            "finished or stopped run"
        )
    return path


def make_controller(spec: str, env, seed: int = 0) -> Controller:
    """``spec``: one of ``SPECS``; ``env`` gives the joint ranges and the nominal stereo rig (the
    exact baselines keep that calibration when the scene is perturbed)."""
    base = env.unwrapped
    if spec == "random":
        return RandomController(base.joint_lower, base.joint_upper, np.random.default_rng(seed))
    if spec == "analytic":
        from learners.baselines.analytic_ik import AnalyticIK

        return AnalyticIK.for_robot(base.nominal_stereo.triangulate, base.robot, joints=base.joints)
    if spec == "jacobian":
        from learners.baselines.jacobian_ik import JacobianIK

        return JacobianIK.for_robot(base.nominal_stereo.triangulate, base.robot, joints=base.joints)
    if spec == "exact-servo":
        from learners.baselines.analytic_ik import AnalyticIK
        from learners.baselines.exact_servo import ExactServo

        ik = AnalyticIK.for_robot(base.nominal_stereo.triangulate, base.robot, joints=base.joints)
        return ExactServo(ik, base.nominal_stereo.project)
    if spec in POSE_NAMED:
        return make_pose_floor(spec, env)
    if spec.endswith(".npz"):
        from envs.harness.checkpoint import check_map_fits, load_map

        som = load_map(Path(spec))  # a VisuomotorSOM, or a HierarchicalSOM of a grasp env
        check_map_fits(spec, som, env)  # a map of another robot or image size is refused
        return som
    raise ValueError(f"unknown controller {spec!r}; valid: {SPECS}")


def check_task(specs: list[str], pose: bool) -> None:
    """Exit with one line if a named controller of ``specs`` belongs to the other task (the
    pose floors on a reach env, the reach baselines on a grasp env)."""
    from envs.cli.common import fail

    for spec in specs:
        if pose and spec in NAMED:
            fail(f"{spec} is a reach controller; on PumaGrasp-v0 use {POSE_SPECS}")
        if not pose and spec in POSE_NAMED:
            fail(f"{spec} needs the grasp env PumaGrasp-v0; on a reach env use {SPECS}")


def make_pose_floor(spec: str, env) -> Controller:
    """``pose_ik`` (exact pose IK) or ``pose_jacobian`` (damped least squares on the pose) from
    the object's pose triangulated with the env's nominal cameras; ValueError on a reach env."""
    from envs.grasp import GraspEnv
    from learners.baselines.pose_ik import PoseIK, PoseJacobianIK

    base = env.unwrapped
    if not isinstance(base, GraspEnv):
        raise ValueError(f"{spec} needs a grasp env (PumaGrasp-v0); for a reach env use {SPECS}")
    floor = PoseIK if spec == "pose_ik" else PoseJacobianIK
    box = {"lower": base.action_lower, "upper": base.action_upper}  # the commands it may send
    return floor(base.nominal_stereo.triangulate, base.task.base, **box, task=base.task)
