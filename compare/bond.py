"""python -m compare bond [--case cases/pile.toml] [--levels 0,20000,40000] [--engines talus,liggghts]
                        [--replicas K] [--out DIR]

The angle of repose against the Bond number. The pile (cases/pile.toml: a column released by a
gate collapses into a pile) runs with LIGGGHTS's simplified JKR cohesion (`sjkr`) at several
cohesion energy densities K (J/m^3), in talus and in the reference. At each level the two
engines are compared as ensembles of replicas (`python -m compare CASE.toml --replicas K --set
contact.cohesion=...`, compare/ensemble.py: the figures and the probe columns within the case's
tolerances), and in each engine the angle of repose must rise with the Bond number.

The Bond number of a level is Bo = K A / (m g): the sjkr pull on a sphere of the mean radius R
resting on a flat wall of its own material, over its weight. sjkr pulls only while the bodies
overlap, and harder the deeper they do, so the overlap delta is the one at which Hertz's elastic
force carries weight and pull together: 4/3 E* sqrt(R) delta^1.5 = m g + K A, 1/E* = 2 (1 - nu^2)
/ E, A = pi (2 R delta - delta^2), the circle the plane cuts, as LIGGGHTS's sjkr takes it at a
wall (compare/tests/test_bond.py checks this overlap and force against talus's own resting sphere).

Verdict (exit 1 otherwise):
- every level's comparison agrees (the ensemble test of compare/ensemble.py);
- in each engine the ensemble mean angle rises from each level to the next;
- in each engine the rise from the first level to the last exceeds three standard errors (the
  standard error of the two engines' difference at each level, which bounds each engine's own).

Writes DIR/bond.json, DIR/report.md and DIR/angle_vs_bond.png; each level's comparison in DIR/K<K>/.
"""
import argparse
import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def resting(case, k=0.0):
    """(R, m, g, delta): the mean radius of the case's particles (a lattice of one material), a
    sphere's mass, gravity, and the overlap delta with which the sphere rests on a flat wall of its
    own material under its own weight and the sjkr pull of energy density `k` (J/m^3): Hertz's
    elastic force 4/3 E* sqrt(R) delta^1.5 (1/E* = 2 (1 - nu^2) / E) carries m g + k A, A =
    pi (2 R delta - delta^2) the circle the plane cuts (solved by bisection)."""
    p = case["particles"]
    mat = next(m for m in case["material"] if m["name"] == p["material"])
    lat = p["lattice"]
    r = 0.5 * (lat["radius_min"] + lat["radius_max"])
    e, nu, rho = mat["youngs_modulus"], mat["poisson_ratio"], mat["density"]
    g = math.sqrt(sum(x * x for x in case["simulation"]["gravity"]))
    m = rho * 4.0 / 3.0 * math.pi * r ** 3
    e_star = e / (2.0 * (1.0 - nu * nu))

    def excess(d):
        return 4.0 / 3.0 * e_star * math.sqrt(r) * d ** 1.5 - m * g - k * math.pi * (2.0 * r * d - d * d)

    lo, hi = 0.0, r
    if excess(hi) <= 0.0:
        raise ValueError(f"energy density {k:g} J/m^3: the pull holds a sphere deeper than its radius")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) < 0.0 else (lo, mid)
    return r, m, g, 0.5 * (lo + hi)


def bond_number(case, k):
    """The Bond number of cohesion energy density `k` (J/m^3) for the case's particles: the sjkr
    pull K A on a sphere resting on a flat wall of its own material ([`resting`]), over its weight."""
    r, m, g, delta = resting(case, k)
    return k * math.pi * (2.0 * r * delta - delta * delta) / (m * g)


