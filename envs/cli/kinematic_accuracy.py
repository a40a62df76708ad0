"""Kinematic accuracy of an arm at one pose: Němeček's linear error model, reverse-mode derivatives.

    .venv/bin/python scripts/accuracy.py --robot puma560 --pose 30 -100 40 20 30 40
    .venv/bin/python scripts/accuracy.py --robot riacs                # pose default: keyframe home

Prints (1) the sensitivity table: tool-point displacement per unit deviation of every chain
parameter (mm per mm for lengths, mm per degree for angles; also the tool rotation), sorted, and
(2) the check of the linear model against MuJoCo models compiled from perturbed MJCF: predicted vs
actual tool error for deviations of 0.1 % and 1 % of each parameter (a parameter that is zero: 0.1
mm / 0.1° at 0.1 %, 1 mm / 1° at 1 %), one at a time and all at once with random signs.
Writes ``accuracy.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from models.analyses import nemecek_accuracy as acc
from models.arms import arm_kinematics

LEVELS = (0.001, 0.01)
MM, DEG = 1e3, 180 / np.pi


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = cli.parser(__doc__)
    p.add_argument("--robot", choices=acc.chain_robots(), default="puma560")
    p.add_argument("--pose", type=float, nargs="+", help="joint angles in degrees (default: home)")
    p.add_argument(
        "--levels",
        type=float,
        nargs="+",
        default=list(LEVELS),
        help="relative deviations (0.001 = 0.1 %%)",
    )
    options.SEED.add(p, help="signs of the all-at-once deviation")
    options.OUT.add(p, default=None, help="default runs/accuracy/<robot>")
    return p.parse_args(argv)


def units(is_angle: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Per parameter: factor from SI per-unit to 'per mm' / 'per degree', and the unit name."""
    return np.where(is_angle, 1 / DEG, 1 / MM), ["deg" if a else "mm" for a in is_angle]


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    rc = acc.robot_chain(args.robot)
    joints = len(rc.joints)
    theta = arm_kinematics(args.robot, joints).home if args.pose is None else np.radians(args.pose)
    if theta.shape != (joints,):
        cli.fail(f"--pose needs {joints} angles (degrees) for {args.robot}")
    out = args.out or Path("runs/accuracy") / args.robot
    out.mkdir(parents=True, exist_ok=True)

    k = rc.parameters(theta)
    is_angle = rc.is_angle()
    per_unit, unit = units(is_angle)
    dp, dphi = acc.sensitivity(rc, theta)
    move = np.linalg.norm(dp, axis=1) * MM * per_unit  # mm per mm or mm per deg
    turn = np.linalg.norm(dphi, axis=1) * DEG * per_unit  # deg per mm or deg per deg
    print(f"{args.robot} at θ = {np.round(np.degrees(theta), 3).tolist()} deg")
    print(f"\nSensitivity of the tool point ({len(k)} chain parameters, largest first)")
    print(f"{'parameter':>10} {'value':>10} {'unit':>4} {'tcp mm/unit':>12} {'tool deg/unit':>14}")
    for j in np.argsort(-move):
        value = k[j] * (DEG if is_angle[j] else MM)
        print(
            f"{rc.chain.names[j]:>10} {value:>10.3f} {unit[j]:>4} {move[j]:>12.4f} {turn[j]:>14.4f}"
        )

    checks = []
    for level in args.levels:
        c = acc.check_linear_model(rc, theta, level, np.random.default_rng(args.seed))
        actual = np.linalg.norm(c.single_actual, axis=1) * MM
        miss = np.linalg.norm(c.single_predicted - c.single_actual, axis=1) * MM
        print(f"\nLinear model vs MuJoCo, deviation {100 * level:g} % (one parameter at a time)")
        print(
            f"{'parameter':>10} {'Δk':>10} {'unit':>4} {'actual mm':>11} {'predicted':>11} "
            f"{'|pred-act| mm':>14}"
        )
        for j in np.argsort(-actual):
            dk = c.dk[j] * (DEG if is_angle[j] else MM)
            pred = np.linalg.norm(c.single_predicted[j]) * MM
            print(
                f"{rc.chain.names[j]:>10} {dk:>10.4f} {unit[j]:>4} {actual[j]:>11.5f} "
                f"{pred:>11.5f} {miss[j]:>14.3e}"
            )
        all_act, all_miss = (
            np.linalg.norm(v) * MM for v in (c.all_actual, c.all_predicted - c.all_actual)
        )
        ang_act, ang_miss = (
            np.linalg.norm(v) * DEG
            for v in (c.all_angle_actual, c.all_angle_predicted - c.all_angle_actual)
        )
        print(
            f"all at once: tcp error actual {all_act:.5f} mm, predicted "
            f"{np.linalg.norm(c.all_predicted) * MM:.5f} mm, miss {all_miss:.3e} mm; "
            f"rotation actual {ang_act:.5f}°, miss {ang_miss:.3e}°"
        )
        checks.append(
            {
                "level": level,
                "dk": c.dk.tolist(),
                "single_actual_m": c.single_actual.tolist(),
                "single_predicted_m": c.single_predicted.tolist(),
                "all_actual_m": c.all_actual.tolist(),
                "all_predicted_m": c.all_predicted.tolist(),
                "all_angle_actual_rad": c.all_angle_actual.tolist(),
                "all_angle_predicted_rad": c.all_angle_predicted.tolist(),
                "max_single_miss_m": float(miss.max() / MM),
                "all_miss_m": float(all_miss / MM),
            }
        )
    result = {
        "robot": args.robot,
        "theta_rad": theta.tolist(),
        "parameters": list(rc.chain.names),
        "k": k.tolist(),
        "is_angle": is_angle.tolist(),
        "sensitivity_dp_per_unit": dp.tolist(),
        "sensitivity_dphi_per_unit": dphi.tolist(),
        "checks": checks,
    }
    write_json(out / "accuracy.json", result)
    print(f"\nwrote {out / 'accuracy.json'}")


#: Console entry point ``visuomotor-accuracy``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
