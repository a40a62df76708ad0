"""How well each arm's cameras frame its workspace: the sensing cameras and the pixel cameras
(``obs_mode="pixels"``, :mod:`envs.sensing.pixel_cameras`).

A *move* is a joint vector drawn uniformly from the controlled joints' ranges and a target drawn
from the robot's workspace, as a reset draws it. A move is *framed* by a pair of cameras when
the marker (the sensed point) and the target lie inside both images by the exact pinhole
projection, which ignores occlusion (the arm may hide the marker). A move that is not framed is
counted under each reason: marker or target, left or right camera, outside which side of the
image (or behind the camera). Pixel counts come from MuJoCo's segmentation rendering: the
target's and the marker's visible pixels, and the arm's share of the image (robot and marker
geoms), in each camera at the images' size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from envs.sensing.drawn_spheres import spheres_drawn
from envs.sensing.pixel_cameras import random_joints, sensed_points
from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT, VISIBLE_GROUPS
from envs.sensing.viewports import View, place_camera

if TYPE_CHECKING:
    from envs.reach import ReachEnv
    from envs.sensing.stereo import CameraPair

#: The image sides a projected point can leave by, in the order they are tested.
SIDES = ("behind", "left", "right", "top", "bottom")
POINTS = ("marker", "target")
CAMERAS = ("left", "right")


@dataclass(frozen=True)
class Moves:
    """Random moves of one arm: joint vectors (N, J) rad, sensed points and targets (N, 3) m."""

    joints: np.ndarray
    markers: np.ndarray
    targets: np.ndarray

    @classmethod
    def draw(cls, env: ReachEnv, n: int, rng: np.random.Generator) -> Moves:
        """``n`` moves: joints uniform in the controlled joints' ranges, targets from the
        robot's workspace, both from ``rng``."""
        joints = random_joints(env, rng, n)
        targets = env.robot_spec.workspace.sample(rng, n) + env.perturbation.base_shift
        return cls(joints, sensed_points(env, joints), targets)


def outside(points: np.ndarray, cameras: CameraPair, height: int, width: int) -> np.ndarray:
    """Where each point (N, 3) leaves each camera's image: (N, 2) int, an index into SIDES + 1
    (0: inside, pixel edges at -0.5 and size - 0.5), the first side in SIDES' order."""
    pixels, depth = cameras.project_with_depth(points)
    uv = pixels.reshape(-1, 2, 2)
    tests = [
        depth <= 0,
        uv[..., 0] < -0.5,
        uv[..., 0] > width - 0.5,
        uv[..., 1] < -0.5,
        uv[..., 1] > height - 0.5,
    ]
    out = np.zeros(depth.shape, dtype=int)
    for k, failed in reversed(list(enumerate(tests, start=1))):
        out[failed] = k
    return out


def framing(moves: Moves, cameras: CameraPair, height: int, width: int) -> dict:
    """The share of moves framed by ``cameras`` (images ``height`` × ``width``) and, per
    reason ``"<marker|target> <left|right> <side>"``, the share of moves that fail by it."""
    where = {p: outside(getattr(moves, p + "s"), cameras, height, width) for p in POINTS}
    framed = np.all([np.all(w == 0, axis=1) for w in where.values()], axis=0)
    reasons = {}
    for point, out in where.items():
        for c, camera in enumerate(CAMERAS):
            for s, side in enumerate(SIDES, start=1):
                share = float(np.mean(out[:, c] == s))
                if share > 0:
                    reasons[f"{point} {camera} {side}"] = share
    return {"framed": float(np.mean(framed)), "moves": len(framed), "reasons": reasons}