def level_figure(fig, ref, name):
    """(talus's ensemble mean, the reference's, the standard error of their difference, ok) of
    figure `name` in a comparison's figures.json."""
    for c in fig["references"][ref]["checks"]:
        if c["kind"] == "figure" and c["name"] == name:
            return c["talus"], c["reference"], c["standard_error"], c["ok"]
    raise SystemExit(f"compare bond: no figure {name} in the comparison with {ref} (did the pile form?)")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m compare bond", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", type=Path, default=ROOT / "cases" / "pile.toml",
                    help="the pile (default cases/pile.toml); its particles are a lattice of one material")
    ap.add_argument("--levels", default="0,20000,40000",
                    help="cohesion energy densities K (J/m^3), rising (default 0,20000,40000; the column "
                         "of cases/pile.toml hardly collapses from about 60000 on)")
    ap.add_argument("--engines", default="talus,liggghts", help="talus and one reference that has sjkr (liggghts)")
    ap.add_argument("--replicas", type=int, default=4, metavar="K", help="replicas per engine and level (default 4)")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "compare" / "bond")
    a = ap.parse_args(argv)
    try:
        levels = [float(x) for x in a.levels.split(",") if x.strip()]
    except ValueError:
        ap.error(f"--levels {a.levels}: numbers separated by commas")
    if len(levels) < 2 or any(y <= x for x, y in zip(levels, levels[1:])) or levels[0] < 0:
        ap.error(f"--levels {a.levels}: at least two energy densities, rising, none negative")
    engs = [e.strip() for e in a.engines.split(",") if e.strip()]
    if len(engs) != 2 or engs[0] != "talus":
        ap.error(f"--engines {a.engines}: talus and one reference, e.g. talus,liggghts")
    ref = engs[1]
    if a.replicas < 2:
        ap.error(f"--replicas {a.replicas}: at least 2 (the rise is judged against the ensembles' scatter)")
    case = tomllib.loads(a.case.read_text())
    a.out.mkdir(parents=True, exist_ok=True)

    rows = []
    for k in levels:
        out = a.out / f"K{k:g}"
        cmd = [sys.executable, "-m", "compare", str(a.case), "--engines", a.engines, "--no-explain",
               "--replicas", str(a.replicas), "--out", str(out)]
        if k > 0:
            cmd += ["--set", f'contact.cohesion={{model="sjkr", energy_density={k!r}}}']
        print(f"compare bond: K = {k:g} J/m^3 (Bo = {bond_number(case, k):.3g}): {' '.join(cmd[1:])}", flush=True)
        log = a.out / f"K{k:g}.log"
        with open(log, "w") as f:
            p = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, cwd=ROOT)
        if not (out / "figures.json").exists():
            print(Path(log).read_text()[-3000:], file=sys.stderr)
            raise SystemExit(f"compare bond: the comparison at K = {k:g} did not finish (exit {p.returncode}; log {log})")
        fig = json.loads((out / "figures.json").read_text())
        t, r, se, ok = level_figure(fig, ref, "angle_of_repose_deg")
        rt, rr, _, _ = level_figure(fig, ref, "runout_95_m")
        rows.append({"energy_density_j_m3": k, "bond_number": bond_number(case, k), "angle_talus_deg": t,
                     f"angle_{ref}_deg": r, "angle_standard_error_deg": se, "runout_95_talus_m": rt,
                     f"runout_95_{ref}_m": rr, "comparison_agrees": p.returncode == 0, "angle_agrees": ok,
                     "folder": str(out)})

    failures = [f"K = {x['energy_density_j_m3']:g}: talus and {ref} differ (see {x['folder']}/report.md)"
                for x in rows if not x["comparison_agrees"]]
    for eng, col in (("talus", "angle_talus_deg"), (ref, f"angle_{ref}_deg")):
        a_ = [x[col] for x in rows]
        for x, y, lo, hi in zip(a_, a_[1:], rows, rows[1:]):
            if not y > x:
                failures.append(f"{eng}: the angle does not rise from Bo = {lo['bond_number']:.3g} ({x:.2f} deg) "
                                f"to Bo = {hi['bond_number']:.3g} ({y:.2f} deg)")
        rise = a_[-1] - a_[0]
        se = math.hypot(rows[0]["angle_standard_error_deg"], rows[-1]["angle_standard_error_deg"])
        if not rise > 3.0 * se:
            failures.append(f"{eng}: the rise {rise:.2f} deg from the first level to the last is not beyond "
                            f"three standard errors ({3.0 * se:.2f} deg)")

    result = {"case": str(a.case), "reference": ref, "replicas": a.replicas, "cohesion": "sjkr",
              "bond_number": "K A / (m g), the sjkr pull on a sphere of the mean radius resting on a flat wall of its "
                             "material (4/3 E* sqrt(R) delta^1.5 = m g + K A, A = pi (2 R delta - delta^2)), over its weight",
              "levels": rows, "failures": failures}
    (a.out / "bond.json").write_text(json.dumps(result, indent=1) + "\n")
    lines = [f"# Angle of repose against the Bond number: talus and {ref}", "",
             f"`python3 -m compare bond --case {a.case.relative_to(ROOT) if a.case.is_relative_to(ROOT) else a.case} "
             f"--levels {a.levels} --engines {a.engines} --replicas {a.replicas}`", "",
             "Ensemble means of the angle of repose (deg) and of the distance holding 95% of the spheres (m), "
             f"{a.replicas} replicas per engine; SE: the standard error of the engines' difference.", "",
             f"| K (J/m^3) | Bo | angle, talus | angle, {ref} | SE | runout, talus | runout, {ref} | agree |",
             "|---|---|---|---|---|---|---|---|"]
    for x in rows:
        lines.append(f"| {x['energy_density_j_m3']:g} | {x['bond_number']:.3g} | {x['angle_talus_deg']:.2f} | "
                     f"{x[f'angle_{ref}_deg']:.2f} | {x['angle_standard_error_deg']:.2f} | {x['runout_95_talus_m']:.4f} | "
                     f"{x[f'runout_95_{ref}_m']:.4f} | {'yes' if x['comparison_agrees'] else 'NO'} |")
    lines += ["", "Verdict: " + ("the angle rises with the Bond number in both engines, and they agree at every level."
                                 if not failures else "FAILED:"), *[f"- {f}" for f in failures]]
    (a.out / "report.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 3.5))
        bo = [x["bond_number"] for x in rows]
        se = [x["angle_standard_error_deg"] for x in rows]
        ax.errorbar(bo, [x["angle_talus_deg"] for x in rows], yerr=se, marker="o", capsize=3, label="talus")
        ax.errorbar(bo, [x[f"angle_{ref}_deg"] for x in rows], yerr=se, marker="s", capsize=3, label=ref)
        ax.set_xlabel("Bond number (sjkr pull on a resting sphere / weight)")
        ax.set_ylabel("angle of repose (deg)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(a.out / "angle_vs_bond.png", dpi=120)
    except ImportError:
        pass
    print("\n".join(lines[6:]))
    print(f"compare bond: report {a.out / 'report.md'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
