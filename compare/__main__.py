"""python -m compare SETUP [--model hertz|hooke] [--engines talus,liggghts,yade] [--out DIR]

SETUP: SC-wall, SC-pair, SC-oblique, H1-small, H1-paper [--resume], or `throughput TARGET` with
TARGET H1-small, H1-paper (talus, LIGGGHTS, YADE) or bed-20k, bed-100k (a dense settled
bed: talus on 1 and 2 threads, LAMMPS on 1 process and 2 ranks, LIGGGHTS; compare/bed.py).
`throughput TARGET --repeat N`: N rounds, the runs' order alternating, each ratio's median
over the rounds (compare/rounds.py).
`python -m compare CASE.toml [--engines talus,liggghts|yade|lammps] [--replicas K] [--perturb KEY=VALUE]`: any
case, exported to the reference and compared as ensembles of K replicas (compare/ensemble.py;
with one replica column by column, compare/case.py; `--fields z` also compares the continuum-field
profiles, compare/fields.py; `python -m compare CASE.toml --help`);
`python -m compare regress CASE.toml --golden FILE`: talus against its golden file
(compare/regress.py); `python -m compare window`: the H1-paper discharge window;
`python -m compare ab --baseline REV`: this tree's talus against a baseline commit, the
runs alternated in one session (compare/ab.py); `python -m compare benchmarks page`: docs/benchmarks.md
from the recorded results (compare/benchpage.py); `python -m compare validation [--out docs/validation.md]
[--compare-dir out/compare] [--cargo-profile ci|release] [--no-cargo]`: docs/validation.md, every closed-form
test (run by cargo) and every comparison in the compare dir with its current figure (compare/validation.py);
`python -m compare bond [--levels K,...]`: the cohesive pile's angle of repose rising with the Bond
number, against LIGGGHTS as ensembles (compare/bond.py); `python -m compare schema [--check]`: docs/case.schema.json (`talus schema`) and the case-file reference
docs/guide/case-reference.md made from it (compare/schema_page.py); `python -m compare pyref [--check]`:
docs/guide/python-reference.md from the module's stub (compare/pyref.py).
Runs the engines, computes every figure from their raw time series by one piece of
code, prints them side by side, writes report.md, figures.json and PNG plots into
DIR, and exits 1 when a figure is outside its tolerance (tolerances.py).
"""
import argparse
import json
import sys
from pathlib import Path

from . import engines, figures, setups, tolerances
from .bed import BEDS, print_table as print_bed, throughput as bed_throughput
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
        if "liggghts" in row["engines"] and "yade" in row["engines"]:
            a, b = row["engines"]["liggghts"], row["engines"]["yade"]
            differ = {}
            for key in table:
                ok, d = tolerances.check(key, b[key], a[key], table)
                if not ok:
                    differ[key] = {"liggghts": a[key], "yade": b[key], "why": WHY.get(key, "")}
            if differ:
                row["references_disagree"] = differ
        results.append(row)
    return results, failures


# why LIGGGHTS and YADE disagree on a figure (each is matched by talus in its own convention)
WHY = {
    "restitution": "end of contact: LIGGGHTS lets the normal force go tensile, YADE clips it at zero "
                   "(with the linear dashpot this raises e_out to the Schwager-Poeschel value)",
    "contact_duration_s": "damping from e: YADE's Thornton et al. (2013) fit is stronger than LIGGGHTS's "
                          "2 sqrt(5/6) beta form; with hooke, YADE's clip ends the contact earlier",
    "max_overlap_m": "damping from e (Thornton fit vs LIGGGHTS's form) changes the peak",
    "max_normal_force_n": "damping from e (Thornton fit vs LIGGGHTS's form) and the clip",
    "tangential_rebound_m_s": "tangential kinematics: YADE Mindlin increments shear with full radii and acts at "
                              "the wall surface (arm r - delta); LIGGGHTS uses r - delta/2 and total shear times the "
                              "current stiffness; damping ratio differs too",
    "spin_rad_s": "as for the tangential rebound: YADE's torque arm at a wall is r - delta, LIGGGHTS's r - delta/2",
}


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
        if row.get("references_disagree"):
            print("  LIGGGHTS and YADE differ (by convention) on: " + ", ".join(row["references_disagree"]))


