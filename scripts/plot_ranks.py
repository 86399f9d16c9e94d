#!/usr/bin/env python3
"""Plot talus per-rank diagnostics (ranks.csv) against simulated time, in the style of the
per-processor figures of parallel hopper-discharge DEM papers (load, particles, contacts).

usage: python3 scripts/plot_ranks.py DIR [DIR ...] [--labels a,b,...] [--out PNG_DIR]

For each DIR, into DIR (or --out) it writes
  ranks_load.png       compute seconds per step, per rank (compute_s / steps in the interval)
  ranks_particles.png  owned particles per rank
  ranks_contacts.png   contacts per rank
  ranks_imbalance.png  imbalance_time and imbalance_work, reference line at 1.10,
with phase changes (e.g. fill -> discharge) as vertical dashed lines. With several DIRs it also
writes ranks_imbalance_compare.png (into --out, else the first DIR; e.g. static vs dynamic planes);
DIRs sharing one --out get "LABEL_" file-name prefixes. Labels default to folder names.
Prints a per-phase summary per DIR; exits 1 on a missing or malformed ranks.csv.
"""
import argparse
import csv
import sys
from pathlib import Path

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HEADER = ["time_s", "step", "phase", "rank", "owned", "ghosts", "contacts",
          "compute_s", "comm_s", "imbalance_time", "imbalance_work"]
THRESHOLD = 1.10


def load(folder: Path) -> dict:
    """Read folder/ranks.csv into numpy columns (one entry per CSV row); exit 1 on bad input."""
    path = folder / "ranks.csv"
    if not path.is_file():
        sys.exit(f"error: {path} not found")
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = [h.strip() for h in next(reader, [])]
        if header != HEADER:
            sys.exit(f"error: {path}: header is {','.join(header) or '(empty)'}\n"
                     f"       expected {','.join(HEADER)}")
        rows = [r for r in reader if r]
    if not rows:
        sys.exit(f"error: {path} has no data rows")
    try:
        d = {n: np.array([r[i].strip() for r in rows]) for i, n in enumerate(HEADER)}
        for n in HEADER:
            if n != "phase":
                d[n] = d[n].astype(float)
    except (ValueError, IndexError) as e:
        sys.exit(f"error: {path}: malformed row ({e})")
    # Rows of one output time are consecutive: a new block starts where the step changes.
    new_block = np.r_[True, d["step"][1:] != d["step"][:-1]]
    block = np.cumsum(new_block) - 1
    block_steps = d["step"][new_block]
    steps = np.diff(block_steps, prepend=0.0)          # first block: its own step count
    d["steps"] = np.maximum(steps, 1.0)[block]
    d["first"] = new_block                             # first row of each output time
    change = np.flatnonzero(d["phase"][1:] != d["phase"][:-1]) + 1
    d["changes"] = [(d["time_s"][i], d["phase"][i]) for i in change]
    return d


def mark_phases(ax, d: dict) -> None:
    for t, phase in d["changes"]:
        ax.axvline(t, color="gray", ls="--", lw=0.8)
        ax.text(t, 1.0, f" {phase}", transform=ax.get_xaxis_transform(),
                va="top", fontsize=8, color="gray")


def save(fig, ax, path: Path, legend: bool = True) -> None:
    ax.set_xlabel("simulated time (s)")
    ax.grid(alpha=0.3)
    if legend:
        ax.legend(loc="best", fontsize=8, ncol=1 + len(ax.get_lines()) // 9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def per_rank(d: dict, values: np.ndarray, ylabel: str, title: str, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ranks = np.unique(d["rank"]).astype(int)
    for r in ranks:
        m = d["rank"] == r
        ax.plot(d["time_s"][m], values[m], lw=1, label=f"rank {r}")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    mark_phases(ax, d)
    save(fig, ax, path, legend=len(ranks) <= 32)


def plot_dir(d: dict, label: str, out: Path, prefix: str) -> None:
    per_rank(d, d["compute_s"] / d["steps"], "compute time per step (s)",
             f"{label}: load per rank", out / f"{prefix}ranks_load.png")
    per_rank(d, d["owned"], "owned particles", f"{label}: particles per rank",
             out / f"{prefix}ranks_particles.png")
    per_rank(d, d["contacts"], "contacts", f"{label}: contacts per rank",
             out / f"{prefix}ranks_contacts.png")
    f = d["first"]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(d["time_s"][f], d["imbalance_time"][f], "b-", lw=1, label="imbalance_time (compute)")
    ax.plot(d["time_s"][f], d["imbalance_work"][f], "r-", lw=1, label="imbalance_work (owned+contacts)")
    ax.axhline(THRESHOLD, color="k", ls=":", lw=1, label=f"{THRESHOLD:.2f}")
    ax.set_ylabel("max / mean over ranks")
    ax.set_title(f"{label}: load imbalance")
    mark_phases(ax, d)
    save(fig, ax, out / f"{prefix}ranks_imbalance.png")


def summary(d: dict, folder: Path, label: str) -> None:
    n_ranks = len(np.unique(d["rank"]))
    print(f"{folder} [{label}]: {n_ranks} ranks, {len(d['rank'])} rows, "
          f"{int(d['first'].sum())} output times")
    phases = list(dict.fromkeys(d["phase"]))           # order of first appearance
    for p in phases:
        m = d["phase"] == p
        print(f"  {p:<10} rows {int(m.sum()):5d}  mean imbalance_time "
              f"{d['imbalance_time'][m].mean():.3f}  imbalance_work {d['imbalance_work'][m].mean():.3f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", type=Path, help="talus output folders holding ranks.csv")
    ap.add_argument("--labels", help="comma-separated labels, one per DIR (default: folder names)")
    ap.add_argument("--out", type=Path, help="write PNGs here instead of into each DIR")
    a = ap.parse_args()
    labels = a.labels.split(",") if a.labels else [p.resolve().name for p in a.dirs]
    if len(labels) != len(a.dirs):
        sys.exit(f"error: {len(labels)} labels given for {len(a.dirs)} folders")
    if a.out:
        a.out.mkdir(parents=True, exist_ok=True)
    data = [load(p) for p in a.dirs]                   # validate everything before plotting
    shared = a.out is not None and len(a.dirs) > 1
    for p, d, label in zip(a.dirs, data, labels):
        prefix = label.replace("/", "_").replace(" ", "_") + "_" if shared else ""
        plot_dir(d, label, a.out or p, prefix)
        summary(d, p, label)
    if len(a.dirs) > 1:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for i, (d, label) in enumerate(zip(data, labels)):
            f, c = d["first"], f"C{i}"
            ax.plot(d["time_s"][f], d["imbalance_time"][f], "-", color=c, lw=1, label=f"{label} time")
            ax.plot(d["time_s"][f], d["imbalance_work"][f], "--", color=c, lw=1, label=f"{label} work")
        ax.axhline(THRESHOLD, color="k", ls=":", lw=1, label=f"{THRESHOLD:.2f}")
        ax.set_ylabel("max / mean over ranks")
        ax.set_title("load imbalance (solid: compute time, dashed: owned+contacts)")
        path = (a.out or a.dirs[0]) / "ranks_imbalance_compare.png"
        save(fig, ax, path)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
