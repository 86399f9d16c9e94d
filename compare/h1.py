"""H1 comparisons: discharge rate, end-of-fill wall loads, Beverloo; and throughput."""
import csv
import json
import math

import numpy as np

from . import engines, figures, tolerances


def _case_numbers(setup):
    c = engines.read_case(setup)
    lat = c["particles"]["lattice"]
    return {"r_min": lat["radius_min"], "r_max": lat["radius_max"], "skin": c["simulation"]["skin"],
            "discharge": c["phase"][-1]["duration"], "density": c["material"][0]["density"]}


def read_probes(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def series(rows, key, sign=1.0):
    return np.array([sign * float(r[key]) for r in rows])


def h1_figures(rows, fill_end_time, total_mass):
    t = series(rows, "time_s")
    m = series(rows, "mass_below_kg")
    sel = t >= fill_end_time - 1e-9
    return {"discharge_rate_kg_s": figures.discharge_rate(t[sel] - fill_end_time, m[sel], total_mass)}


def _reference_figures(rows, fill_end_csv, fill_end, mass):
    g = h1_figures(rows, fill_end, mass)
    fe = next(csv.DictReader(open(fill_end_csv)))
    g.update({"fill_end_wall_force_z_n": -float(fe["hopper_force_z_n"]),
              "fill_end_gate_force_z_n": -float(fe["gate_force_z_n"])})
    return g


def _run_talus(setup, convention, work, result, series_out, reuse=False):
    """Run talus in a convention; record its figures and series as `talus[convention]`."""
    probes, summ = engines.run_talus_h1(setup, convention, work, reuse=reuse)
    rows = read_probes(probes)
    f = h1_figures(rows, summ["fill_end_time_s"], summ["total_mass_kg"])
    f.update({"fill_end_wall_force_z_n": summ["fill_end_wall_force_z_n"],
              "fill_end_gate_force_z_n": summ["fill_end_gate_force_z_n"]})
    name = f"talus[{convention}]"
    result["engines"][name] = f
    series_out[name] = rows
    result["total_weight_n"] = summ["total_weight_n"]
    return summ


def compare_h1(setup, engs, out, resume=False):
    """talus in each reference's convention against that reference, all from the same cloud.
    The reference runs fill for as long as talus's fill did (its kinetic-energy rule).
    With `resume`, finished talus and LIGGGHTS runs in `out` are reused, and YADE
    checkpoints itself and continues an unfinished run in `out`/yade (engines.run_yade_h1)."""
    nums = _case_numbers(setup)
    result = {"setup": setup, "engines": {}, "pairs": [], "failures": []}
    series_out = {}
    for ref in ("liggghts", "yade"):
        if ref not in engs:
            continue
        tname = f"talus[{ref}]"
        summ = _run_talus(setup, ref, out / f"talus-{ref}", result, series_out, reuse=resume)
        mass, fill_end = summ["total_mass_kg"], summ["fill_end_time_s"]
        if ref == "liggghts":
            rp, rf, _ = engines.run_liggghts_h1(setup, out / ref, fill_end, nums["discharge"], summ["timestep_s"], nums["skin"],
                                                reuse=resume)
        else:
            rp, rf, _ = engines.run_yade_h1(setup, out / ref, fill_end, nums["discharge"], summ["timestep_s"], nums["skin"],
                                            resume=resume)
        rows_r = read_probes(rp)
        result["engines"][ref] = _reference_figures(rows_r, rf, fill_end, mass)
        series_out[ref] = rows_r
        result["pairs"].append((tname, ref))
    if not result["pairs"]:
        if "talus" not in engs:
            raise engines.EngineError("H1 needs talus among the engines")
        _run_talus(setup, "talus", out / "talus", result, series_out, reuse=resume)
    weight = result["total_weight_n"]
    d = nums["r_min"] + nums["r_max"]  # mean diameter
    rho_b = tolerances.BULK_FRACTION * nums["density"]
    bev = figures.beverloo(rho_b, 0.04, d, tolerances.BEVERLOO_C, tolerances.BEVERLOO_K)
    result["beverloo_kg_s"] = bev
    for name, g in result["engines"].items():
        g["force_balance"] = (g["fill_end_wall_force_z_n"] + g["fill_end_gate_force_z_n"]) / weight
        g["wall_share"] = g["fill_end_wall_force_z_n"] / weight
        g["rate_over_beverloo"] = g["discharge_rate_kg_s"] / bev if g["discharge_rate_kg_s"] else None
        if abs(g["force_balance"] - 1.0) > tolerances.H1_BALANCE:
            result["failures"].append(f"{name}: walls + gate = {g['force_balance']:.4f} of the weight")
    for tname, ref in result["pairs"]:
        t, g = result["engines"][tname], result["engines"][ref]
        dr = t["discharge_rate_kg_s"] / g["discharge_rate_kg_s"] - 1.0
        if abs(dr) > tolerances.H1_DISCHARGE_RATE_REL:
            result["failures"].append(f"discharge rate: {tname} differs from {ref} by {100 * dr:.1f}%")
        ds = t["wall_share"] - g["wall_share"]
        if abs(ds) > tolerances.H1_FORCE_SPLIT_OF_WEIGHT:
            result["failures"].append(f"wall share of the weight: {tname} {t['wall_share']:.3f}, {ref} {g['wall_share']:.3f}")
    if "liggghts" in result["engines"] and "yade" in result["engines"]:
        a, b = result["engines"]["liggghts"], result["engines"]["yade"]
        result["references_disagree"] = {
            "discharge_rate_rel": b["discharge_rate_kg_s"] / a["discharge_rate_kg_s"] - 1.0,
            "wall_share_diff": b["wall_share"] - a["wall_share"],
            "why": "YADE's Mindlin damping from Thornton's fit is stronger than LIGGGHTS's for the same e, "
                   "YADE clips the normal force, and YADE facets double-count spheres on shared coplanar edges "
                   "(seen: up to 17 of ~13,700 contacts); talus in each code's convention follows each.",
        }
    return result, series_out


def plot_h1(out, setup, result, series_out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    for name, rows in series_out.items():
        t = series(rows, "time_s")
        a1.plot(t, series(rows, "mass_below_kg"), label=name)
        a2.plot(t, series(rows, "hopper_force_z_n", -1), label=f"{name} hopper walls")
        a2.plot(t, series(rows, "gate_force_z_n", -1), "--", label=f"{name} gate")
    a1.set_ylabel("discharged mass (kg)")
    a2.set_ylabel("vertical load (N, downward)")
    a2.set_xlabel("time (s)")
    a1.legend(fontsize=8)
    a2.legend(fontsize=7)
    a1.set_title(f"{setup}: Beverloo {result['beverloo_kg_s']:.3f} kg/s")
    fig.tight_layout()
    png = out / f"{setup}.png"
    fig.savefig(png, dpi=100)
    names = list(result["engines"])
    keys = list(next(iter(result["engines"].values())).keys())
    lines = [f"# {setup}", "", "talus runs in each reference's convention (talus[liggghts], talus[yade]); all engines start from the same cloud file and meshes.",
             f"Beverloo: W = C rho_b sqrt(g) (D - k d)^2.5, C = {tolerances.BEVERLOO_C}, k = {tolerances.BEVERLOO_K}, "
             f"rho_b = {tolerances.BULK_FRACTION} rho, D = 40 mm (square side), d = mean diameter: "
             f"{result['beverloo_kg_s']:.4f} kg/s.", "",
             "| figure | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for k in keys:
        lines.append(f"| {k} | " + " | ".join(f"{result['engines'][n][k]:.5g}" if result['engines'][n][k] is not None else "-" for n in names) + " |")
    if "references_disagree" in result:
        rd = result["references_disagree"]
        lines += ["", f"LIGGGHTS and YADE differ: discharge rate {100 * rd['discharge_rate_rel']:+.1f}%, wall share {rd['wall_share_diff']:+.3f} of the weight. Why: {rd['why']}"]
    lines += ["", "## Result", "", "all within tolerance" if not result["failures"] else "\n".join(f"- {x}" for x in result["failures"]),
              "", f"![{setup}]({png.name})", ""]
    (out / "report.md").write_text("\n".join(lines))
    (out / "figures.json").write_text(json.dumps(result, indent=1))


def throughput(setup, engs, out, max_steps=None, k=0, first=None):
    """Particle-steps per second of each engine on the same case, N, time step and steps.
    With `max_steps`, every engine runs only the first steps of the fill. `k`: the round
    (compare/rounds.py: odd rounds run the engines in the reverse order); `first`: talus's
    one-thread summary of an earlier round, which gives LIGGGHTS and YADE the fill's end
    when they run before talus (talus is deterministic: every round's fill ends alike).
    Returns the figures and that summary."""
    from . import rounds
    nums = _case_numbers(setup)
    known = {"summary": first}

    def talus_1():
        # one process on one core each (talus: one thread), as the reference codes run
        _, summ = engines.run_talus_h1(setup, "liggghts", out / "talus", max_steps, threads=1)
        known["summary"] = summ
        return summ["particle_steps_per_s"]

    def phases():
        summ = known["summary"]
        if summ is None:
            raise ValueError("throughput: LIGGGHTS or YADE before talus, without talus's summary of an earlier round")
        n, steps = summ["particles"], summ["steps"]
        if max_steps:
            return n, steps, summ["timestep_s"], steps * summ["timestep_s"], 0.0
        return n, steps, summ["timestep_s"], summ["fill_end_time_s"], nums["discharge"]

    def liggghts():
        n, _, dt, fill, discharge = phases()
        _, _, log = engines.run_liggghts_h1(setup, out / "liggghts", fill, discharge, dt, nums["skin"])
        secs, lsteps = engines.liggghts_loop_seconds(log)
        return n * lsteps / secs

    def yade():
        # whole-process wall time (includes YADE's start-up and the per-interval probes)
        n, steps, dt, fill, discharge = phases()
        _, _, secs = engines.run_yade_h1(setup, out / "yade", fill, discharge, dt, nums["skin"])
        return n * steps / secs

    def talus_on(ranks=1, threads=None):
        # talus on 2 MPI ranks or 2 threads (this machine has 2 cores): same case, steps and cloud
        return lambda: engines.run_talus_h1(setup, "liggghts", out / "talus", max_steps, ranks=ranks,
                                            threads=threads)[1]["particle_steps_per_s"]

    jobs = [("talus", talus_1)]
    jobs += [(e, f) for e, f in (("liggghts", liggghts), ("yade", yade)) if e in engs]
    jobs += [("talus_2_ranks", talus_on(ranks=2)), ("talus_2_threads", talus_on(threads=2))]
    res, ran = rounds.run_jobs(jobs, k)
    n, steps = known["summary"]["particles"], known["summary"]["steps"]
    ratios = {k: res["talus"] / v for k, v in res.items() if k not in ("talus", "talus_2_ranks", "talus_2_threads")}
    ratios["talus_2_threads/talus"] = res["talus_2_threads"] / res["talus"]
    ratios.update({f"talus_2_ranks/{k}": res["talus_2_ranks"] / v for k, v in res.items() if k != "talus_2_ranks"})
    return {"setup": setup, "particles": n, "steps": steps, "particle_steps_per_s": res, "talus_over": ratios,
            "order": ran}, known["summary"]
