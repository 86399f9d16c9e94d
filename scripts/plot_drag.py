#!/usr/bin/env python3
"""Figures and table of the drag paper from `talus drag` outputs.

usage: python3 scripts/plot_drag.py OUT_DIR [OUT_DIR ...] [--out PNG_DIR]

Each OUT_DIR (e.g. out/drag/c1) holds summary.json, drag_vs_displacement.csv and
snapshots.csv. Writes, per case into its folder: <case>_drag.png (mean drag
against displacement with a +-1 std band, the averaging window shaded: Fig. 7),
<case>_snapshots_layers.png and <case>_snapshots_cluster.png (Figs. 9-12); and
into --out (default: the parent of the first OUT_DIR): drag_compare.png (Fig. 13),
drag_ellipse_vs_disc.png (e0 against c1, Fig. 8, when both are given),
drag_density.png (pairs differing only by density: Fig. 14) and drag_table.md.
"""
import argparse
import csv
import json
import sys
import tomllib
from pathlib import Path

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, Ellipse  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def load(d):
    d = Path(d)
    if not (d / "summary.json").exists():
        sys.exit(f"error: {d} has no summary.json (run `talus drag` first)")
    s = json.loads((d / "summary.json").read_text())
    if not (d / "drag_vs_displacement.csv").exists():
        sys.exit(f"error: {d} has no drag_vs_displacement.csv")
    a = np.loadtxt(d / "drag_vs_displacement.csv", delimiter=",", skiprows=1, ndmin=2)
    toml = ROOT / "cases" / "drag" / f"{s['case']}.toml"
    if not toml.exists():
        sys.exit(f"error: no case file {toml} for {d}")
    case = tomllib.loads(toml.read_text())
    snaps = list(csv.DictReader(open(d / "snapshots.csv"))) if (d / "snapshots.csv").exists() else []
    return d, s, a, case, snaps