def pixel_counts(env: ReachEnv, moves: Moves, views: list[View], radius: float | None) -> dict:
    """Medians over the moves and both views of the target's and the marker's visible pixels
    and of the arm's share of the image (robot and marker geoms), by segmentation rendering of
    ``views`` (whole views, model cameras or posed), the spheres drawn at least ``radius`` m
    (None: as they are)."""
    import mujoco

    base = env
    model, data = base.model, mujoco.MjData(base.model)
    mujoco.mj_copyData(data, model, base.data)
    height, width = views[0].window.height, views[0].window.width
    arm = np.isin(model.geom_group, (GROUP_ROBOT, GROUP_MARKER))
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[list(VISIBLE_GROUPS)] = 1
    renderer = mujoco.Renderer(model, height, width)
    renderer.enable_segmentation_rendering()
    counts: dict[str, list[float]] = {"target_px": [], "marker_px": [], "arm_share": []}
    target, markers = base.target_geom_ids, base.effector_geom_ids
    try:
        for q, point in zip(moves.joints, moves.targets, strict=True):
            data.mocap_pos[base.target_mocap_id] = point
            base.set_joints(q, data)
            for view in views:
                with spheres_drawn(model, data, target, markers, radius):
                    camera = -1 if view.pose is not None else view.camera
                    renderer.update_scene(data, camera=camera, scene_option=option)
                    if view.pose is not None:
                        place_camera(renderer.scene, view)
                    ids, kinds = np.moveaxis(renderer.render(), -1, 0)
                geoms = np.where(kinds == int(mujoco.mjtObj.mjOBJ_GEOM), ids, -1)
                counts["target_px"].append(float(np.isin(geoms, target).sum()))
                counts["marker_px"].append(float(np.isin(geoms, markers).sum()))
                counts["arm_share"].append(float(arm[geoms[geoms >= 0]].sum()) / geoms.size)
    finally:
        renderer.close()
    return {key: float(np.median(values)) for key, values in counts.items()}


def sensing_views(env: ReachEnv, height: int, width: int) -> list[View]:
    """The sensing cameras' whole views at ``height`` × ``width`` (what ``obs_mode="pixels"``
    showed before the pixel cameras)."""
    return [View.whole(name, height, width) for name in env.stereo.camera_names]


def study(base: ReachEnv, moves: int, pixel_moves: int, seed: int) -> dict:
    """Framing of ``moves`` random moves by the sensing and the pixel cameras, and pixel counts
    over the first ``pixel_moves`` of them in the sensing cameras at the pixel size and in the
    pixel cameras (``base``: an unwrapped reach env)."""
    drawn = Moves.draw(base, moves, np.random.default_rng(seed))
    rig = base.pixel_rig
    few = Moves(
        drawn.joints[:pixel_moves], drawn.markers[:pixel_moves], drawn.targets[:pixel_moves]
    )
    return {
        "sensing": framing(drawn, base.stereo, base.image_height, base.image_width),
        "pixels": framing(drawn, rig.cameras, rig.height, rig.width),
        "sensing_px": pixel_counts(base, few, sensing_views(base, rig.height, rig.width), None),
        "pixels_px": pixel_counts(base, few, rig.views(), rig.sphere_radius),
        "sizes": {
            "sensing": [base.image_width, base.image_height],
            "pixels": [rig.width, rig.height],
        },
    }


def reasons_text(reasons: dict[str, float], most: int = 3) -> str:
    """The commonest failure reasons as ``"marker right bottom 12.3 %, ..."``."""
    top = sorted(reasons.items(), key=lambda kv: -kv[1])[:most]
    return ", ".join(f"{name} {share * 100:.1f} %" for name, share in top) or "none"


def markdown(results: dict[str, dict]) -> str:
    """The docs' tables: framing by arm and camera pair, then pixel counts."""
    lines = [
        "| arm | cameras | moves framed | commonest reasons a move is not (share of moves) |",
        "|---|---|---|---|",
    ]
    for env_id, r in results.items():
        for kind, label in (("sensing", "sensing"), ("pixels", "pixel")):
            w, h = r["sizes"][kind]
            f = r[kind]
            lines.append(
                f"| {env_id} | {label} {w}×{h} | {f['framed'] * 100:.1f} % | "
                f"{reasons_text(f['reasons'])} |"
            )
    lines += [
        "",
        "| arm | cameras at the pixel size | target px (median) | marker px (median) | arm |",
        "|---|---|---|---|---|",
    ]
    for env_id, r in results.items():
        w, h = r["sizes"]["pixels"]
        for kind, label in (("sensing_px", "sensing"), ("pixels_px", "pixel")):
            c = r[kind]
            lines.append(
                f"| {env_id} | {label} {w}×{h} | {c['target_px']:.0f} | {c['marker_px']:.0f} | "
                f"{c['arm_share'] * 100:.1f} % |"
            )
    return "\n".join(lines)


def observation_row(env, seed: int, scale: int) -> np.ndarray:
    """An env's image observation after a reset and one random move (``env``: made with
    ``obs_mode="pixels"``, seeded by ``seed``): left | right, each pixel ``scale`` × ``scale``,
    (scale H, 2 scale W, 3) uint8."""
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    obs = env.step(rng.uniform(env.action_space.low, env.action_space.high))[0]
    row = np.concatenate([obs["pixels_left"], obs["pixels_right"]], axis=1)
    return np.repeat(np.repeat(row, scale, axis=0), scale, axis=1)
