"""How well the grasp task's rendered sensing sees the object's and the hand's poses.

For each object (validation stream of ``seed``): the object's pose fitted to its markers sensed
at reset, and the hand's fitted to its markers sensed after a kinematic move onto the exact
grasp joints, both against the MuJoCo ground truth; the cameras see both bodies in the same
images. A pose whose markers a camera did not all see is counted apart::

    .venv/bin/python -m envs.studies.pose_sensing_accuracy     # the table of the env page
"""

from __future__ import annotations

import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.grasp import GraspEnv
from envs.harness.streams import seed_env
from envs.pose_reward import goal_poses
from envs.sensing.triangulation import camera_floats
from models.marker_frame import orientation_angle

POSES = 300


def pose_error(env: GraspEnv, pixels: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """Position (mm) and orientation (°) error of the pose fitted to ``pixels`` (12,)."""
    cameras = tuple(camera_floats(c) for c in env.nominal_stereo.cameras)
    pose = goal_poses(cameras, pixels[:, None])[0]
    position = 1e3 * float(np.linalg.norm(pose[:3, 3] - truth[:3, 3]))
    return position, float(np.degrees(orientation_angle(pose[:3, :3], truth[:3, :3])))


def measure(sensing: str, poses: int = POSES, seed: int = 0) -> dict[str, object]:
    """Errors (n, 2) of the object's and the hand's sensed poses and the unseen counts."""
    env = GraspEnv(sensing=sensing, control="kinematic")
    seed_env(env, seed, "validation")
    found: dict[str, list[tuple[float, float]]] = {"object": [], "hand": []}
    unseen = {"object": 0, "hand": 0}
    try:
        for _ in range(poses):
            _, info = env.reset()
            if info["visible_target"].all():
                found["object"].append(pose_error(env, env.sensed_target(), info["target_pose"]))
            else:
                unseen["object"] += 1
            _, _, _, _, info = env.step(env.target_joints)
            if info["visible_effector"].all():
                found["hand"].append(pose_error(env, env.sensed_effector(), info["effector_pose"]))
            else:
                unseen["hand"] += 1
    finally:
        env.close()
    return {"errors": {k: np.array(v) for k, v in found.items()}, "unseen": unseen}


def main() -> None:
    print(
        "| sensing | object mm (mean / p95) | object ° | hand mm | hand ° "
        "| not seen (object, hand) "
        "|"
    )
    print("|---|---|---|---|---|---|")
    for sensing in ("render", "foveated"):
        result = measure(sensing)
        cells = []
        for body in ("object", "hand"):
            e = result["errors"][body]
            for k in (0, 1):
                cells.append(f"{e[:, k].mean():.2f} / {np.percentile(e[:, k], 95):.2f}")
        unseen = result["unseen"]
        print(
            f"| `{sensing}` | {' | '.join(cells)} | "
            f"{unseen['object']}, {unseen['hand']} of {POSES} |"
        )


if __name__ == "__main__":
    main()
