"""Rendered marker sensing (whole images and foveated) against the exact projection, by the
fraction of the marker that the robot hides.

    .venv/bin/python scripts/sensing_accuracy.py --poses 400 [--image-size 320x240] [--seed 0]
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.robots import default_reach_env_ids
from envs.studies.sensing_accuracy import measure, table


def main(argv: list[str] | None = None) -> dict:
    p = cli.parser(__doc__)
    cli.add_count(p, "--poses", 400, "random poses per arm")
    options.IMAGE_SIZE.add(p, default="320x240")
    options.SEED.add(p)
    options.JSON.add(p, help="also write the rows here")
    args = p.parse_args(argv)
    width, height = args.image_size
    results = {}
    for env_id in default_reach_env_ids():
        cli.check_image_size(env_id, args.image_size)
        env = gym.make(env_id, sensing="render", control="kinematic", width=width, height=height)
        env.reset(seed=args.seed)
        rows = table(measure(env, args.poses, np.random.default_rng(args.seed)))
        env.close()
        results[env_id] = rows
        print(f"{env_id}: {args.poses} poses, 2 cameras, errors in px against the projection")
        print(f"{'hidden':>11} {'views':>6}   {'whole: seen, mean, max':>24}   "
              f"{'foveated: seen, mean, max':>26}")  # fmt: skip
        for r in rows:
            line = f"{r['hidden_from']:>4.2f}-{r['hidden_to']:<4.2f}  {r['views']:>6}"
            for name in ("whole", "foveated"):
                line += (f"   {r[name + '_visible'] * 100:>6.1f}% {r[name + '_mean_px']:>7.3f}"
                         f" {r[name + '_max_px']:>7.3f}")  # fmt: skip
            print(line)
    if args.json is not None:
        write_json(args.json, results)
    return results


#: Console entry point ``visuomotor-sensing-accuracy``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
