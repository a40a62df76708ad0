"""The main job, end to end and headless: train the visuomotor SOM on every arm of the robot
registry (``envs.robots.ROBOTS``), evaluate it with exact projection and kinematic moves and with
rendered (foveated) cameras and servo moves, and write plots, videos (the map beside the exact
IK) and camera images.

    .venv/bin/python scripts/demo.py --out runs/demo          (what `make demo` runs; ~3 minutes)
"""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import evaluate, options, train, video
from envs.composite import CompositeView, draw_inset
from envs.harness.run_folder import write_json
from envs.reach import ReachEnv
from envs.robots import ROBOTS
from learners.persistence import write_atomic

CAMERAS = ("cam_left", "cam_right", "overview")  # in the order of CompositeView.panels
SCENE_IMAGE_SIZE = (640, 480)  # width, height of each scene image, pixels
SCENE_SEED = 3  # the target of the scene images


def runs() -> list[tuple[str, str]]:
    """(reach env, run folder) of every robot in the registry's default runs: each is trained,
    evaluated and filmed."""
    return [(spec.reach_env, spec.short) for spec in ROBOTS.values() if spec.default_runs]


def scene_images(out: Path) -> list[Path]:
    """Both sensing cameras and the overview of every robot's scene, at the home pose with a
    target drawn by ``reset(seed=SCENE_SEED)``, as PNG: what the cameras see (target and green
    marker), with an inset magnifying the marker where the arm is small in the camera views
    (:attr:`envs.robots.RobotSpec.magnify`: RIACS)."""
    paths = []
    for name in cli.progress(tuple(ROBOTS), "scene images", "scene"):
        joints = ROBOTS[name].joint_options[0]  # the fewest joints the arm's envs control
        env = ReachEnv(robot=name, joints=joints, sensing="project", control="kinematic")
        _, info = env.reset(seed=SCENE_SEED)  # home pose, a target in the workspace
        width, height = SCENE_IMAGE_SIZE
        sensing_size = (env.image_width, env.image_height)
        view = CompositeView(env.model, height, width, sensing_size)
        marker = env.stereo.project(info["effector_pos"][None])[0]  # (4,) sensing pixels
        nothing = np.full(4, np.nan)  # no overlays: the picture shows what the camera sees
        panels = view.panels(env.data, nothing, nothing)
        for k, (camera, image) in enumerate(zip(CAMERAS, panels, strict=True)):
            if ROBOTS[name].magnify and k < 2:
                draw_inset(image, view.to_panel(marker[2 * k : 2 * k + 2]), height / 480)
            path = out / f"{name}_{camera}.png"
            _, png = cv2.imencode(".png", image[..., ::-1])  # cv2.imwrite hides a failed write
            paths.append(write_atomic(path, lambda f, png=png: f.write(png.tobytes())))
        view.close()
        env.close()
    return paths


def main(argv: list[str] | None = None) -> None:
    p = cli.parser(__doc__)
    options.OUT.add(p, default=Path("runs/demo"))
    options.TRIALS.add(p, default=10_000)
    options.TARGETS.add(p, default=300, help="held-out targets per evaluation")
    args = p.parse_args(argv)
    start = time.time()
    results = {}
    scene_images(args.out / "scenes")
    for env_id, short in runs():
        run = args.out / short
        print(f"\n== {env_id}: training {args.trials} trials (exact projection, kinematic) ==")
        # --force: a demo run starts over in its folder (make demo twice gives the same files)
        train.main(["--env", env_id, "--trials", str(args.trials), "--out", str(run),
                    "--eval-trials", "100", "--force"])  # fmt: skip
        for sensing, control in (("project", "kinematic"), ("foveated", "servo")):
            print(f"\n-- {env_id}: evaluation with sensing={sensing}, control={control} --")
            summary = evaluate.main(["--run", str(run), "--targets", str(args.targets),
                                     "--sensing", sensing, "--control", control,
                                     "--out", str(run / f"eval_{sensing}_{control}")]
                                    + (["--no-plots"] if sensing == "project" else []))  # fmt: skip
            results[f"{short}_{sensing}_{control}"] = summary["controllers"][0]
    for env_id, short in runs():
        # The map above, the exact IK below, on the same targets, filmed in real time.
        video.main(["--env", env_id, "--controller", str(args.out / short / "checkpoint.npz"),
                    "--compare", "analytic", "--trials", "5",
                    "--out", str(args.out / f"{short}_som.mp4")])  # fmt: skip
    write_json(args.out / "summary.json", results)
    print(f"\nDone in {time.time() - start:.0f} s. Under {args.out}/:")
    print("  scenes/*.png                 both cameras and an overview of each scene")
    shorts = [short for _, short in runs()]
    for files, what in (
        ([f"{s}/" for s in shorts], "trained maps (checkpoint.npz), metrics.jsonl, learning curve"),
        ([f"{s}/eval_*/" for s in shorts], "evaluation tables and plots (rendered sensing, servo)"),
        ([f"{s}_som.mp4" for s in shorts], "the map (top) and exact IK (below) moving, real time"),
    ):
        print(f"  {', '.join(files):<28} {what}")
    print("  summary.json                 errors after each move (all trials), every arm")


#: Console entry point ``visuomotor-demo``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
