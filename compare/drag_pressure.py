"""Drag against confining pressure: `python3 -m compare.drag_pressure [--pressures P,...]
[--engines talus[,yade]] [--out DIR]`.

Runs cases/drag-pressure.toml (bed 1 of the drag paper's case c1 under a servo lid that
holds a line load P, the cylinder then pushed 6 mm up at 2 m/s) at each P, computes the
mean drag over displacements 1-5 mm and drag / (P D_c) by the same code as
`python -m compare` (compare/case.py, `drag_figures`), and writes a table (table.md,
family.json) and a plot of both against P into DIR (default out/drag-pressure). With
`--engines talus,yade` each P also runs in YADE through the exporter (its driver runs
the same servo controller), talus then in YADE's convention.
"""
import argparse
import json
import sys
import tomllib
from pathlib import Path

from . import case as cm
from .case import EngineError, drag_figures

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "drag-pressure.toml"
PRESSURES = [1.0e3, 3.0e3, 1.0e4, 3.0e4]


def lid_index(case):
    return next(i for i, w in enumerate(case["wall"]) if "servo" in w)


def at(p, engine, out):
    """One engine on the case at pressure p (N/m): "talus" (its own convention),
    "talus[yade]" or "yade" (exported). Returns the drag figures."""
    case = tomllib.load(open(CASE, "rb"))
    lid = lid_index(case)
    cm.SETS = [f"wall[{lid}].servo.pressure={p!r}"]
    if engine == "yade":
        s = cm.run_reference(CASE, "yade", out)
    else:
        s, _ = cm.run_talus(CASE, "yade" if engine == "talus[yade]" else "talus", out)
    case["wall"][lid]["servo"]["pressure"] = p
    return drag_figures(s, case)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m compare.drag_pressure", description=__doc__.split("\n\n")[0])
    ap.add_argument("--pressures", default=",".join(f"{p:g}" for p in PRESSURES), help="line loads P (N/m), comma-separated")
    ap.add_argument("--engines", default="talus", help="talus, or talus,yade")
    ap.add_argument("--out", default=str(ROOT / "out" / "drag-pressure"))
    a = ap.parse_args(argv)
    try:
        ps = [float(x) for x in a.pressures.split(",")]
    except ValueError:
        ap.error(f"--pressures {a.pressures}: not a list of numbers")
    if any(not p > 0 for p in ps):
        ap.error(f"--pressures {a.pressures}: every pressure must be positive")
    engs = a.engines.split(",")
    if "talus" not in engs or any(e not in ("talus", "yade") for e in engs):
        ap.error(f"--engines {a.engines}: talus, or talus,yade")
    out = Path(a.out)
    rows = []
    try:
        for p in ps:
            row = {"pressure_n_m": p, "talus": at(p, "talus", out / f"P{p:g}" / "talus")}
            if "yade" in engs:
                row["talus[yade]"] = at(p, "talus[yade]", out / f"P{p:g}" / "talus-yade")
                row["yade"] = at(p, "yade", out / f"P{p:g}" / "yade")
            rows.append(row)
            print(f"P = {p:g} N/m: " + ", ".join(f"{k} drag {v['mean_drag_n']:.4g} N, drag/(P D_c) {v['drag_per_p_dc']:.4g}"
                                                  for k, v in row.items() if k != "pressure_n_m"), flush=True)
    except EngineError as e:
        print(f"drag_pressure: {e}", file=sys.stderr)
        return 1
    write(out, rows)
    return 0


def write(out, rows):
    out.mkdir(parents=True, exist_ok=True)
    (out / "family.json").write_text(json.dumps(rows, indent=1))
    engs = [k for k in rows[0] if k != "pressure_n_m"]
    lines = ["# Drag against confining pressure (cases/drag-pressure.toml)", "",
             "| P (N/m) | " + " | ".join(f"{e}: drag (N) | {e}: drag/(P D_c)" for e in engs) + " |",
             "|---|" + "---|---|" * len(engs)]
    for r in rows:
        lines.append(f"| {r['pressure_n_m']:g} | " + " | ".join(f"{r[e]['mean_drag_n']:.4g} | {r[e]['drag_per_p_dc']:.4g}" for e in engs) + " |")
    (out / "table.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    p = [r["pressure_n_m"] for r in rows]
    for e in engs:
        ax[0].loglog(p, [r[e]["mean_drag_n"] for r in rows], "o-", label=e)
        ax[1].semilogx(p, [r[e]["drag_per_p_dc"] for r in rows], "o-", label=e)
    ax[0].set(xlabel="P (N/m)", ylabel="mean drag (N)")
    ax[1].set(xlabel="P (N/m)", ylabel="drag / (P D_c)", ylim=(0, None))
    for x in ax:
        x.legend()
    fig.tight_layout()
    fig.savefig(out / "drag_pressure.png", dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
