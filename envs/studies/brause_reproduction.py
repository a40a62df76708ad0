"""Reproduce Brause (1989) §5-6 and appendix B for the PUMA 560: storage table 6a, the
linear-approximation error e^LA along a straight path (Figs. 5f-5i, fit 5.7-5.8) and over the
whole reachable workspace (slope scan), the optimal storage resolution (§6.2, appendix B, Figs.
6.2 and B.1), and e^LA of learned Kohonen maps, trained with Brause's own protocol and with the
MRS loop.

:func:`reproduce` runs it all (``scripts/reproduce_brause.py`` is its command line); the
figures are drawn by :mod:`envs.studies.brause_figures`. The definitions and the readings of
garbled equations are in ``models/analyses/brause_linear_error.py`` and
``models/analyses/brause_optimal_resolution.py``; docs/reproducing.md reads the results.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from envs.studies import brause_figures as figures
from learners.persistence import write_atomic
from models.analyses import brause_linear_error as B
from models.analyses import brause_optimal_resolution as RES
from models.puma560 import DH, WORKSPACE_BASE_LOWER, WORKSPACE_BASE_UPPER

TABLE_N = (10, 50, 100, 1000)
SOM_LATTICES = (3, 4, 6, 8)
SOM_TRIALS_PER_NEURON = 40
SOM_MIN_TRIALS = 5000
UNITS = {"rad": 1.0, "deg": 180 / np.pi, "m": 1.0, "mm": 1e3, "1e-2 mm": 1e5}


def storage_rows() -> list[dict]:
    ours = B.storage(np.array(TABLE_N), B.SE_PER_NEURON_BRAUSE)
    camera = B.storage(np.array(TABLE_N), B.camera_map_numbers_per_neuron())
    rows = []
    for i, n in enumerate(TABLE_N):
        rows.append(
            {
                "n": n,
                "neurons": float(ours["neurons"][i]),
                "elements": float(ours["elements"][i]),
                "bytes_10bit": float(ours["bytes_10bit"][i]),
                "bytes_12bit": float(ours["bytes_12bit"][i]),
                "paper": dict(
                    zip(
                        ("elements", "bytes_10bit", "bytes_12bit"), B.PAPER_TABLE_6A[n], strict=True
                    )
                ),
                "camera_map": {
                    k: float(camera[k][i]) for k in ("elements", "bytes_10bit", "bytes_12bit")
                },
            }
        )
    return rows


def print_storage(rows: list[dict]) -> None:
    print(
        "Table 6a: storage (15 SE per neuron; paper in brackets) | camera-input map "
        f"({B.camera_map_numbers_per_neuron()} SE per neuron)"
    )
    print(
        f"{'n':>5} {'SE':>20} {'3SE=4B':>20} {'2SE=4B':>20} | {'SE':>9} {'3SE=4B':>9} {'2SE=4B':>9}"
    )
    for r in rows:
        p, c = r["paper"], r["camera_map"]
        cells = [f"{r[k]:.3g} [{p[k]:.3g}]" for k in ("elements", "bytes_10bit", "bytes_12bit")]
        cam = [f"{c[k]:.3g}" for k in ("elements", "bytes_10bit", "bytes_12bit")]
        print(
            f"{r['n']:>5} {cells[0]:>20} {cells[1]:>20} {cells[2]:>20} | "
            f"{cam[0]:>9} {cam[1]:>9} {cam[2]:>9}"
        )


def path_study(points: int, edge: float, dx: float) -> dict:
    """Brause's e^LA along the straight path of ``points`` samples, for a workspace of edge
    ``edge`` (m) cut into n³ cells and A_c by central differences of step ``dx`` (m): the
    errors, the point P, the power-law fits and the figures of A along the path."""
    s, w = B.path(B.PATH_START, B.PATH_END, points)
    n_values = np.array(B.N_VALUES)
    joint, cart = zip(*(B.border_errors(w, edge / n, dx) for n in n_values), strict=True)
    joint = np.array(joint)  # (n, M, 3) rad
    cart = np.array(cart)  # (n, M) m
    joint_max = np.max(joint, axis=-1)  # (n, M)
    ref = int(np.flatnonzero(n_values == 100)[0])
    P = B.first_local_maximum(joint_max[ref])
    b, C = B.fit_power_law(n_values, joint_max[:, P])
    b_cart, C_cart = B.fit_power_law(n_values, cart[:, P])
    A_path = B.central_difference(w, dx)  # (M, 3, 3) rad/m
    valid = np.all(np.isfinite(joint_max), axis=0)
    slopes = np.polyfit(np.log10(n_values), np.log10(joint_max[:, valid]), 1)[0]
    fits = {f"joint [{u}]": {"b": b, "C": C * UNITS[u]} for u in ("rad", "deg")} | {
        f"cartesian [{u}]": {"b": b_cart, "C": C_cart * UNITS[u]} for u in ("m", "mm", "1e-2 mm")
    }
    return {
        "s": s,
        "w": w,
        "n": n_values,
        "joint": joint,
        "joint_max": joint_max,
        "cart": cart,
        "P": P,
        "fits": fits,
        "A_P": A_path[P],
        "theta": B.exact_joints(w)[0],
        "V_A": float(A_path.max() - A_path.min()),
        "S_A": float(np.max(np.abs(A_path[P].sum(axis=1)))),  # his max_i Σ_j A_ij, magnitude
        "S_A_abs": float(np.max(np.abs(A_path[P]).sum(axis=1))),  # max_i Σ_j |A_ij|
        "b_range": (float(slopes.min()), float(slopes.max())),
    }


def print_fits(study: dict) -> None:
    P = study["P"]
    print(
        f"\nPoint P: s = {study['s'][P]:.4f} of the path, w = {np.round(study['w'][P], 4)} m "
        "(frame 0)"
    )
    print(
        f"A_c at P (rad/m): row sums {np.round(study['A_P'].sum(axis=1), 3)}; "
        f"Brause: S_A = 1e-5 rad per 1e-2 mm = 1 rad/m"
    )
    print(
        f"{'fit lg e = a + b lg n at P':<28} {'b':>10} {'C':>12}   paper: b = {B.PAPER_B}, "
        f"C = {B.PAPER_C}"
    )
    for name, f in study["fits"].items():
        print(f"{name:<28} {f['b']:>10.5f} {f['C']:>12.5g}")


def notes(study: dict, scan: dict) -> list[str]:
    """Where our b, C, S_A and V_A differ from Brause's, with the numbers of this run."""
    rad, deg = study["fits"]["joint [rad]"], study["fits"]["joint [deg]"]
    lo, hi = study["b_range"]
    return [
        f"Units: his e^LA is a joint error in radians. Our C is {rad['C']:.3g} rad "
        f"({deg['C']:.3g} in degrees; his 2.01). His A figures are per 1e-2 mm: S_A = 1e-5 is "
        f"1 rad/m, V_A = 2e-4 is 20 rad/m. Ours: S_A = max_i |Σ_j A_ij| = {study['S_A']:.2f} rad/m "
        f"at our P (max_i Σ_j |A_ij| = {study['S_A_abs']:.2f}), V_A = {study['V_A']:.3g} rad/m "
        "along our path: the same order of magnitude, not the same values (our P and path are "
        "not his).",
        f"Slope: b = {rad['b']:.4f} at our P, between {lo:.3f} and {hi:.3f} at every point of our "
        f"path whose cells are reachable for all n, and between {scan['b_min']:.3f} and "
        f"{scan['b_max']:.3f} over {scan['points']} reachable grid points of the whole workspace "
        f"({scan['spacing_m'] * 1e3:.0f} mm grid, n = 10...1000). b = -2.66 is not reproduced "
        "anywhere. A tangent-plane approximation errs by 1/2 h^T (d2t) h + O(h^3) with h ~ 1/n, "
        "so b -> -2 wherever t is smooth. Hypotheses for his -2.66, none testable without his "
        "P and program: an A_c that is not the tangent (e.g. a one-sided or coarse difference "
        "in 5.4), a fit over a different range of n, border points other than corners and face "
        "centres, or a P outside the joint ranges used here.",
        f"C: ours {rad['C']:.3g} rad against his 2.01 depends on where P lies (the curvature of t "
        "there) and on b: with his steeper slope, errors of the same size at n ~ 10 extrapolate "
        "to a larger C at n = 1.",
    ]


