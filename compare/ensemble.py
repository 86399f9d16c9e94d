"""Ensemble verdicts for `python -m compare CASE.toml`: chaotic cases compared as
ensembles of replicas, not run against run.

Two correct engines part particle by particle within a few hundredths of a second in
any granular flow, so series compared step by step cannot agree there. Instead:

1. **Replicas.** Each engine runs K replicas of the case (`--replicas K`, the case's
   `[compare] replicas`, default 4). Replica k moves every initial particle by a seeded
   random vector of 1e-9 of its radius (replica 0: unmoved), written into the particle
   file both engines read; a case whose particles are all inserted changes its
   insertions' seeds instead. Replicas run as parallel jobs, talus on one thread each.
2. **Divergence time.** Where a probe column's replicas of one engine first spread
   apart by more than half its step-by-step tolerance (the column's `series_range`,
   a fraction of its range), that engine's replicas part; t_d is the earlier of the
   two engines' times. Before t_d, replica 0 of talus and of the reference are compared
   step by step as a single run would be. After it, only statistics.
3. **Window statistics.** The windows are the case's `[compare] windows`, or else its
   phases; each is cut to start at t_d. For every probe column and window, each
   replica gives a time mean and a fluctuation (the standard deviation over time); for
   the case's analysis figures (discharge rate, angle of repose, drag, ...) each
   replica gives its value.
4. **The test.** For each statistic the two ensembles' means differ by D. A one-sided
   Welch t-test of the hypothesis |D| <= margin at the 5% level: "differs" only where
   the ensembles show, with 95% confidence, a difference larger than the margin; the
   margin is the case's `window_mean` of the column's range (window means and
   fluctuations) or its `figure_rel` of the figure (figures). So "agrees" means the
   difference lies within what the two ensembles' own scatter allows plus the margin.
   A comparison makes a hundred such tests, so their p-values are adjusted together
   (Benjamini-Hochberg, false discovery rate 5%): where talus and the reference agree
   on everything, a comparison says "differs" with probability at most 5%, and where a
   change shows in many columns each of them needs less evidence.
   Each check also states the smallest change it detects with 80% power:
   margin + (t_0.975 + t_0.80) x standard error, as a fraction of the column's range
   (or of the figure).
5. **Power.** `--perturb KEY=VALUE` changes one value in talus's runs only: a test of
   the test. A null change agrees; a real one (friction 0.5 -> 0.3) differs.

The report has a plot per column with both ensembles' bands (mean +- 2 sigma over the
replicas) and t_d marked, a table of every check, and figures.json with everything.
"""
import csv
import json
import math
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from scipy import stats

from . import case as C
from .engines import TALUS, EngineError, toml_value

DEFAULT_REPLICAS = 4
# each replica's initial positions moved by this fraction of the particle's radius
NUDGE = 1e-9
ALPHA = 0.05
POWER = 0.80


# ------------------------------------------------------------------ replicas

