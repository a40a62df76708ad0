"""How well each arm's cameras frame its workspace: the share of random moves whose marker and
target both sensing cameras, and both pixel cameras (``obs_mode="pixels"``), show, why the others
fail, and the target's and marker's pixels and the arm's share of the image at the pixel size.

    .venv/bin/python scripts/framing.py --moves 2000 --pixel-moves 200 [--seed 0]
"""

from __future__ import annotations

import gymnasium as gym

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.robots import reach_env_ids
from envs.studies.framing import markdown, study


def main(argv: list[str] | None = None) -> dict:
    p = cli.parser(__doc__)
    cli.add_count(p, "--moves", 2000, "random moves per arm (projected)")
    cli.add_count(p, "--pixel-moves", 200, "of them, rendered to count pixels")
    options.SEED.add(p)
    options.JSON.add(p, help="also write the results here")
    args = p.parse_args(argv)
    results = {}
    for env_id in reach_env_ids():
        env = gym.make(env_id, sensing="project", control="kinematic")
        results[env_id] = study(env.unwrapped, args.moves, args.pixel_moves, args.seed)
        env.close()
    print(markdown(results))
    if args.json is not None:
        write_json(args.json, results)
    return results


#: Console entry point ``visuomotor-framing``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