def slope_scan(spacing: float) -> dict:
    points, b, _ = B.slope_scan(spacing)
    return {
        "spacing_m": spacing,
        "n": list(B.SCAN_N),
        "points": len(points),
        "b_min": float(b.min()),
        "b_max": float(b.max()),
        "b_percentiles_1_50_99": np.percentile(b, [1, 50, 99]).tolist(),
        "point_of_min_b_m": points[np.argmin(b)].tolist(),
    }


#: r_w (bits) along which Figs. 6.2 and B.1 are drawn (the paper plots against s(r_w)).
R_W_GRID = np.arange(6.0, 44.01, 0.25)
#: Storage (bytes) of the paper's two comparisons.
PAPER_BYTES = (RES.PUBLISHED["storage_bytes"], RES.PUBLISHED["big_storage_bytes"])


def error_models(study: dict) -> dict[str, tuple[RES.ErrorModel, str]]:
    """The three curves: his (b, C, V_A, S_A) read as he computed and as derived, and ours."""
    fit = study["fits"]["joint [rad]"]
    ours = RES.ErrorModel(b=fit["b"], C=fit["C"], V_A=study["V_A"], S_A=study["S_A"])
    paper = RES.ErrorModel()
    return {
        "paper (b, C), g as published": (paper, "published"),
        "paper (b, C), g derived": (paper, "derived"),
        "ours (b, C, V_A, S_A), g derived": (ours, "derived"),
    }


