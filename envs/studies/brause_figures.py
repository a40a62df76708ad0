"""The figures of the Brause reproduction (:mod:`envs.studies.brause_reproduction`): Figs. 5f-5i
along the path and at the point P, Figs. 6.2 and B.1 of the optimal storage resolution."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.plots import save_figure
from models.analyses import brause_linear_error as B
from models.analyses import brause_optimal_resolution as RES

PLOT_N = (10, 100, 1000)  #: curves drawn in Figs. 5g, 5h (his choice)

#: The error figures along the path: (key of the study, unit, scale from SI, file, title).
PATH_ERRORS = (
    ("joint_max", "rad", 1.0, "fig5g_joint_error.png", "Fig. 5g: maximal joint error e^LA"),
    ("cart", "mm", 1e3, "fig5h_cartesian_error.png", "Fig. 5h: maximal Cartesian error"),
)
DPI = 120


def plot_path(study: dict, out: Path) -> None:
    """Write Figs. 5f, 5g and 5h of the path study into the folder ``out``."""
    save_figure(joints_figure(study), out / "fig5f_joints.png", DPI, bbox_inches=None)
    for key, unit, scale, name, title in PATH_ERRORS:
        figure = path_error_figure(study, key, unit, scale, title)
        save_figure(figure, out / name, DPI, bbox_inches=None)


def joints_figure(study: dict) -> Figure:
    """Fig. 5f: the exact joint angles θ1..θ3 (deg) against the path position s, one line each."""
    s = study["s"]
    fig, ax = plt.subplots(figsize=(6, 4))
    for i in range(3):
        ax.plot(s, np.degrees(study["theta"][:, i]), label=f"θ{i + 1}")
    ax.set(
        xlabel="path position s",
        ylabel="joint angle t_i(x) (deg)",
        title="Fig. 5f: exact joint angles along the path (right-above)",
    )
    ax.legend()
    fig.tight_layout()
    return fig


def path_error_figure(study: dict, key: str, unit: str, scale: float, title: str) -> Figure:
    """Figs. 5g, 5h: the error ``study[key]`` (times ``scale``, in ``unit``) along the path, one
    line per n of :data:`PLOT_N`, and the point P as a vertical line."""
    s, n = study["s"], study["n"]
    fig, ax = plt.subplots(figsize=(6, 4))
    for value in PLOT_N:
        i = int(np.flatnonzero(n == value)[0])
        ax.semilogy(s, study[key][i] * scale, label=f"n = {value}")
    ax.axvline(s[study["P"]], color="grey", ls=":", label="P")
    ax.set(xlabel="path position s", ylabel=f"error ({unit})", title=title)
    ax.legend()
    fig.tight_layout()
    return fig


def plot_fit(study: dict, som: list[dict], out: Path) -> None:
    """Write Fig. 5i into the folder ``out``."""
    save_figure(fit_figure(study, som), out / "fig5i_fit.png", DPI, bbox_inches=None)


def fit_figure(study: dict, som: list[dict]) -> Figure:
    """Fig. 5i: e^LA at P against n (exact, path maximum, the fit, Brause's fit and the learned
    maps' errors per protocol) and, right, the approximation resolution (5.9)."""
    n, P = study["n"], study["P"]
    e = study["joint_max"][:, P]
    fit = study["fits"]["joint [rad]"]
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    ax.loglog(n, e, "o", label="exact IK + tangent A, at P")
    ax.loglog(
        n,
        np.nanmax(study["joint_max"], axis=1),
        "s",
        mfc="none",
        label="same, maximum along the path",
    )
    ax.loglog(
        n, fit["C"] * n ** fit["b"], "-", label=f"fit: b = {fit['b']:.3f}, C = {fit['C']:.3g}"
    )
    ax.loglog(n, B.PAPER_C * n**B.PAPER_B, "--", label=f"Brause: b = {B.PAPER_B}, C = {B.PAPER_C}")
    for protocol in sorted({r["protocol"] for r in som}):
        rows = [r for r in som if r["protocol"] == protocol]
        ne = np.array([r["n_equivalent"] for r in rows])
        for key, marker, what in (
            ("joint_max_path", "^-", "max"),
            ("joint_median_path", "v-", "median"),
        ):
            label = f"learned SOM ({protocol} protocol), {what} on path"
            ax.loglog(ne, [r[key] for r in rows], marker, label=label)
    ax.set(
        xlabel="neurons per dimension n",
        ylabel="joint error e^LA (rad)",
        title="Fig. 5i: e^LA at P",
    )
    ax.legend(fontsize=7)
    ax2.semilogx(n, B.resolution_bits(e), "o-")
    ax2.set(
        xlabel="neurons per dimension n",
        ylabel="r_n (bits)",
        title="Fig. 5i right: approximation resolution (5.9)",
    )
    fig.tight_layout()
    return fig


_ADJUST = {"left": 0.07, "right": 0.98, "bottom": 0.12, "top": 0.92, "wspace": 0.25}


def plot_resolution(res: dict, out: Path) -> None:
    """Write Figs. 6.2 and B.1 of the resolution study into the folder ``out``."""
    storage = out / "fig6_2_storage_error.png"
    save_figure(storage_error_figure(res), storage, DPI, bbox_inches=None)
    optimal = out / "figB_1_optimal_resolution.png"
    save_figure(optimal_resolution_figure(res), optimal, DPI, bbox_inches=None)


def _styles(res: dict) -> dict[str, str]:
    """A line style per error model of the resolution study."""
    return dict(zip([k for k in res if k != "published"], ("-", "--", ":"), strict=True))


def storage_error_figure(res: dict) -> Figure:
    """Fig. 6.2: joint error e^MAX (a) and Cartesian error (b) against storage, optimal and
    equal resolutions per error model, and Brause's published point."""
    styles = _styles(res)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for name, ls in styles.items():
        curve = res[name]["curve"]
        mb = np.array([c["storage_MB"] for c in curve]) * 1e6
        for ax, key, scale in ((axes[0], "e_max", 1.0), (axes[1], "cartesian", 1.0)):
            opt = [c[f"{key}_rad" if key == "e_max" else f"{key}_mm"] for c in curve]
            eq = [c[f"{key}_equal_rad" if key == "e_max" else f"{key}_equal_mm"] for c in curve]
            ax.loglog(mb, np.array(opt) * scale, ls, color="C0", label=f"optimal, {name}")
            ax.loglog(mb, np.array(eq) * scale, ls, color="C3", label=f"equal r, {name}")
    p = RES.PUBLISHED
    axes[1].loglog(
        [p["storage_bytes"]] * 2,
        [p["e_opt_mm"], p["e_equal_mm"]],
        "k*",
        ms=10,
        label="Brause: 0.164 / 0.201 mm at 1.9 MB",
    )
    axes[0].set(xlabel="storage (bytes)", ylabel="e^MAX (rad)", title="Fig. 6.2a: joint error")
    axes[1].set(
        xlabel="storage (bytes)",
        ylabel="Cartesian error (mm, at our P)",
        title="Fig. 6.2b: Cartesian error",
    )
    axes[0].legend(fontsize=6)
    axes[1].legend(fontsize=6)
    fig.subplots_adjust(**_ADJUST)  # tight_layout takes seconds on 16-decade log axes
    return fig


def optimal_resolution_figure(res: dict) -> Figure:
    """Fig. B.1: the optimal resolutions r_w, r_θ, r_A (a) and neurons per dimension n (b)
    against storage per error model, and Brause's published point."""
    styles, p = _styles(res), RES.PUBLISHED
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for name, ls in styles.items():
        curve = res[name]["curve"]
        mb = np.array([c["storage_MB"] for c in curve]) * 1e6
        for key, color in (("r_w", "C0"), ("r_theta", "C1"), ("r_A", "C2")):
            ax.semilogx(mb, [c[key] for c in curve], ls, color=color, label=f"{key}, {name}")
        ax2.loglog(mb, [c["n"] for c in curve], ls, color="C4", label=f"n, {name}")
    ax.plot([p["storage_bytes"]] * 3, [p["r_w"], p["r_theta"], p["r_A"]], "k*", ms=9)
    ax2.plot([p["storage_bytes"]], [p["n"]], "k*", ms=9, label="Brause: n = 39.6 at 1.9 MB")
    ax.set(xlabel="storage (bytes)", ylabel="bits", title="Fig. B.1a: optimal resolutions")
    ax2.set(xlabel="storage (bytes)", ylabel="n", title="Fig. B.1b: optimal neurons per dimension")
    ax.legend(fontsize=6)
    ax2.legend(fontsize=6)
    fig.subplots_adjust(**_ADJUST)  # tight_layout takes seconds on 16-decade log axes
    return fig