def drag_plot(d, s, a):
    fig, ax = plt.subplots(figsize=(6, 4))
    x, m, sd = a[:, 0] * 1e3, a[:, 1], a[:, 2]
    ax.plot(x, m, lw=1, label=f"{s['case']}: mean of {s['beds']} beds")
    ax.fill_between(x, m - sd, m + sd, alpha=0.3, label="+-1 std")
    lo, hi = (v * 1e3 for v in s["average_window_m"])
    ax.axvspan(lo, hi, color="grey", alpha=0.1)
    ax.hlines(s["mean_drag_n"], lo, hi, colors="k", linestyles="--", label=f"mean {s['mean_drag_n']:.0f} N")
    ax.set_xlabel("displacement (mm)")
    ax.set_ylabel("drag (N)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(d / f"{s['case']}_drag.png", dpi=120)
    plt.close(fig)


def snapshots(d, s, snaps):
    if not snaps:
        return
    disp = sorted({float(r["displacement_m"]) for r in snaps})
    # one container for all panels: x = 0..max, y = 0..max over every snapshot
    xmax = max(float(r["x_m"]) + float(r["radius_m"]) for r in snaps)
    ymax = max(float(r["y_m"]) + float(r["radius_m"]) for r in snaps)
    h = 4 * ymax / xmax + 1  # panel height follows the container's shape
    for mode in ("layers", "cluster"):
        fig, axes = plt.subplots(1, len(disp), figsize=(4 * len(disp), h))
        for ax, dd in zip(np.atleast_1d(axes), disp):
            rows = [r for r in snaps if float(r["displacement_m"]) == dd]
            for r in rows:
                if mode == "layers":
                    c = "tab:blue" if int(r["layer"]) % 2 == 0 else "tab:orange"
                else:
                    c = "tab:red" if r["cluster"] == "1" else "0.75"
                xy = (float(r["x_m"]) * 1e3, float(r["y_m"]) * 1e3)
                a = float(r["radius_m"]) * 1e3
                b = float(r.get("minor_m") or r["radius_m"]) * 1e3
                if b < a:  # an ellipse: semi-axes a, b, major axis at angle_rad
                    ax.add_patch(Ellipse(xy, 2 * a, 2 * b, angle=np.degrees(float(r["angle_rad"])), fc=c, ec="k", lw=0.2))
                else:
                    ax.add_patch(Circle(xy, a, fc=c, ec="k", lw=0.2))
            r0 = rows[0]
            ax.add_patch(Circle((float(r0["cylinder_x_m"]) * 1e3, float(r0["cylinder_y_m"]) * 1e3), float(r0["cylinder_radius_m"]) * 1e3, fc="k"))
            ax.set_xlim(0, xmax * 1e3)
            ax.set_ylim(0, ymax * 1e3)
            ax.set_aspect("equal")
            ax.set_xlabel("x (mm)")
            ax.set_ylabel("y (mm)")
            ax.set_title(f"{s['case']}: s = {dd * 1e3:.1f} mm")
        fig.tight_layout()
        fig.savefig(d / f"{s['case']}_snapshots_{mode}.png", dpi=110)
        plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--out")
    a = ap.parse_args()
    runs = [load(d) for d in a.dirs]
    out = Path(a.out) if a.out else Path(a.dirs[0]).resolve().parent
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 4))
    rows = []
    for d, s, arr, case, snaps in runs:
        drag_plot(d, s, arr)
        snapshots(d, s, snaps)
        ax.plot(arr[:, 0] * 1e3, arr[:, 1], lw=1, label=s["case"])
        c, m = case["drag"], case["material"]
        rows.append((s["case"], c["shape"], c.get("aspect_ratio", 1.0), c["granule_size"] * 1e6, m["density"],
                     s["mean_drag_n"], s["std_drag_n"], s["beds"]))
    ax.set_xlabel("displacement (mm)")
    ax.set_ylabel("mean drag (N)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "drag_compare.png", dpi=120)
    plt.close(fig)
    # Fig. 8: the ellipse code at aspect ratio 1 (e0) against the disc code (c1)
    by_case = {s["case"]: (s, arr) for _, s, arr, _, _ in runs}
    if "e0" in by_case and "c1" in by_case:
        fig, ax = plt.subplots(figsize=(6, 4))
        for k, lab in (("c1", "disc code (c1)"), ("e0", "ellipse code, aspect ratio 1 (e0)")):
            s, arr = by_case[k]
            x = arr[:, 0] * 1e3
            ax.plot(x, arr[:, 1], lw=1, label=f"{lab}: {s['mean_drag_n']:.0f} +- {s['std_drag_n']:.0f} N")
            ax.fill_between(x, arr[:, 1] - arr[:, 2], arr[:, 1] + arr[:, 2], alpha=0.2)
        ax.set_xlabel("displacement (mm)")
        ax.set_ylabel("mean drag (N)")
        ax.set_title("ellipse code at aspect ratio 1 against the disc code")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "drag_ellipse_vs_disc.png", dpi=120)
        plt.close(fig)
    # density pairs: same shape, aspect ratio and size
    groups = {}
    for r in rows:
        groups.setdefault((r[1], r[2], r[3]), []).append(r)
    pairs = [sorted(g, key=lambda r: r[4]) for g in groups.values() if len({r[4] for r in g}) > 1]
    if pairs:
        # colour by density (not by position: a group may hold c1 and c11 alike)
        dens = sorted({r[4] for g in pairs for r in g})
        colour = {v: f"C{i}" for i, v in enumerate(dens)}
        fig, ax = plt.subplots(figsize=(6, 4))
        xs, names, x = [], [], 0
        for g in pairs:
            for r in g:
                ax.bar(x, r[5], yerr=r[6], color=colour[r[4]], capsize=3)
                xs.append(x)
                names.append(r[0])
                x += 1
            x += 1  # gap between groups
        for v in dens:
            ax.bar(0, 0, color=colour[v], label=f"{v:.3g} kg/m3")
        ax.set_xticks(xs, names)
        ax.set_ylabel("mean drag (N)")
        ax.set_title("mean drag +-1 std: density pairs")
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "drag_density.png", dpi=120)
        plt.close(fig)
    t = ["| case | shape | aspect ratio | D_g (um) | density (kg/m3) | mean drag (N) | std (N) | std (%) | beds |",
         "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        t.append(f"| {r[0]} | {r[1]} | {r[2]:g} | {r[3]:.0f} | {r[4]:.3g} | {r[5]:.1f} | {r[6]:.1f} | {100 * r[6] / r[5]:.0f} | {r[7]} |")
    (out / "drag_table.md").write_text("\n".join(t) + "\n")
    print("\n".join(t))


if __name__ == "__main__":
    main()