def _throughput(a, bed, engs, out):
    """`throughput TARGET [--repeat N]`: one round, or N alternating rounds and their medians."""
    from . import h1, rounds
    target = a.target or "H1-small"
    each, first = [], None
    for k in range(a.repeat):
        if bed:
            r = bed_throughput(target, engs, out.resolve(), a.steps, k=k)
            print_bed(r)
        else:
            r, first = h1.throughput(target, engs, out, a.steps, k=k, first=first)
            print(json.dumps(r, indent=1))
        if a.repeat > 1:
            print(f"(round {k + 1} of {a.repeat}, order: {', '.join(r['order'])})")
            (out / f"throughput-round-{k + 1}.json").write_text(json.dumps(r, indent=1))
        each.append(r)
    if a.repeat > 1:
        r = {"setup": target, **rounds.summarise(each)}
        rounds.print_summary(r)
    (out / "throughput.json").write_text(json.dumps(r, indent=1))
    print(f"\nwritten: {out / 'throughput.json'}")
    return 0


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["window"]:  # H1-paper discharge window, its own options: compare/window.py
        from . import window
        return window.main(argv[1:])
    if argv[:1] and argv[0].endswith(".toml"):  # any case: exported, run, compared (compare/case.py)
        from . import case
        return case.main(argv)
    if argv[:1] == ["benchmarks"]:  # docs/benchmarks.md from measured results: compare/benchpage.py
        from . import benchpage
        return benchpage.main(argv[1:])
    if argv[:1] == ["ab"]:  # this tree's talus against a baseline commit: compare/ab.py
        from . import ab
        return ab.main(argv[1:])
    if argv[:1] == ["pyref"]:  # docs/guide/python-reference.md from the module's stub: compare/pyref.py
        from . import pyref
        return pyref.main(argv[1:])
    if argv[:1] == ["schema"]:  # docs/case.schema.json and the case-file reference: compare/schema_page.py
        from . import schema_page
        return schema_page.main(argv[1:])
    if argv[:1] == ["validation"]:  # docs/validation.md from the tests and comparisons: compare/validation.py
        from . import validation
        return validation.main(argv[1:])
    if argv[:1] == ["bond"]:  # the cohesive pile's angle of repose against the Bond number: compare/bond.py
        from . import bond
        return bond.main(argv[1:])
    if argv[:1] == ["regress"]:  # talus against its golden file: compare/regress.py
        from . import regress
        return regress.main(argv[1:])

    ap = argparse.ArgumentParser(prog="python -m compare", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("setup", choices=SC_SETUPS + H1_SETUPS + ["throughput"])
    ap.add_argument("target", nargs="?", choices=H1_SETUPS + list(BEDS),
                    help="with `throughput`: H1-small, H1-paper, bed-20k or bed-100k")
    ap.add_argument("--model", choices=["hertz", "hooke"], default="hertz")
    ap.add_argument("--engines", help="default: talus,liggghts,yade; for the beds talus,lammps,liggghts")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--steps", type=int, help="throughput: run only this many steps (H1: of the fill; beds: of the window) in every engine")
    ap.add_argument("--repeat", type=int, default=1, metavar="N",
                    help="throughput: N rounds, each running every engine once, the order of the runs alternating "
                         "(forward, backward, ...); reports each ratio's median over the rounds and its range "
                         "(compare/rounds.py)")
    ap.add_argument("--resume", action="store_true",
                    help="H1-small, H1-paper: reuse the finished talus and LIGGGHTS runs in DIR, and run YADE resumably "
                         "(a checkpoint every 10 min of wall time): an unfinished YADE run in DIR/yade continues from "
                         "its last checkpoint; run the same command again until it finishes")
    a = ap.parse_args(argv)
    if a.resume and a.setup not in H1_SETUPS:
        ap.error("--resume is for H1-small and H1-paper")
    if a.repeat < 1 or (a.repeat > 1 and a.setup != "throughput"):
        ap.error(f"--repeat {a.repeat}: a number of rounds of at least 1, and only with `throughput`")
    bed = a.setup == "throughput" and a.target in BEDS
    known = ("talus", "lammps", "liggghts") if bed else ("talus", "liggghts", "yade")
    engs = [e.strip() for e in (a.engines or ",".join(known)).split(",") if e.strip()]
    for e in engs:
        if e not in known:
            ap.error(f"--engines: unknown engine `{e}` here ({', '.join(known)})")
    try:
        engines.check_versions(engs)
    except engines.EngineError as err:
        print(f"compare: {err}", file=sys.stderr)
        return 2
    out = a.out or Path("out") / "compare" / (f"throughput-{a.target}" if bed else f"{a.setup}-{a.model}")
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
            return _throughput(a, bed, engs, out)
        result, series_out = h1.compare_h1(a.setup, engs, out, resume=a.resume)
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
