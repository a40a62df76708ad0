"""The report of a held-out evaluation (``envs.harness.evaluation``): a map's name in it, the
reach table (mean error after every move, median and 95th percentile after the last, the
complete trials), the grasp task's table (position and orientation after every move) and the
figures of a map's evaluation. ``scripts/evaluate.py`` prints and writes them.
"""

from __future__ import annotations

from pathlib import Path

from envs.harness import plots
from envs.harness.evaluation import Evaluation
from envs.harness.training import Trainer
from envs.sensing.rendering import render_camera
from learners.som.controller import VisuomotorSOM

CELL = 13  # characters of a number's column in the grasp tables


def som_name(som: VisuomotorSOM) -> str:
    """A map's name in the table: its protocol and, for MRS, its fine-move options."""
    name = f"som {som.protocol}"
    if som.protocol == "mrs":
        name += "+fit" * (som.abar == "local-fit") + "+refine" * som.refine
        name += "+recover" * som.recover
    return name


def format_table(rows: list[dict]) -> str:
    """Mean error after each move, then median and 95th percentile after the last, all over
    every trial (a trial that stopped counts where it stopped), and the complete trials."""
    moves = len(rows[0]["mean_mm"])
    names = ["coarse"] + [f"fine {k}" for k in range(1, moves)]
    width = max(len("controller"), *(len(r["controller"]) for r in rows)) + 2
    head = f"{'controller':<{width}}" + "".join(f"{n + ' [mm]':>13}" for n in names)
    head += f"{'median':>8}{'p95':>8}{'% reach':>9}{'px':>7}{'us/query':>10}{'complete':>10}"
    lines = [head, "-" * len(head)]
    for r in rows:
        line = f"{r['controller']:<{width}}" + "".join(f"{e:>13.3f}" for e in r["mean_mm"])
        line += f"{r['median_mm'][-1]:>8.3f}{r['p95_mm'][-1]:>8.3f}"
        line += f"{r['mean_percent_reach'][-1]:>9.4f}{r['mean_px'][-1]:>7.3f}"
        line += f"{r['microseconds_per_query']:>10.1f}{r['complete_fraction'] * 100:>9.1f}%"
        lines.append(line)
    lines.append(
        f"[mm]: mean error after each move; median, p95 (mm), % reach, px: after {names[-1]}"
    )
    for r in rows:
        if "recovered_trials" in r:
            lines.append(
                f"{r['controller']}: {r['recovered_trials']} trials recovered from an unseen "
                f"marker, {r['mean_recovery_moves']:.4f} extra moves per trial"
            )
    lines.append("all trials counted; a trial stopped by an unseen marker keeps its last error")
    return "\n".join(lines)


def format_pose_table(rows: list[dict]) -> str:
    """The grasp task's tables, one line per controller and move, over every trial, in two
    blocks that fit a terminal: the position error (mean in mm and % of reach, median, largest),
    then the orientation error (mean, median, largest, in degrees) with the share of trials over
    1 mm or 1°; then each controller's complete trials."""
    width = max(len("controller"), *(len(r["controller"]) for r in rows)) + 2
    blocks = (
        ("position error", ("mean [mm]", "% reach", "median [mm]", "max [mm]"),
         lambda r, k: (f"{r['mean_mm'][k]:.3f}", f"{r['mean_percent_reach'][k]:.4f}",
                       f"{r['median_mm'][k]:.3f}", f"{r['max_mm'][k]:.2f}")),
        ("orientation error", ("mean [deg]", "median [deg]", "max [deg]", ">1mm|1deg"),
         lambda r, k: (f"{r['mean_deg'][k]:.3f}", f"{r['median_deg'][k]:.3f}",
                       f"{r['max_deg'][k]:.2f}", f"{100 * r['tail_fraction'][k]:.2f}%")),
    )  # fmt: skip
    lines = []
    for title, names, cells in blocks:
        head = f"{'controller':<{width}}{'move':<8}" + "".join(f"{n:>{CELL}}" for n in names)
        lines += [title, head, "-" * len(head)]
        for r in rows:
            for k in range(len(r["mean_mm"])):
                move = "coarse" if k == 0 else f"fine {k}"
                name = r["controller"] if k == 0 else ""
                values = "".join(f"{c:>{CELL}}" for c in cells(r, k))
                lines.append(f"{name:<{width}}{move:<8}{values}")
        lines.append("")
    for r in rows:
        lines.append(f"{r['controller']}: {r['complete_fraction'] * 100:.1f}% complete trials")
    lines.append("all trials counted; a trial stopped by an unseen marker keeps its last error")
    return "\n".join(lines)


def write_plots(
    env,
    som: VisuomotorSOM,
    result: Evaluation,
    metrics: list[dict] | None,
    run: Path | None,
    out: Path,
) -> None:
    """The evaluation's figures into ``out``; the learning curve of the training run ``run``
    (its ``metrics`` rows: its own held-out evaluations, in the training's settings) into the
    run folder."""
    base = env.unwrapped
    name = type(som).__name__
    if metrics is not None and run is not None:
        trained = Trainer.stored_config(run)
        during = plots.subject(base.robot, trained.sensing, trained.control, name)
        plots.learning_curve(metrics, base.reach, run / "learning_curve.png", subject=during)
    subject = plots.subject(base.robot, base.sensing, base.control, name)
    plots.error_histogram(result, out / "error_histogram.png", subject=subject)
    image = render_camera(base.model, base.data, "cam_left", base.stereo.height, base.stereo.width)
    plots.lattice_in_image(
        som.w, som.lattice, image, out / "lattice_left_camera.png", subject=subject
    )
    plots.error_vectors(result, out / "error_vectors.png", subject=subject)
    plots.error_map(result, out / "error_map_coarse.png", move=0, subject=subject)
    plots.error_map(result, out / "error_map_final.png", move=result.moves - 1, subject=subject)
