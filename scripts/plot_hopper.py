#!/usr/bin/env python3
"""Plot an H1 run: discharged mass and wall forces against time (PNG), and print the summary.

usage: python3 scripts/plot_hopper.py OUT_DIR
"""
import csv
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = Path(sys.argv[1])
    rows = list(csv.DictReader(open(out / "probes.csv")))
    summary = json.load(open(out / "summary.json"))
    t = [float(r["time_s"]) for r in rows]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    a1.plot(t, [float(r["mass_below_kg"]) for r in rows], "k-")
    a1.set_ylabel("discharged mass (kg)")
    t_fill = summary.get("fill_end_time_s")
    for name, style in [("hopper", "b-"), ("gate", "r-"), ("box", "g-")]:
        key = f"{name}_force_z_n"
        if key in rows[0]:
            a2.plot(t, [-float(r[key]) for r in rows], style, label=f"{name} (downward load)")
    a2.axhline(summary["total_weight_n"], color="gray", ls=":", label="total weight")
    if t_fill is not None:
        for a in (a1, a2):
            a.axvline(t_fill, color="gray", ls="--", lw=0.8)
        a1.text(t_fill, 0.0, " gate removed", va="bottom")
    a2.set_xlabel("time (s)")
    a2.set_ylabel("vertical wall force (N)")
    a2.legend(loc="best", fontsize=8)
    rate = summary.get("discharge_rate_kg_s")
    a1.set_title(f"H1 hopper: discharge rate {rate:.3f} kg/s" if rate else "H1 hopper")
    fig.tight_layout()
    png = out / "hopper.png"
    fig.savefig(png, dpi=110)
    print(f"\nH1 summary ({out}):")
    for k in ["particles", "fill_end_time_s", "fill_end_wall_force_z_n", "fill_end_gate_force_z_n",
              "total_weight_n", "fill_end_force_balance", "discharge_rate_kg_s", "particle_steps_per_s"]:
        if k in summary:
            print(f"  {k:<28} {summary[k]}")
    print(f"plot: {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
