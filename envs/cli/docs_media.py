"""The documentation's animations: one small looping GIF per environment, in docs/assets/.

RiacsReach-v0, PumaReach-v0 and PumaGrasp-v0 show the learned map: each is trained here first
(``scripts/train.py``'s idealised setting, :data:`TRAINING_TRIALS` trials, --seed; seconds on the
reach envs, under a minute on the grasp env), then filmed on held-out targets with servo control
and foveated sensing (a coarse move and fine moves), both camera views and the overview.
PumaTrack-v0: the overview of the PUMA following a held-out circle with NATEnet, trained here
as ``scripts/train_natenet.py`` trains it (its default paths, --seed), the path and the tool's
trace drawn. The
overlay text is large for the GIFs' size, so that it reads on the pages that show them scaled
down. Each file stays under 2 MB.

.venv/bin/python scripts/docs_media.py                  (writes docs/assets/<EnvId>.gif)
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options, train
from envs.cli.controllers import make_controller
from envs.grasp import GRASP_ENV_IDS
from envs.harness.checkpoint import checkpoint_path
from envs.harness.film import TrialFilm, side_by_side
from envs.harness.grasp_film import GraspFilm
from envs.harness.streams import seed_env
from envs.harness.video import annotate
from envs.robots import default_grasp_env_ids, default_reach_env_ids
from learners.natenet import PathTracker
from learners.persistence import write_atomic

GIF_FPS = 12.0  # frames per second of the animations
GIF_PANEL = (256, 192)  # width, height of each panel of the reach animations, pixels
TRACK_WIDTH = 400  # width of the PumaTrack animation, pixels
MAX_BYTES = 2_000_000  # the largest GIF the docs accept
#: OpenCV font scale of the overlays: 23-pixel lines on a 768-pixel-wide GIF, still legible
#: where a page shows it at 680 pixels (the docs site's content width).
TEXT_SCALE = 0.52
#: Training trials of each animated map: the demo's 10 000 on the reach envs, 2 per leaf of the
#: grasp env's default lattice (docs/grasp.md).
TRAINING_TRIALS = {"RiacsReach-v0": 10_000, "PumaReach-v0": 10_000, "PumaGrasp-v0": 6_144}
FINE_MOVES = {"RiacsReach-v0": 1, "PumaReach-v0": 1, "PumaGrasp-v0": 2}


def trained_map(env_id: str, seed: int, folder: Path) -> Path:
    """Train ``env_id``'s map into ``folder`` (scripts/train.py with its defaults but
    :data:`TRAINING_TRIALS` and one held-out evaluation at the end) and return its checkpoint."""
    trials = str(TRAINING_TRIALS[env_id])
    train.main(["--env", env_id, "--trials", trials, "--seed", str(seed), "--eval-every", trials,
                "--eval-trials", "100", "--out", str(folder), "--force"])  # fmt: skip
    return checkpoint_path(folder)


def map_title(env_id: str) -> str:
    """The first overlay line: the env and the learned map."""
    return f"{env_id}   learned map (SOM, {TRAINING_TRIALS[env_id]:,} training trials)"


def map_frames(env_id: str, checkpoint: Path, trials: int, seed: int) -> list[np.ndarray]:
    """Frames of the map of ``checkpoint`` on ``trials`` held-out targets (evaluation set
    ``seed``), servo control and foveated sensing: one coarse and :data:`FINE_MOVES` fine moves
    each."""
    grasp = env_id in GRASP_ENV_IDS
    render = {"render_mode": "rgb_array"} if grasp else {}  # the grasp env draws its own views
    env = gym.make(env_id, sensing="foveated", control="servo", **render)
    controller = make_controller(str(checkpoint), env, seed)
    seed_env(env, seed, "evaluation")  # targets no training run draws
    film = (GraspFilm if grasp else TrialFilm)(
        env, map_title(env_id), fps=GIF_FPS, panel=GIF_PANEL, text_scale=TEXT_SCALE
    )
    frames = []
    for i in range(trials):
        _, stages = film.trial(controller, FINE_MOVES[env_id], f"trial {i + 1}/{trials}")
        frames += side_by_side([stages])
    film.close()
    env.close()
    return frames


def trained_tracker(seed: int) -> tuple[PathTracker, int]:
    """NATEnet trained as ``scripts/train_natenet.py`` trains it (its defaults: the training
    paths, exploration and input of :class:`~envs.studies.natenet_tracking.TrackingStudy`), as a
    path tracker, and its node count."""
    from envs.harness.tracking import train_on_paths
    from envs.studies.natenet_tracking import TRAIN_SEEDS, TrackingStudy
    from envs.track import PumaTrackEnv
    from learners.natenet import NATEnet

    study = TrackingStudy(out=Path("."), seed=seed)
    env = PumaTrackEnv(sensing=study.sensing, path_kind="any")
    net = NATEnet(input_dim=study.input_dim, max_nodes=study.max_nodes)
    paths = seed * 10_000 + TRAIN_SEEDS + np.arange(study.train_paths)
    rng = np.random.default_rng(seed)
    train_on_paths(env, net, paths, study.exploration, rng, study.gain)
    env.close()
    print(f"trained NATEnet on {study.train_paths} paths: {net.n_nodes} nodes")
    return PathTracker.from_net(net, study.gain), net.n_nodes


def track_frames(seed: int, every: int = 2) -> list[np.ndarray]:
    """Every ``every``-th overview frame of one held-out PumaTrack-v0 path (a test circle of
    ``scripts/train_natenet.py``) tracked by the NATEnet of :func:`trained_tracker`."""
    from envs.harness.tracking import track_episode
    from envs.studies.natenet_tracking import CIRCLE_SEEDS, TEST_RADIUS

    tracker, nodes = trained_tracker(seed)
    env = gym.make(
        "PumaTrack-v0", render_mode="rgb_array", path_kind="circle", circle_radius=TEST_RADIUS
    )
    result = track_episode(env, tracker, seed=CIRCLE_SEEDS + seed * 10_000, record=True)
    env.close()
    frames = result.frames[::every]
    height = round(frames[0].shape[0] * TRACK_WIDTH / frames[0].shape[1])
    errors = np.concatenate([[0.0], result.position_errors])[::every]  # m, after each step
    return [
        annotate(
            cv2.resize(f, (TRACK_WIDTH, height), interpolation=cv2.INTER_AREA),
            [f"PumaTrack-v0   learned NATEnet ({nodes} nodes)", f"error {1e3 * e:.2f} mm"],
            TEXT_SCALE * TRACK_WIDTH / (3 * GIF_PANEL[0]) * 1.4,
        )
        for f, e in zip(frames, errors, strict=True)
    ]


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
    for env_id in (*default_reach_env_ids(), *default_grasp_env_ids()):
        with tempfile.TemporaryDirectory(prefix="docs_media_") as folder:
            checkpoint = trained_map(env_id, args.seed, Path(folder) / "run")
            frames = map_frames(env_id, checkpoint, args.trials, args.seed)
        written.append(write_gif(frames, args.out / f"{env_id}.gif", GIF_FPS))
    written.append(write_gif(track_frames(args.seed), args.out / "PumaTrack-v0.gif", GIF_FPS))
    for path in written:
        print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return written


#: Console entry point ``visuomotor-docs-media``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
