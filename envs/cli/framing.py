"""How well each arm's cameras frame its workspace: the share of random moves whose marker and
target both sensing cameras, and both pixel cameras (``obs_mode="pixels"``), show, why the others
fail, and the target's and marker's pixels and the arm's share of the image at the pixel size.

    .venv/bin/python scripts/framing.py --moves 2000 --pixel-moves 200 [--seed 0] \
        [--sheet docs/assets/pixel_observations.png]
"""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.robots import reach_env_ids
from envs.studies.framing import markdown, observation_row, study
from learners.persistence import write_atomic

SHEET_SCALE = 3  # screen pixels per observation pixel in the sheet


def main(argv: list[str] | None = None) -> dict:
    p = cli.parser(__doc__)
    cli.add_count(p, "--moves", 2000, "random moves per arm (projected)")
    cli.add_count(p, "--pixel-moves", 200, "of them, rendered to count pixels")
    options.SEED.add(p)
    options.JSON.add(p, help="also write the results here")
    p.add_argument(
        "--sheet",
        type=cli.out_file,
        default=None,
        help="also write each arm's 84x84 image observation after a random move here (PNG)",
    )
    args = p.parse_args(argv)
    results, rows = {}, []
    for env_id in reach_env_ids():
        env = gym.make(env_id, sensing="project", control="kinematic", obs_mode="pixels")
        results[env_id] = study(env.unwrapped, args.moves, args.pixel_moves, args.seed)
        if args.sheet is not None:
            rows.append(observation_row(env, args.seed, SHEET_SCALE))
        env.close()
    print(markdown(results))
    if args.sheet is not None:
        _, png = cv2.imencode(".png", np.concatenate(rows)[..., ::-1])  # imwrite hides a failure
        write_atomic(args.sheet, lambda f: f.write(png.tobytes()))
    if args.json is not None:
        write_json(args.json, results)
    return results


#: Console entry point ``visuomotor-framing``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
