"""The redundancy study: the swivel angle against points built by hand and against a rotation of
the Panda-type arm's elbow about its shoulder-wrist line, its points against MuJoCo's bodies and
joint axes, the neighbour jumps of a hand-made lattice, the count of commands outside the joint
ranges, and the program on a small run against evaluate.py's numbers for the same targets."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
import models
from envs.cli import evaluate as evaluate_cli
from envs.cli import redundancy as redundancy_cli
from envs.harness.training import RunConfig, Trainer
from envs.studies.redundancy import (
    RedundancyError,
    arm_points,
    arm_swivel,
    at_limits,
    dh_arm_of,
    neighbour_steps,
    outside_ranges,
    step_figures,
    swivel_angle,
    wrapped,
)
from envs.studies.redundancy_plot import links

from helpers import assert_drawn_png

PANDA = dh_arm_of("panda")
#: An in-range Panda posture away from singularities (rad).
POSTURE = np.array([0.3, -0.4, 0.2, -2.0, 0.3, 1.8, 0.5])


def _rotated(point: np.ndarray, centre: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``point`` turned by ``angle`` about the line through ``centre`` along ``axis``
    (Rodrigues' formula)."""
    k = axis / np.linalg.norm(axis)
    v = point - centre
    turned = v * math.cos(angle) + np.cross(k, v) * math.sin(angle)
    return centre + turned + k * (k @ v) * (1 - math.cos(angle))


def _turned_shoulder(theta: np.ndarray, angle: float) -> np.ndarray:
    """Joints 1-3 solved (Gauss-Newton, finite differences) so that the wrist stays and the
    elbow moves to where turning it by ``angle`` about the shoulder-wrist line puts it."""
    shoulder, elbow, wrist = arm_points(PANDA, theta)
    goal = np.concatenate([_rotated(elbow, shoulder, wrist - shoulder, angle), wrist])

    def residual(q: np.ndarray) -> np.ndarray:
        _, e, w = arm_points(PANDA, np.concatenate([q, theta[3:]]))
        return np.concatenate([e, w]) - goal

    q = theta[:3].copy()
    for _ in range(50):
        r = residual(q)
        jac = np.stack([(residual(q + h) - r) / 1e-7 for h in np.eye(3) * 1e-7], axis=1)
        q -= np.linalg.lstsq(jac, r, rcond=None)[0]
    assert np.abs(residual(q)).max() < 1e-10  # the turn is reachable with joints 1-3
    return np.concatenate([q, theta[3:]])


# ---- the swivel angle


def test_the_swivel_angle_of_points_built_by_hand():
    """S→W along x: the elbow above the line is 0, turned about +x by the right-hand rule
    (towards -y) +90°, below ±180°, towards +y -90°; a vertical S→W has none."""
    s, w = np.zeros(3), np.array([1.0, 0.0, 0.0])
    elbows = np.array([[0.3, 0.0, 0.5], [0.3, -0.5, 0.0], [0.6, 0.0, -0.2], [0.3, 0.4, 0.0]])
    psi = swivel_angle(s, elbows, w)
    np.testing.assert_allclose(np.degrees(psi[[0, 1, 3]]), [0.0, 90.0, -90.0], atol=1e-12)
    assert abs(abs(np.degrees(psi[2])) - 180.0) < 1e-12
    assert np.isnan(swivel_angle(s, np.array([0.5, 0.0, 0.5]), np.array([0.0, 0.0, 1.0])))


@pytest.mark.parametrize("angle", [0.4, -0.25, 1.1])
def test_turning_the_elbow_about_the_shoulder_wrist_line_changes_the_swivel_by_that_angle(angle):
    turned = _turned_shoulder(POSTURE, angle)
    assert wrapped(arm_swivel(PANDA, turned) - arm_swivel(PANDA, POSTURE)) == pytest.approx(
        angle, abs=1e-8
    )
    # the turn moved the elbow, not the shoulder or the wrist
    before, after = arm_points(PANDA, POSTURE), arm_points(PANDA, turned)
    np.testing.assert_allclose(after[0], before[0], atol=1e-12)
    np.testing.assert_allclose(after[2], before[2], atol=1e-9)
    assert np.linalg.norm(after[1] - before[1]) > 0.01


def _on_line(point: np.ndarray, anchor: np.ndarray, axis: np.ndarray) -> float:
    """Distance (m) of ``point`` from the line through ``anchor`` along ``axis``."""
    return float(np.linalg.norm(np.cross(point - anchor, axis / np.linalg.norm(axis))))


def test_shoulder_elbow_and_wrist_are_where_mujoco_puts_the_bodies_and_on_their_joint_axes():
    model = models.load_model("panda")
    data = mujoco.MjData(model)
    for theta in (POSTURE, PANDA.home):
        for i, q in enumerate(theta, start=1):
            data.qpos[model.joint(f"joint{i}").qposadr[0]] = q
        mujoco.mj_kinematics(model, data)
        shoulder, elbow, wrist = arm_points(PANDA, theta)
        for point, body in ((shoulder, "link2"), (elbow, "link4"), (wrist, "link6")):
            np.testing.assert_allclose(point, data.body(body).xpos, atol=1e-9)

        def axis(i: int) -> tuple[np.ndarray, np.ndarray]:
            j = model.joint(f"joint{i}").id
            return data.xanchor[j], data.xaxis[j]

        for point, joints in ((shoulder, (1, 2, 3)), (elbow, (4,)), (wrist, (5, 6))):
            for i in joints:
                assert _on_line(point, *axis(i)) < 1e-9, (i, point)
        assert _on_line(wrist, *axis(7)) > 0.08  # joint 7's axis passes the wrist 0.088 m off


