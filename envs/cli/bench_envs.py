"""Reach-env speed: steps per second for every robot × sensing × control, against Gymnasium's
``Reacher-v5`` measured in the same run, plus the cost of one rendered stereo sensing, plus the
RL loop.

    .venv/bin/python scripts/bench_envs.py [--steps 200] [--json runs/bench_envs.json]
    .venv/bin/python scripts/bench.py envs [same options]
    .venv/bin/python scripts/bench_envs.py --rl-only [--rl-steps 20000] [--rl-rounds 5]
        [--rl-clock thread]
    .venv/bin/python scripts/bench_envs.py --agents-only [--sb3-steps 600]

Agents (also in the full run): image observations (``obs_mode="pixels"``, two 84×84 cameras,
project sensing, kinematic control) in steps/s against ``Reacher-v5`` in
``gymnasium.wrappers.AddRenderObservation`` at 84×84 (its image replaces its observation); the
``render()`` frame's milliseconds (wall and this process's CPU time, which leaves out other
processes' load); and, with the rl extra, SAC + HER against plain SAC in time per env step, in
alternating rounds of the same run (``copy_info_dict=True``, one torch thread).

RL loop: the loop of an RL library, on ``gym.make`` envs (their registered time limits and
wrappers), random actions, ``reset()`` whenever an episode ends (every 4 moves for the reach
envs, every 50 steps for Reacher-v5). ``RiacsReach-v0`` and ``PumaReach-v0`` (project,
kinematic) and Reacher-v5 run in alternating rounds so that load from other processes falls on
all of them; reported: transitions/s with the resets, steps/s without them, µs per reset, each
with its ratio to Reacher-v5. ``--rl-clock thread`` times the loop in this thread's CPU time
instead of wall time: on a shared machine it leaves out the time other processes take the core
(they still slow it through shared caches and hyper-threads).

Each row: construct the env (not timed), reset it (not timed: this also starts the renderers),
then time ``--steps`` moves with random in-range commands drawn beforehand. The envs are stepped
unwrapped (no TimeLimit or checker), the peer too.
"""

from __future__ import annotations

from importlib.util import find_spec

from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.studies import env_speed as speed


def main(argv: list[str] | None = None) -> dict:
    parser = cli.parser(__doc__)
    cli.add_count(parser, "--steps", 200, "timed moves per env row")
    cli.add_count(parser, "--peer-steps", 5000, "timed Reacher-v5 steps")
    cli.add_count(parser, "--sense-repeats", 50, "timed sensing calls")
    options.SEED.add(parser)
    cli.add_count(parser, "--rl-steps", 20_000, "RL-loop steps per round")
    cli.add_count(parser, "--rl-rounds", 5, "alternating RL-loop rounds")
    parser.add_argument("--rl-only", action="store_true", help="only the RL loop")
    parser.add_argument(
        "--agents-only", action="store_true", help="only images, render() and SAC + HER"
    )
    cli.add_count(parser, "--sb3-steps", 600, "env steps per SAC run")
    cli.add_count(parser, "--sb3-rounds", 2, "alternating SAC / HER rounds")
    parser.add_argument(
        "--rl-clock",
        choices=tuple(speed.CLOCKS),
        default="wall",
        help="RL loop: wall or thread time",
    )
    options.JSON.add(parser)
    args = parser.parse_args(argv)
    if args.rl_only and args.agents_only:
        parser.error("choose one of --rl-only and --agents-only")
    if not args.rl_only and find_spec("torch") is not None:
        import torch._dynamo  # noqa: F401  (before anything renders: see compare_rl)
    results: dict = {}
    if not (args.rl_only or args.agents_only):
        results = speed.measure(args.steps, args.peer_steps, args.sense_repeats, args.seed)
        print(speed.format_table(results))
    if not args.rl_only:
        results["agents"] = speed.measure_agents(
            args.steps, args.sb3_steps, args.sb3_rounds, args.seed
        )
        print(speed.format_agents(results["agents"]))
    if not args.agents_only:
        results["rl_loop"] = speed.time_rl_loop(
            args.rl_steps, args.rl_rounds, args.seed, args.rl_clock
        )
        print(speed.format_rl_table(results["rl_loop"]))
    if args.json is not None:
        write_json(args.json, results)
        print(f"wrote {args.json}")
    return results


#: Console entry point ``visuomotor-bench-envs``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