def config_row(model: RES.ErrorModel, c: RES.Config, theta_p: np.ndarray) -> dict:
    e = float(model.e_joint(c.n, c.r_w, c.r_theta, c.r_A))
    q = c.equal()
    e_eq = float(model.e_joint(q.n, q.r_w, q.r_theta, q.r_A))
    return {
        "n": c.n,
        "r_w": c.r_w,
        "r_theta": c.r_theta,
        "r_A": c.r_A,
        "r_equal": q.r_w,
        "storage_MB": c.bits / RES.BITS_PER_BYTE / 1e6,
        "e_max_rad": float(np.sqrt(3) * e),
        "e_max_equal_rad": float(np.sqrt(3) * e_eq),
        "cartesian_mm": float(RES.cartesian_error(theta_p, e)) * 1e3,
        "cartesian_equal_mm": float(RES.cartesian_error(theta_p, e_eq)) * 1e3,
        "ratio_opt_to_equal": e / e_eq,
    }


def resolution_study(study: dict) -> dict:
    """Appendix B for each error model: the optimum at r_w = 17 (his point) and at his two
    storages, the brute-force check, and the curves of Figs. 6.2 and B.1."""
    theta_p = study["theta"][study["P"]]
    out = {}
    for name, (model, reading) in error_models(study).items():
        curve = [RES.optimum(model, r, reading) for r in R_W_GRID]
        at = {f"{b:.3g} B": RES.optimum_for_storage(model, b * 8, reading) for b in PAPER_BYTES}
        c19 = at[f"{PAPER_BYTES[0]:.3g} B"]
        brute = RES.grid_minimum(model, c19.bits, c19)
        out[name] = {
            "model": vars(model) | {"reading": reading},
            "at_r_w_17": config_row(model, RES.optimum(model, 17.0, reading), theta_p),
            **{f"at {k}": config_row(model, c, theta_p) for k, c in at.items()},
            "brute_force_at_1.9MB": config_row(model, brute, theta_p),
            "curve": [config_row(model, c, theta_p) for c in curve],
        }
    out["published"] = RES.PUBLISHED
    return out


