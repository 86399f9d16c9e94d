"""python -m compare SETUP [--model hertz|hooke] [--engines talus,liggghts,yade] [--out DIR]

SETUP: SC-wall, SC-pair, SC-oblique, H1-small, H1-paper.
Runs the engines, computes every figure from their raw time series by one piece of
code, prints them side by side, writes report.md, figures.json and PNG plots into
DIR, and exits 1 when a figure is outside its tolerance (tolerances.py).
"""
import argparse
import json
import sys
from pathlib import Path

from . import engines, figures, setups, tolerances
from .report import write_sc_report

SC_SETUPS = ["SC-wall", "SC-pair", "SC-oblique"]
H1_SETUPS = ["H1-small", "H1-paper"]
# talus is run in the convention of the reference it is compared with
CONVENTION = {"liggghts": "liggghts", "yade": "yade"}


def compare_sc(setup, model, engs, out):
    runs = setups.sc_runs(setup, model)
    table = dict(tolerances.SC)
    if setup == "SC-oblique":
        table.update(tolerances.SC_OBLIQUE)
    results = []
    failures = []
    for run in runs:
        work = out / run.label
        row = {"run": run.label, "e": run.e, "angle": run.angle, "engines": {}}
        if "talus" in engs:
            row["engines"]["talus[talus]"] = figures.sc_figures(
                engines.run_talus_sc(run, "talus", work, setups.DT_SC), setup)
        for ref in ("liggghts", "yade"):
            if ref not in engs:
                continue
            runner = engines.run_liggghts_sc if ref == "liggghts" else engines.run_yade_sc
            row["engines"][ref] = figures.sc_figures(runner(run, work, setups.DT_SC), setup)
            if "talus" in engs:
                tname = f"talus[{CONVENTION[ref]}]"
                tf = figures.sc_figures(engines.run_talus_sc(run, CONVENTION[ref], work, setups.DT_SC), setup)
                row["engines"][tname] = tf
                checks = {}
                for key in table:
                    ok, d = tolerances.check(key, tf[key], row["engines"][ref][key], table)
                    checks[key] = {"ok": ok, "diff": d}
                    if not ok:
                        failures.append(f"{run.label}: {key} talus {tf[key]:.6g} vs {ref} {row['engines'][ref][key]:.6g}")
                row[f"check_vs_{ref}"] = checks
        results.append(row)
    return results, failures


def print_sc(results):
    for row in results:
        print(f"\n{row['run']}")
        names = list(row["engines"])
        keys = list(next(iter(row["engines"].values())).keys())
        print("  " + f"{'figure':<26}" + "".join(f"{n:>16}" for n in names))
        for k in keys:
            print("  " + f"{k:<26}" + "".join(f"{row['engines'][n].get(k, float('nan')):>16.6g}" for n in names))
        for ref in ("liggghts", "yade"):
            c = row.get(f"check_vs_{ref}")
            if c:
                bad = [k for k, v in c.items() if not v["ok"]]
                print(f"  talus vs {ref}: " + ("ok" if not bad else "OUTSIDE TOLERANCE: " + ", ".join(bad)))


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m compare", description=__doc__.splitlines()[0])
    ap.add_argument("setup", choices=SC_SETUPS + H1_SETUPS + ["throughput"])
    ap.add_argument("target", nargs="?", help="with `throughput`: H1-small or H1-paper")
    ap.add_argument("--model", choices=["hertz", "hooke"], default="hertz")
    ap.add_argument("--engines", default="talus,liggghts,yade")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    engs = [e.strip() for e in a.engines.split(",") if e.strip()]
    for e in engs:
        if e not in ("talus", "liggghts", "yade"):
            ap.error(f"--engines: unknown engine `{e}` (talus, liggghts, yade)")
    try:
        engines.check_versions(engs)
    except engines.EngineError as err:
        print(f"compare: {err}", file=sys.stderr)
        return 2
    out = a.out or Path("out") / "compare" / f"{a.setup}-{a.model}"
    out.mkdir(parents=True, exist_ok=True)
    if a.setup in SC_SETUPS:
        try:
            results, failures = compare_sc(a.setup, a.model, engs, out)
        except (engines.EngineError, ValueError) as err:
            print(f"compare: {err}", file=sys.stderr)
            return 2
        print_sc(results)
        (out / "figures.json").write_text(json.dumps(
            {"setup": a.setup, "model": a.model, "tolerances": {**tolerances.SC, **tolerances.SC_OBLIQUE},
             "runs": results, "failures": failures}, indent=1))
        write_sc_report(out, a.setup, a.model, results, failures)
        print(f"\nreport: {out / 'report.md'}")
        if failures:
            print("\nOUTSIDE TOLERANCE:\n  " + "\n  ".join(failures))
            return 1
        return 0
    from . import h1
    try:
        if a.setup == "throughput":
            target = a.target or "H1-small"
            r = h1.throughput(target, engs, out)
            print(json.dumps(r, indent=1))
            (out / "throughput.json").write_text(json.dumps(r, indent=1))
            return 0
        result, series_out = h1.compare_h1(a.setup, engs, out)
    except (engines.EngineError, ValueError) as err:
        print(f"compare: {err}", file=sys.stderr)
        return 2
    h1.plot_h1(out, a.setup, result, series_out)
    for name, g in result["engines"].items():
        print(name, json.dumps(g))
    print(f"Beverloo: {result['beverloo_kg_s']:.4f} kg/s")
    print(f"report: {out / 'report.md'}")
    if result["failures"]:
        print("\nOUTSIDE TOLERANCE:\n  " + "\n  ".join(result["failures"]))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