def replica_sets(case_path, case, k, work):
    """`--set` arguments that make replica k: the case's initial particles, each moved by a
    seeded random vector of NUDGE of its radius (k = 0: as they are), as a CSV file both
    engines read; a case without initial particles gets its insertions' seeds moved by k.
    Returns (sets, how)."""
    parts = case.get("particles", {})
    inserts = [(i, j) for i, ph in enumerate(case.get("phase", [])) for j, _ in enumerate(ph.get("insert", []))]
    if parts.get("list") == [] and inserts:
        sets = [f"phase[{i}].insert[{j}].seed={case['phase'][i]['insert'][j]['seed'] + 7919 * k}" for i, j in inserts]
        return sets, "insertion seeds"
    if any(any(p.get("spin", [0.0, 0.0, 0.0])) for p in parts.get("list", [])):
        raise EngineError("replicas: the case's particles start spinning, which a replica's particle file does not carry; "
                          "use --replicas 1")
    work.mkdir(parents=True, exist_ok=True)
    cloud = work / "cloud.csv"
    if k == 0:
        # the case's initial particles as this comparison's --set values make them
        C.run([TALUS, "cloud", case_path, "--out", cloud, *[a for kv in C.SETS for a in ("--set", kv)]], work / "cloud.log")
    with open(cloud, newline="") as f:
        rows = list(csv.DictReader(f))
    ids = np.array([int(r["id"]) for r in rows])
    x = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    rad = np.array([float(r["radius"]) for r in rows])
    v = np.array([[float(r[c]) for c in ("vx", "vy", "vz")] for r in rows])
    if k > 0:
        d = np.random.default_rng(20111 + k).normal(size=x.shape)
        x = x + d / np.linalg.norm(d, axis=1)[:, None] * (NUDGE * rad)[:, None]
    path = (work / f"replica{k}.csv").resolve()
    with open(path, "w") as f:
        f.write("id,x,y,z,radius,vx,vy,vz\n")
        for i in range(len(ids)):
            f.write("%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (ids[i], *x[i], rad[i], *v[i]))
    table = {key: val for key, val in parts.items() if key not in ("list", "lattice", "csv")}
    table["csv"] = str(path)
    return [f"particles={toml_value(table)}"], f"initial positions moved by {NUDGE:g} of each radius"


def run_replicas(case_path, case, refs, k_reps, out, perturb):
    """Every replica of talus (in each reference's convention, with `perturb`) and of each
    reference, as parallel jobs. Returns {ref: (talus runs, reference runs)}, each run a
    (series, figures) pair, and how the replicas differ."""
    # each replica's particle file made once, before the jobs (which read it side by side)
    made = [replica_sets(case_path, case, k, out / "replicas") for k in range(k_reps)]

    def job(ref, k):
        conv = C.CONVENTION[ref]
        sets = made[k][0]
        t_out = out / f"talus-{conv}" / f"replica{k}"
        ts, summary = C.run_talus(case_path, conv, t_out, [*sets, "parallel.threads=1", *perturb])
        ts["timestep_s"] = summary["timestep_s"]
        r_out = out / ref / f"replica{k}"
        rs = C.run_reference(case_path, ref, r_out, t_out / "inserted.csv", extra=sets)
        return (ts, C.figures_of(ts, case, summary, t_out)), (rs, C.figures_of(rs, case, summary, r_out))

    work = [(ref, k) for ref in refs for k in range(k_reps)]
    with ThreadPoolExecutor(max_workers=max(1, os.cpu_count() or 1)) as pool:
        done = list(pool.map(lambda rk: job(*rk), work))
    res = {ref: ([], []) for ref in refs}
    for (ref, _), (t, r) in zip(work, done):
        res[ref][0].append(t)
        res[ref][1].append(r)
    return res, made[-1][1]


# ------------------------------------------------------------------ analysis

def columns(t_runs, r_runs, tol):
    first, ref = t_runs[0][0], r_runs[0][0]
    return [c for c in first if c not in C.SKIP and c != "timestep_s" and c not in tol["ignore"] and c in ref]


def same_steps(ts, rs, before):
    """The rows both engines wrote at the same step (times within half a time step),
    before `before`: the step-by-step comparison reads no interpolated values (an
    exported deck writes every N steps, talus where the interval is crossed, so their
    rows part by a step now and then, which in a spiky force series is no small error)."""
    t, r = ts["time_s"], rs["time_s"]
    half = 0.5 * ts["timestep_s"]
    j = np.clip(np.searchsorted(r, t), 1, len(r) - 1)
    j = np.where(np.abs(r[j - 1] - t) < np.abs(r[j] - t), j - 1, j)
    keep = (np.abs(r[j] - t) <= half) & (t < before)
    tk = {c: v[keep] for c, v in ts.items() if c != "timestep_s"}
    rk = {c: (v[j[keep]] if c != "time_s" else tk["time_s"]) for c, v in rs.items()}
    return tk, rk


def scales(cols, r_runs):
    """Each column's scale: the reference ensemble's largest range (at least 1e-9 of its size)."""
    out = {}
    for c in cols:
        rng = max(float(s[c].max() - s[c].min()) for s, _ in r_runs)
        big = max(float(np.abs(s[c]).max()) for s, _ in r_runs)
        out[c] = max(rng, 1e-9 * big, 1e-300)
    return out


def divergence_time(runs, cols, scale, tol):
    """When this ensemble's replicas part: the first time a column's replicas spread, on
    replica 0's times, by more than half its series tolerance of the scale (None: never)."""
    t0 = runs[0][0]["time_s"]
    first = math.inf
    for c in cols:
        limit = 0.5 * tol["series"].get(c, tol["series_range"]) * scale[c]
        spread = np.zeros_like(t0)
        for s, _ in runs[1:]:
            spread = np.maximum(spread, np.abs(np.interp(t0, s["time_s"], s[c]) - runs[0][0][c]))
        over = np.nonzero(spread > limit)[0]
        if over.size:
            first = min(first, float(t0[over[0]]))
    return None if first == math.inf else first


def windows_after(tol, series, t_d):
    """The windows compared by statistics: the case's `windows` or else its phases, each
    from t_d on (those with fewer than 4 probe rows left are dropped)."""
    t = series["time_s"]
    if tol["windows"]:
        spans = [(f"[{w0:g}, {w1:g}] s", w0, w1) for w0, w1 in tol["windows"]]
    else:
        spans = []
        for name in dict.fromkeys(series["phase"]):
            sel = series["phase"] == name
            spans.append((f"phase {name}", float(t[sel].min()), float(t[sel].max())))
    out = []
    for name, w0, w1 in spans:
        w0 = max(w0, t_d if t_d is not None else math.inf)
        if ((t >= w0) & (t <= w1)).sum() >= 4:
            out.append((name, w0, w1))
    return out


def welch(a, b, margin):
    """The one-sided Welch test of |mean(a) - mean(b)| <= margin: (difference, standard error,
    degrees of freedom, shifted t, p-value, agrees, smallest change detected with 80% power)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = float(a.mean() - b.mean())
    va = a.var(ddof=1) / len(a) if len(a) > 1 else 0.0
    vb = b.var(ddof=1) / len(b) if len(b) > 1 else 0.0
    se = math.sqrt(va + vb)
    if se > 0:
        num = (va + vb) ** 2
        den = (va ** 2 / (len(a) - 1) if len(a) > 1 else 0.0) + (vb ** 2 / (len(b) - 1) if len(b) > 1 else 0.0)
        df = num / den if den > 0 else float(len(a) + len(b) - 2)
        t_stat = (abs(d) - margin) / se
        p = float(stats.t.sf(t_stat, df))
        detect = margin + (stats.t.ppf(1 - ALPHA / 2, df) + stats.t.ppf(POWER, df)) * se
    else:
        df, t_stat = math.inf, (math.inf if abs(d) > margin else -math.inf)
        p = 0.0 if abs(d) > margin else 1.0
        detect = margin
    return {"difference": d, "standard_error": se, "df": df, "t": t_stat, "p": p, "agrees": p >= ALPHA,
            "detectable": float(detect)}


def window_checks(t_runs, r_runs, cols, scale, tol, windows):
    out = []
    for name, w0, w1 in windows:
        for c in cols:
            m = tol["window_means"].get(c, tol["window_mean"])
            for stat, f in (("mean", np.mean), ("fluctuation", np.std)):
                vals = []
                for runs in (t_runs, r_runs):
                    v = []
                    for s, _ in runs:
                        sel = (s["time_s"] >= w0) & (s["time_s"] <= w1)
                        v.append(float(f(s[c][sel])) if sel.any() else math.nan)
                    vals.append(v)
                w = welch(vals[0], vals[1], m * scale[c])
                out.append({"kind": f"window {stat}", "name": c, "window": name, "talus": float(np.mean(vals[0])),
                            "reference": float(np.mean(vals[1])), "margin": m, "scale": scale[c],
                            "detectable": w["detectable"] / scale[c], "deviation": abs(w["difference"]) / scale[c],
                            "tolerance": m, "ok": bool(w["agrees"]), **{k: w[k] for k in ("t", "p", "df", "standard_error")}})
    return out


def adjust(checks):
    """Benjamini-Hochberg: each statistical check's q-value (its p-value adjusted for
    the number of checks) and its verdict at a false discovery rate of ALPHA."""
    tested = [c for c in checks if "p" in c]
    if not tested:
        return
    p = np.array([c["p"] for c in tested])
    order = np.argsort(p)
    m = len(p)
    q = np.empty(m)
    q[order] = np.minimum.accumulate((p[order] * m / np.arange(1, m + 1))[::-1])[::-1]
    for c, qi in zip(tested, np.minimum(q, 1.0)):
        c["q"] = float(qi)
        c["ok"] = bool(qi >= ALPHA)


def figure_ensemble_checks(t_runs, r_runs, tol):
    out = []
    keys = [k for k in t_runs[0][1] if k not in tol["ignore"] and all(k in f for _, f in t_runs + r_runs)]
    for k in keys:
        a = [f[k] for _, f in t_runs]
        b = [f[k] for _, f in r_runs]
        ref = abs(float(np.mean(b))) or 1.0
        m = tol["figures"].get(k, tol["figure_rel"])
        w = welch(a, b, m * ref)
        out.append({"kind": "figure", "name": k, "window": "", "talus": float(np.mean(a)), "reference": float(np.mean(b)),
                    "margin": m, "scale": ref, "detectable": w["detectable"] / ref, "deviation": abs(w["difference"]) / ref,
                    "tolerance": m, "ok": bool(w["agrees"]), **{x: w[x] for x in ("t", "p", "df", "standard_error")}})
    return out


def analyse(case, tol, t_runs, r_runs):
    """Every check of one reference: step by step before t_d, statistics after."""
    cols = columns(t_runs, r_runs, tol)
    scale = scales(cols, r_runs)
    tt, tr = divergence_time(t_runs, cols, scale, tol), divergence_time(r_runs, cols, scale, tol)
    t_d = min((x for x in (tt, tr) if x is not None), default=None)
    tk, rk = same_steps(t_runs[0][0], r_runs[0][0], t_d if t_d is not None else math.inf)
    early = C.series_checks(tk, rk, dict(tol, windows=[])) if len(tk["time_s"]) > 1 else []
    for c in early:
        c["window"] = f"before t_d" if t_d is not None else "whole run"
    windows = windows_after(tol, t_runs[0][0], t_d)
    checks = early + window_checks(t_runs, r_runs, cols, scale, tol, windows) + figure_ensemble_checks(t_runs, r_runs, tol)
    adjust(checks)
    return {"divergence_time_s": t_d, "divergence_talus_s": tt, "divergence_reference_s": tr,
            "windows": [{"name": n, "from_s": a, "to_s": b} for n, a, b in windows], "checks": checks}


# ------------------------------------------------------------------ report

def plot_bands(out, name, ensembles, t_d, cols):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (out / "plots").mkdir(parents=True, exist_ok=True)
    paths = {}
    for c in cols:
        fig, ax = plt.subplots(figsize=(5.5, 3.2))
        for label, runs in ensembles.items():
            t = runs[0][0]["time_s"]
            y = np.array([np.interp(t, s["time_s"], s[c]) for s, _ in runs])
            mu, sd = y.mean(0), y.std(0, ddof=1) if len(runs) > 1 else np.zeros_like(t)
            (line,) = ax.plot(t, mu, lw=1, label=f"{label} (mean of {len(runs)})")
            ax.fill_between(t, mu - 2 * sd, mu + 2 * sd, color=line.get_color(), alpha=0.25, lw=0)
        if t_d is not None:
            ax.axvline(t_d, color="k", ls="--", lw=0.8, label="replicas part (t_d)")
        paths[c] = C.save_plot(fig, ax, out, c, f"{name}: {c} (mean +- 2 sigma over replicas)")
    return paths


def report(out, case_path, refs, result):
    lines = [f"# {Path(case_path).name}: talus against {', '.join(refs)}, by ensembles", "",
             f"{result['replicas']} replicas per engine ({result['replicas_differ_by']}); --perturb: "
             f"{', '.join(result['perturb']) or 'none'}.", "",
             "Before t_d (when one engine's replicas part) replica 0 of each engine is compared step by step; after "
             "it, window means and fluctuations and the analysis figures by a one-sided Welch test of "
             "|difference| <= margin, its p-values adjusted together (Benjamini-Hochberg, q) and `differs` where "
             "q < 0.05. `detectable`: the smallest change one test finds with 80% power, as a fraction of the scale.", ""]
    for ref, r in result["references"].items():
        td = r["divergence_time_s"]
        lines += [f"## talus[{C.CONVENTION[ref]}] against {ref}", "",
                  f"t_d = {td if td is not None else 'never (the replicas agree throughout)'} s "
                  f"(talus {r['divergence_talus_s']}, {ref} {r['divergence_reference_s']}); windows: "
                  + (", ".join(f"{w['name']} ({w['from_s']:.4g}-{w['to_s']:.4g} s)" for w in r["windows"]) or "none"), "",
                  "| check | name | window | deviation | margin | detectable | p | q | verdict |", "|---|---|---|---|---|---|---|---|---|"]
        for c in r["checks"]:
            det = f"{c['detectable']:.3g}" if "detectable" in c else "-"
            p = f"{c['p']:.3g}" if "p" in c else "-"
            q = f"{c['q']:.3g}" if "q" in c else "-"
            verdict = ("agrees" if c["kind"] != "series" else "ok") if c["ok"] else "**DIFFERS**"
            lines.append(f"| {c['kind']} | {c['name']} | {c.get('window', '')} | {c['deviation']:.3g} | {c['tolerance']:g} | {det} | {p} | {q} | {verdict} |")
        lines.append("")
    lines += ["## Plots", ""] + [f"![{c}](plots/{c}.png)" for c in result["plotted"]]
    (out / "report.md").write_text("\n".join(lines) + "\n")


def compare(case_path, case, refs, tol, out, k_reps, perturb):
    """The ensemble comparison of `python -m compare CASE.toml`; returns the exit code."""
    runs, how = run_replicas(case_path, case, refs, k_reps, out, perturb)
    result = {"case": str(case_path), "replicas": k_reps, "replicas_differ_by": how, "perturb": list(perturb),
              "tolerances": tol, "references": {}}
    ensembles = {}
    for ref in refs:
        t_runs, r_runs = runs[ref]
        result["references"][ref] = analyse(case, tol, t_runs, r_runs)
        ensembles[f"talus[{C.CONVENTION[ref]}]"] = t_runs
        ensembles[ref] = r_runs
    t_d = min((r["divergence_time_s"] for r in result["references"].values() if r["divergence_time_s"] is not None), default=None)
    cols = columns(*runs[refs[0]], tol)
    result["plotted"] = list(plot_bands(out, Path(case_path).stem, ensembles, t_d, cols))
    failures = [f"talus vs {ref}: {c['kind']} {c['name']} {c.get('window', '')}: deviation {c['deviation']:.3g} (margin {c['tolerance']:g})"
                for ref, r in result["references"].items() for c in r["checks"] if not c["ok"]]
    result["failures"] = failures
    (out / "figures.json").write_text(json.dumps(result, indent=1, default=float) + "\n")
    report(out, case_path, refs, result)
    n = sum(len(r["checks"]) for r in result["references"].values())
    for ref, r in result["references"].items():
        print(f"talus vs {ref}: replicas part at t_d = {r['divergence_time_s']} s; "
              f"{sum(c['ok'] for c in r['checks'])} of {len(r['checks'])} checks agree")
    print(f"{n - len(failures)} of {n} checks within tolerance ({k_reps} replicas per engine); report: {out / 'report.md'}")
    if failures:
        print("DIFFERS:\n  " + "\n  ".join(failures))
        return 1
    return 0