def print_resolution(res: dict) -> None:
    p = RES.PUBLISHED
    print("\n§6.2 / appendix B: optimal storage resolution (e^MAX per (B.1); Cartesian at our P)")
    head = (
        f"{'model, where':<48}{'n':>7}{'r_w':>7}{'r_θ':>7}{'r_A':>7}{'r=':>7}{'MB':>7}"
        f"{'e^MAX rad':>11}{'opt mm':>8}{'equal mm':>9}{'opt/eq':>8}"
    )
    print(head + "\n" + "-" * len(head))
    print(
        f"{'Brause (printed in §6.2)':<48}{p['n']:>7}{p['r_w']:>7}{p['r_theta']:>7}{p['r_A']:>7}"
        f"{p['r_equal']:>7}{p['storage_bytes'] / 1e6:>7}{'':>11}{p['e_opt_mm']:>8}"
        f"{p['e_equal_mm']:>9}{p['e_opt_mm'] / p['e_equal_mm']:>8.3f}"
    )
    for name, r in res.items():
        if name == "published":
            continue
        for where in ("at_r_w_17", "at 1.9e+06 B", "brute_force_at_1.9MB"):
            c = r[where]
            print(
                f"{name + ', ' + where:<48.48}{c['n']:>7.2f}{c['r_w']:>7.2f}{c['r_theta']:>7.2f}"
                f"{c['r_A']:>7.2f}{c['r_equal']:>7.2f}{c['storage_MB']:>7.3f}"
                f"{c['e_max_rad']:>11.4g}{c['cartesian_mm']:>8.3f}{c['cartesian_equal_mm']:>9.3f}"
                f"{c['ratio_opt_to_equal']:>8.3f}"
            )
        if r["model"]["reading"] == "published":
            c = r["at_r_w_17"]
            print(
                f"{'':<4}Cartesian per rad of e^MAX: at our P "
                f"{c['cartesian_mm'] / c['e_max_rad']:.0f} mm/rad; at his P (0.201 mm at his "
                f"equal-r point) {p['e_equal_mm'] / c['e_max_equal_rad']:.0f} mm/rad"
            )
        big = r["at 1.13e+14 B"]
        print(
            f"{'':<4}at 1.13e14 bytes: equal-resolution error / optimal = "
            f"{1 / big['ratio_opt_to_equal']:.2f} (Brause: {p['big_ratio']})"
        )


#: The learned maps: Brause's protocol as published, and MRS with this project's additions
#: (Gaussian RITT3 neighbourhood, averaged coarse move, schedules with floors, exploration).
SOM_VARIANTS = ({"protocol": "brause"}, {"protocol": "mrs", "rule": "mrs"})