def test_a_robot_without_swivel_points_is_refused_naming_what_to_add():
    with pytest.raises(RedundancyError, match="swivel_joints"):
        dh_arm_of("ur5e")


# ---- jumps between neighbours


def test_neighbour_steps_of_a_hand_made_lattice():
    """(4, 3, 2) lattice, all 0 but neuron (1, 1, 0) at 0.3: 46 neighbour pairs, 5 of them
    (its neighbours) 0.3 apart."""
    lattice = (4, 3, 2)
    values = np.zeros(lattice)
    values[1, 1, 0] = 0.3
    steps = neighbour_steps(values.ravel(), lattice, circular=False)
    assert len(steps) == 3 * 3 * 2 + 4 * 2 * 2 + 4 * 3 * 1
    assert steps.max() == pytest.approx(0.3)
    assert np.sum(np.isclose(steps, 0.3)) == 5 and np.sum(steps == 0) == len(steps) - 5
    figures = step_figures(steps)
    assert figures["max_deg"] == pytest.approx(math.degrees(0.3), abs=1e-3)
    assert figures["median_deg"] == 0.0
    # two joints at once: the second joint's column twice the first's
    both = neighbour_steps(np.stack([values.ravel(), 2 * values.ravel()], 1), lattice, False)
    np.testing.assert_allclose(both, np.stack([steps, 2 * steps], 1))


def test_neighbour_steps_of_angles_wrap_around_the_circle():
    values = np.array([math.pi - 0.01, -math.pi + 0.01, -math.pi + 0.03])  # a 1-D lattice of 3
    np.testing.assert_allclose(neighbour_steps(values, (3,), circular=True), [0.02, 0.02])
    np.testing.assert_allclose(
        neighbour_steps(values, (3,), circular=False), [2 * math.pi - 0.02, 0.02]
    )


def test_the_figure_links_join_lattice_neighbours_only():
    lattice = (4, 3, 2)
    coords = np.indices(lattice).reshape(3, -1).T.astype(float)  # C order
    segments = links(coords, lattice)
    assert len(segments) == len(neighbour_steps(np.zeros(24), lattice, circular=False))
    np.testing.assert_allclose(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1), 1.0)
    assert len({tuple(sorted(map(tuple, s))) for s in segments}) == len(segments)  # each once


# ---- commands against the joint ranges


def test_commands_outside_the_ranges_and_at_a_range_end_are_counted_once_each():
    lower, upper = np.array([-1.0, -1.0]), np.array([1.0, 2.0])
    commands = np.array(
        [[0.0, 0.0], [1.0, 2.0], [1.0 + 1e-9, 0.0], [-2.0, 3.0], [0.0, -1.0], [0.5, -1.0 - 1e-12]]
    )
    assert outside_ranges(commands, lower, upper) == 3
    assert at_limits(commands, lower, upper) == 2


# ---- the program on a small run


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("panda_run")
    config = RunConfig.of(
        env="PandaReach-v0", trials=40, lattice=(3, 3, 2), eval_every=40, eval_trials=5, seed=1
    )
    trainer = Trainer(config, out)
    try:
        trainer.run()
    finally:
        trainer.close()
    return out


def test_the_program_counts_every_move_and_reports_evaluate_s_errors(small_run, tmp_path):
    targets = 12
    summary = redundancy_cli.main(
        ["--run", str(small_run), "--targets", str(targets), "--out", str(tmp_path / "r")]
    )
    written = json.loads((tmp_path / "r" / redundancy_cli.JSON_FILE).read_text())
    assert written == json.loads(json.dumps(summary))
    assert_drawn_png(tmp_path / "r" / redundancy_cli.FIGURE_FILE)
    commands = summary["commands"]
    assert commands["coarse"]["commands"] == targets  # project sensing sees every target
    assert (
        commands["all"]["commands"] == commands["coarse"]["commands"] + commands["fine"]["commands"]
    )
    assert commands["fine"]["commands"] == 2 * targets
    assert commands["all"]["outside_ranges"] == 0  # the map clips every command
    assert summary["neighbour_pairs"] == 2 * 3 * 2 + 3 * 2 * 2 + 3 * 3 * 1
    assert len(summary["joint_jumps"]) == 7
    reference = evaluate_cli.main(
        ["--run", str(small_run), "--targets", str(targets), "--no-plots",
         "--out", str(tmp_path / "e")]
    )  # fmt: skip
    (row,) = reference["controllers"]
    assert summary["evaluation"]["mean_mm"] == row["mean_mm"]  # the same targets and moves
