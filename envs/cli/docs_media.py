"""The documentation's animations: one small looping GIF per environment, in docs/assets/.

RiacsReach-v0 and PumaReach-v0: reach trials filmed as the arm moves (servo control, foveated
sensing, the exact IK as controller: no training needed), both camera views and the overview.
PumaTrack-v0: the overview of the PUMA following a path with the exact inverse Jacobian, the
path and the tool's trace drawn. PumaGrasp-v0: the hand brought onto objects by the exact pose IK
(``envs.harness.grasp_film``). Each file stays under 2 MB.

.venv/bin/python scripts/docs_media.py                  (writes docs/assets/<EnvId>.gif)
"""

from __future__ import annotations

from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.cli.controllers import make_controller
from envs.harness.film import TrialFilm, side_by_side
from envs.harness.grasp_film import grasp_frames
from envs.robots import default_reach_env_ids
from learners.persistence import write_atomic

GIF_FPS = 12.0  # frames per second of the animations
GIF_PANEL = (256, 192)  # width, height of each panel of the reach animations, pixels
TRACK_WIDTH = 400  # width of the PumaTrack animation, pixels
MAX_BYTES = 2_000_000  # the largest GIF the docs accept


def reach_frames(env_id: str, trials: int, seed: int) -> list[np.ndarray]:
    """Frames of ``trials`` filmed reach trials (one coarse and one fine move each)."""
    env = gym.make(env_id, sensing="foveated", control="servo")
    env.reset(seed=seed)
    title = f"{env_id}  exact IK  sensing=foveated  control=servo"
    film = TrialFilm(env, title, fps=GIF_FPS, panel=GIF_PANEL)
    controller = make_controller("analytic", env, seed)
    frames = []
    for i in range(trials):
        _, stages = film.trial(controller, 1, f"trial {i + 1}/{trials}")
        frames += side_by_side([stages])
    film.close()
    env.close()
    return frames


def track_frames(seed: int, every: int = 2) -> list[np.ndarray]:
    """Every ``every``-th overview frame of one PumaTrack-v0 path tracked exactly."""
    from envs.harness.tracking import exact_inverse_jacobian, track_episode
    from learners.natenet import PathTracker

    env = gym.make("PumaTrack-v0", render_mode="rgb_array")
    result = track_episode(env, PathTracker(exact_inverse_jacobian), seed=seed, record=True)
    env.close()
    frames = result.frames[::every]
    height = round(frames[0].shape[0] * TRACK_WIDTH / frames[0].shape[1])
    return [cv2.resize(f, (TRACK_WIDTH, height), interpolation=cv2.INTER_AREA) for f in frames]


def write_gif(frames: list[np.ndarray], path: Path, fps: float) -> Path:
    """A looping GIF of RGB frames; ValueError if it is not under MAX_BYTES."""
    import imageio.v3 as iio

    gif = iio.imwrite("<bytes>", np.stack(frames), extension=".gif", duration=1000 / fps, loop=0)
    write_atomic(path, lambda f: f.write(gif))
    size = path.stat().st_size
    if size >= MAX_BYTES:
        raise ValueError(f"{path} is {size} bytes, over {MAX_BYTES}; use fewer --trials")
    return path


def main(argv: list[str] | None = None) -> list[Path]:
    parser = cli.parser(__doc__)
    options.OUT.add(parser, default=Path("docs/assets"))
    options.TRIALS.add(parser, default=2)
    options.SEED.add(parser, default=1)
    args = parser.parse_args(argv)
    written = []
    for env_id in default_reach_env_ids():
        frames = reach_frames(env_id, args.trials, args.seed)
        written.append(write_gif(frames, args.out / f"{env_id}.gif", GIF_FPS))
    written.append(write_gif(track_frames(args.seed), args.out / "PumaTrack-v0.gif", GIF_FPS))
    grasp = grasp_frames(args.trials, args.seed, GIF_FPS, GIF_PANEL)
    written.append(write_gif(grasp, args.out / "PumaGrasp-v0.gif", GIF_FPS))
    for path in written:
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return written


#: Console entry point ``visuomotor-docs-media``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