def som_study(lattices: list[int], edge: float, seed: int, w: np.ndarray) -> list[dict]:
    """Train 3-D-input maps on the wrist centre (kinematic) with both protocols and measure
    (3.7) of the winner, Θ_c + A_c (x − w_c), along the path: e^LA of a learned map."""
    from learners.som.controller import VisuomotorSOM

    lower, upper = WORKSPACE_BASE_LOWER, WORKSPACE_BASE_UPPER
    theta_init = B.exact_joints(((lower + upper) / 2)[None])[0][0]
    box_edge = float(np.prod(upper - lower) ** (1 / 3))  # edge of the cube of equal volume
    rows = []
    for variant in SOM_VARIANTS:
        for n in lattices:
            trials = max(SOM_MIN_TRIALS, SOM_TRIALS_PER_NEURON * n**3)
            som = VisuomotorSOM(
                DH.lower[:3],
                DH.upper[:3],
                lattice=(n, n, n),
                input_dim=3,
                t_max=trials,
                rng=seed,
                input_low=lower,
                input_high=upper,
                theta_init=theta_init,
                min_dv=1e-7,
                **variant,
            )
            accepted = B.train_cartesian(som, trials, np.random.default_rng(seed + 1))
            joint, cart = B.map_errors(B.linear_map(som.w, som.theta, som.A, w), w)
            rows.append(
                {
                    "protocol": som.protocol,
                    "rule": som.rule if som.protocol == "mrs" else "(3.9)/(3.10)",
                    "lattice": n,
                    "trials": trials,
                    "accepted": accepted,
                    "n_equivalent": n * edge / box_edge,
                    "joint_max_path": float(np.nanmax(joint)),
                    "joint_median_path": float(np.nanmedian(joint.max(axis=1))),
                    "cart_max_path_m": float(np.nanmax(cart)),
                    "cart_median_path_m": float(np.nanmedian(cart)),
                }
            )
            r = rows[-1]
            print(
                f"SOM {n}×{n}×{n}, protocol {r['protocol']}, rule {r['rule']}: {trials} trials, "
                f"n_equivalent {r['n_equivalent']:.1f}, (3.7) joint error max "
                f"{r['joint_max_path']:.4g} rad, median {r['joint_median_path']:.4g} rad; "
                f"Cartesian max {1e3 * r['cart_max_path_m']:.3g} mm, median "
                f"{1e3 * r['cart_median_path_m']:.3g} mm"
            )
    return rows


def reproduce(
    out: Path,
    points: int = 401,
    edge: float = B.BRAUSE_EDGE,
    dx: float = B.DX,
    scan_spacing: float = B.SCAN_SPACING,
    lattices: tuple[int, ...] = SOM_LATTICES,
    seed: int = 0,
    som: bool = True,
) -> dict:
    """The whole reproduction: print its tables, write its figures and ``brause.json`` into
    ``out`` and return what the JSON holds (``som=False`` leaves out the learned maps)."""
    out.mkdir(parents=True, exist_ok=True)
    rows = storage_rows()
    print_storage(rows)
    study = path_study(points, edge, dx)
    print_fits(study)
    figures.plot_path(study, out)
    scan = slope_scan(scan_spacing)
    explanation = notes(study, scan)
    print("\nNotes:\n- " + "\n- ".join(explanation))
    res = resolution_study(study)
    print_resolution(res)
    figures.plot_resolution(res, out)
    maps = som_study(list(lattices), edge, seed, study["w"]) if som else []
    figures.plot_fit(study, maps, out)
    P = study["P"]
    result = {
        "table_6a": rows,
        "path": {
            "start_m": B.PATH_START.tolist(),
            "end_m": B.PATH_END.tolist(),
            "points": points,
            "edge_m": edge,
            "dx_m": dx,
        },
        "P": {
            "index": P,
            "s": float(study["s"][P]),
            "w_m": study["w"][P].tolist(),
            "A_rad_per_m": study["A_P"].tolist(),
        },
        "n": study["n"].tolist(),
        "joint_error_at_P_rad": study["joint_max"][:, P].tolist(),
        "cartesian_error_at_P_m": study["cart"][:, P].tolist(),
        "joint_error_max_on_path_rad": np.nanmax(study["joint_max"], axis=1).tolist(),
        "resolution_bits_at_P": B.resolution_bits(study["joint_max"][:, P]).tolist(),
        "fits": study["fits"],
        "paper": {"b": B.PAPER_B, "C": B.PAPER_C},
        "V_A_rad_per_m": study["V_A"],
        "S_A_rad_per_m": study["S_A"],
        "b_range_on_path": list(study["b_range"]),
        "slope_scan": scan,
        "appendix_B": res,
        "notes": explanation,
        "som": maps,
    }
    text = json.dumps(result, indent=2).encode()
    write_atomic(out / "brause.json", lambda f: f.write(text))
    print(f"\nwrote {out}/brause.json and figures")
    return result
