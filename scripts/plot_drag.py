#!/usr/bin/env python3
"""Figures and table of the drag paper from `talus drag` outputs.

usage: python3 scripts/plot_drag.py OUT_DIR [OUT_DIR ...] [--out PNG_DIR]

Each OUT_DIR (e.g. out/drag/c1) holds summary.json, drag_vs_displacement.csv and
snapshots.csv. Writes, per case into its folder: <case>_drag.png (mean drag
against displacement with a +-1 std band, the averaging window shaded: Fig. 7),
<case>_snapshots_layers.png and <case>_snapshots_cluster.png (Figs. 9-12); and
into --out (default: the parent of the first OUT_DIR): drag_compare.png (Fig. 13),
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
from matplotlib.patches import Circle  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def load(d):
    d = Path(d)
    if not (d / "summary.json").exists():
        sys.exit(f"error: {d} has no summary.json (run `talus drag` first)")
    s = json.loads((d / "summary.json").read_text())
    a = np.loadtxt(d / "drag_vs_displacement.csv", delimiter=",", skiprows=1, ndmin=2)
    case = tomllib.loads((ROOT / "cases" / "drag" / f"{s['case']}.toml").read_text())
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
    for mode in ("layers", "cluster"):
        fig, axes = plt.subplots(1, len(disp), figsize=(4 * len(disp), 4.8))
        for ax, dd in zip(np.atleast_1d(axes), disp):
            rows = [r for r in snaps if float(r["displacement_m"]) == dd]
            xmax = max(float(r["x_m"]) + float(r["radius_m"]) for r in rows)
            ymax = max(float(r["y_m"]) + float(r["radius_m"]) for r in rows)
            for r in rows:
                if mode == "layers":
                    c = "tab:blue" if int(r["layer"]) % 2 == 0 else "tab:orange"
                else:
                    c = "tab:red" if r["cluster"] == "1" else "0.75"
                ax.add_patch(Circle((float(r["x_m"]) * 1e3, float(r["y_m"]) * 1e3), float(r["radius_m"]) * 1e3, fc=c, ec="k", lw=0.2))
            r0 = rows[0]
            ax.add_patch(Circle((float(r0["cylinder_x_m"]) * 1e3, float(r0["cylinder_y_m"]) * 1e3), float(r0["cylinder_radius_m"]) * 1e3, fc="k"))
            ax.set_xlim(0, xmax * 1e3)
            ax.set_ylim(0, ymax * 1e3)
            ax.set_aspect("equal")
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
    # density pairs: same shape, aspect ratio and size
    groups = {}
    for r in rows:
        groups.setdefault((r[1], r[2], r[3]), []).append(r)
    pairs = [sorted(g, key=lambda r: r[4]) for g in groups.values() if len({r[4] for r in g}) > 1]
    if pairs:
        fig, ax = plt.subplots(figsize=(6, 4))
        for k, g in enumerate(pairs):
            for j, r in enumerate(g):
                ax.bar(3 * k + j, r[5], yerr=r[6], color=["tab:blue", "tab:orange"][j % 2], capsize=3)
                ax.text(3 * k + j, 0, r[0], ha="center", va="bottom", color="w")
        ax.set_ylabel("mean drag (N)")
        ax.set_xticks([])
        ax.set_title("density 3.9e3 (blue) against 3.9e4 (orange) kg/m3")
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
