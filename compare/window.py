"""python -m compare window [--steps N] [--checkpoint CK] [--out DIR] [--repeat N]

H1-paper discharge throughput over a window of N steps (default 8,000) from the
end-of-fill checkpoint, in one invocation on one machine:

- talus, the first `--fill-steps` (2,000) steps of the fill on 1 thread: the reference
  the discharge is measured against;
- talus, the discharge window from the checkpoint on 1 thread, 2 threads, and 2 MPI
  ranks x 1 thread;
- LIGGGHTS 3.8 (1 process) on the same window: the checkpoint's particles (positions,
  radii, velocities; `talus cloud --restart`) as a data file, the gate absent, the same
  meshes, material, Hertz law, time step, skin and gravity (liggghts_cases/H1-window.in);
  its `Loop time` is the figure.

Writes DIR/window.json and prints a table: particle-steps/s of each run, the ratios
discharge/fill, talus/LIGGGHTS, 2 threads/1 thread, 2 ranks/1 thread, and the seconds of
each stage of talus's 1-thread window. Without --checkpoint the fill is run (the case
unchanged, all cores) until its end-of-fill checkpoint is written, then stopped; the
checkpoint is kept in DIR/fill and reused. The talus binary is $TALUS_BIN, or
target/release/talus.

What differs between the two windows: LIGGGHTS starts without contact history and with
zero angular velocities (the CSV has neither; enough for a throughput figure); talus runs
the case as it is (the checkpoint carries the case's hash), so it writes the case's probe
rows and HDF5 snapshots inside its timed loop, and keeps the case's `convention = "talus"`
friction cap (mu times the elastic normal force; LIGGGHTS caps with the dashpot included).
Both rebuild their lists with the same skin (the builds are reported). The mass below the
gate plane at a time both engines have is reported as a check that the windows agree.
"""
import argparse
import csv
import json
import os
import re
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

from . import engines

TALUS = Path(os.environ.get("TALUS_BIN") or engines.TALUS)
ROOT = engines.ROOT
DECK = ROOT / "liggghts_cases" / "H1-window.in"
MPI = ["mpirun", "--allow-run-as-root", "--oversubscribe"]
# the thresholds (issue 11, part 6)
TARGETS = {"discharge_over_fill": 0.7, "talus_over_liggghts": 2.0,
           "two_threads_over_one": 1.85, "two_ranks_over_one": 1.85}


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _timed(cmd, log, cwd=ROOT):
    """Run cmd (output to log); the machine's load and the CPU seconds the run got."""
    load0, cpu0, t0 = os.getloadavg()[0], _children_cpu(), time.perf_counter()
    engines._run([str(c) for c in cmd], log, cwd=cwd)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0
    return {"process_wall_s": wall, "process_cpu_s": cpu, "load_1min_before": load0,
            "load_1min_after": os.getloadavg()[0]}


def make_checkpoint(case, out):
    """Run the fill of `case` (unchanged: the checkpoint carries the case's hash) until
    talus writes checkpoint_after_fill.bin, then stop it with SIGTERM."""
    ck = out / "checkpoint_after_fill.bin"
    if ck.exists():
        return ck
    out.mkdir(parents=True, exist_ok=True)
    print(f"window: running the fill of {case.name} to its end-of-fill checkpoint (H1-paper: about 10 minutes on 2 idle cores)", flush=True)
    with open(out.parent / "fill.log", "w") as log:
        p = subprocess.Popen([str(TALUS), "run", str(case), "--out", str(out), "--quiet"], cwd=ROOT,
                             stdout=log, stderr=subprocess.STDOUT)
        try:
            while p.poll() is None and not ck.exists():  # written to .partial, renamed when whole
                time.sleep(2.0)
        finally:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)  # talus stops after the step, writes its outputs
                p.wait()
    if not ck.exists():
        raise engines.EngineError(f"the fill ended (exit {p.returncode}) without {ck}; log {out.parent / 'fill.log'}")
    return ck


def _talus(case, out, steps, threads=1, ranks=1, restart=None, reuse=False):
    """One talus run; its summary.json plus the process's wall, CPU and the load."""
    summ = out / "summary.json"
    meta = out.parent / f"{out.name}.timing.json"
    if reuse and summ.exists() and meta.exists():
        print(f"window: {out.name}: kept", flush=True)
        return json.loads(summ.read_text()), json.loads(meta.read_text())
    print(f"window: {out.name}: {steps} steps, {ranks} rank(s) x {threads} thread(s)", flush=True)
    cmd = [TALUS, "run", case, "--out", out, "--steps", str(steps), "--threads", str(threads), "--quiet"]
    if restart:
        cmd += ["--restart", restart]
    if ranks > 1:
        cmd = [*MPI, "-n", str(ranks), *cmd]
    t = _timed(cmd, out.parent / f"{out.name}.log")
    s = json.loads(summ.read_text())
    t["particle_steps_per_cpu_s"] = s["particles"] * s["steps_this_run"] / t["process_cpu_s"] if t["process_cpu_s"] else 0.0
    meta.write_text(json.dumps(t, indent=1))
    return json.loads(summ.read_text()), t


def _mass_series(probes, t0):
    """(time since the window's start, mass below the gate plane) of each probe row."""
    with open(probes) as f:
        return [(float(r["time_s"]) - t0, float(r["mass_below_kg"])) for r in csv.DictReader(f)]


def _mass_at(series, t):
    """The mass below at time t of the window, linear between probe rows."""
    for (t0, m0), (t1, m1) in zip(series, series[1:]):
        if t0 <= t <= t1:
            return m0 + (m1 - m0) * (t - t0) / (t1 - t0) if t1 > t0 else m1
    return None


def _liggghts(case, ck, out, steps, dt, reuse=False):
    """LIGGGHTS on the same window from the checkpoint's particles (positions, radii,
    velocities); returns its figures and the timing."""
    out.mkdir(parents=True, exist_ok=True)
    c = engines.read_case(case.stem)
    mat = c["material"][0]
    stl = {w["name"]: (case.parent / w["stl"]).resolve() for w in c["wall"] if "stl" in w}
    g = c["simulation"]["gravity"]
    if g[0] != 0.0 or g[1] != 0.0 or g[2] >= 0.0:
        raise engines.EngineError("the window deck takes gravity along -z")
    log, probes, meta = out / "window.log", out / "probes.csv", out / "timing.json"
    if not (reuse and log.exists() and meta.exists()):
        cloud, data = out / "fill_end.csv", out / "fill_end.data"
        engines._run([str(TALUS), "cloud", str(case), "--restart", str(ck), "--out", str(cloud)], out / "cloud.log")
        lo, hi = c["simulation"]["domain"]["lo"], c["simulation"]["domain"]["hi"]
        engines._run(["python3", str(ROOT / "liggghts_cases" / "csv_to_data.py"), str(cloud), str(data),
                      "--density", repr(mat["density"]),
                      "--box", *(repr(float(v)) for v in (lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]))],
                     out / "data.log")
        print(f"window: liggghts: {steps} steps, 1 process", flush=True)
        var = {"cloud": data, "out": probes, "hopper_stl": stl["hopper"], "box_stl": stl["box"],
               "gate_z": repr(float(c["output"].get("mass_below_z", 0.0))), "steps": steps, "dt": repr(dt),
               "skin": repr(c["simulation"]["skin"]), "youngs": repr(mat["youngs_modulus"]),
               "poisson": repr(mat["poisson_ratio"]), "density": repr(mat["density"]),
               "restitution": repr(mat["restitution"]), "friction": repr(mat["friction"]),
               "gravity": repr(-float(g[2])), "interval": repr(c["output"]["interval"])}
        cmd = ["liggghts", "-in", DECK, "-log", log]
        for k, v in var.items():
            cmd += ["-var", k, str(v)]
        meta.write_text(json.dumps(_timed(cmd, out / "liggghts.stdout"), indent=1))
    else:
        print("window: liggghts: kept", flush=True)
    secs, lsteps = engines.liggghts_loop_seconds(log)
    if lsteps != steps:
        raise engines.EngineError(f"LIGGGHTS ran {lsteps} steps, not {steps}; log {log}")
    n = sum(1 for _ in open(out / "fill_end.csv")) - 1
    meta_d = json.loads(meta.read_text())
    meta_d["particle_steps_per_cpu_s"] = n * lsteps / meta_d["process_cpu_s"]
    builds = [int(m) for m in re.findall(r"Neighbor list builds = (\d+)", log.read_text())]
    return {"particles": n, "steps": lsteps, "loop_s": secs, "particle_steps_per_s": n * lsteps / secs,
            "neighbor_builds": builds[-1] if builds else None,
            "stage_seconds": _liggghts_stages(log), **meta_d}, _mass_series(probes, 0.0)


def _liggghts_stages(log):
    """The window run's breakdown: seconds in Pair, Neigh, Comm, Outpt, Other (LIGGGHTS's
    Modify time, the mesh walls and integration, is in Other in 3.8)."""
    st = {}
    for line in log.read_text().splitlines():
        m = re.match(r"(\w+)\s+time \(%\) = ([0-9.eE+-]+)", line)
        if m:
            st[m.group(1).lower()] = float(m.group(2))
    return st


def _row(summ, timing, builds0=0):
    r = {k: summ[k] for k in ("particles", "steps_this_run", "ranks", "threads", "wall_clock_s",
                              "particle_steps_per_s", "timestep_s", "state_hash")}
    r["neighbor_builds"] = summ["neighbor_builds"] - builds0
    r.update(timing)
    return r


def _talus_mass_series(out, summ):
    t0 = summ["time_s"] - summ["steps_this_run"] * summ["timestep_s"]
    return _mass_series(out / "probes.csv", t0)


def window(case, out, steps, fill_steps, checkpoint=None, liggghts=True, reuse=False, k=0):
    """One round of the window's runs (compare/rounds.py: round k runs them backward if k is odd)."""
    from . import rounds
    ck = Path(checkpoint).resolve() if checkpoint else make_checkpoint(case, out / "fill")
    res = {"case": str(case.relative_to(ROOT)) if case.is_relative_to(ROOT) else str(case),
           "checkpoint": str(ck), "talus": str(TALUS), "window_steps": steps, "fill_steps": fill_steps,
           "cores": os.cpu_count(), "runs": {}}
    # the neighbour builds the checkpoint has counted (summary.json counts from the run's start)
    s0, _ = _talus(case, out / "window-start", 0, threads=1, restart=ck, reuse=reuse)
    builds0, dt = s0["neighbor_builds"], s0["timestep_s"]
    series, one_thread = {}, {}

    def fill():
        s, t = _talus(case, out / "fill-first", fill_steps, threads=1, reuse=reuse)
        return _row(s, t)

    def talus_window(tag, threads, ranks=1):
        def run():
            s, t = _talus(case, out / tag, steps, threads=threads, ranks=ranks, restart=ck, reuse=reuse)
            if threads == 1 and ranks == 1:
                series["talus_window_1_thread"] = _talus_mass_series(out / tag, s)
                one_thread["summary"] = s
            return _row(s, t, builds0)
        return run

    def liggghts_window():
        row, series["liggghts_window_1_process"] = _liggghts(case, ck, out / "liggghts", steps, dt, reuse)
        return row

    jobs = [("talus_fill_1_thread", fill), ("talus_window_1_thread", talus_window("window-t1", 1)),
            ("talus_window_2_threads", talus_window("window-t2", 2)),
            ("talus_window_2_ranks", talus_window("window-p2", 1, ranks=2))]
    if liggghts:
        jobs.append(("liggghts_window_1_process", liggghts_window))
    runs, res["order"] = rounds.run_jobs(jobs, k)
    res["runs"] = runs
    s1 = one_thread["summary"]
    res["stage_seconds_window_1_thread"] = s1["stage_seconds"]
    res["window_start_step"] = s1["steps"] - s1["steps_this_run"]
    # the same physics on the same window: mass below the gate plane at a time both have
    series = {k: v for k, v in series.items() if len(v) > 1}
    if series:
        t_c = min(v[-1][0] for v in series.values())
        res["mass_below_kg"] = {"window_time_s": t_c, **{k: _mass_at(v, t_c) for k, v in series.items()}}
    ps = {k: v["particle_steps_per_s"] for k, v in runs.items()}
    one = ps["talus_window_1_thread"]
    ratios = {"discharge_over_fill": one / ps["talus_fill_1_thread"],
              "two_threads_over_one": ps["talus_window_2_threads"] / one,
              "two_ranks_over_one": ps["talus_window_2_ranks"] / one}
    if liggghts:
        ratios["talus_over_liggghts"] = one / ps["liggghts_window_1_process"]
    res["particle_steps_per_s"] = ps
    res["ratios"] = ratios
    res["targets"] = targets(ratios)
    hashes = {runs[k]["state_hash"] for k in ("talus_window_1_thread", "talus_window_2_threads", "talus_window_2_ranks")}
    res["talus_windows_same_state"] = len(hashes) == 1
    return res


def targets(ratios):
    return {k: {"at_least": v, "met": ratios[k] >= v} for k, v in TARGETS.items() if k in ratios}


def print_table(r):
    runs = r["runs"]
    names = {"talus_fill_1_thread": f"talus fill, first {r['fill_steps']} steps, 1 thread",
             "talus_window_1_thread": "talus window, 1 thread",
             "talus_window_2_threads": "talus window, 2 threads",
             "talus_window_2_ranks": "talus window, 2 ranks x 1 thread",
             "liggghts_window_1_process": "LIGGGHTS window, 1 process (loop time)"}
    print(f"\n{r['case']}: discharge window of {r['window_steps']} steps from step {r.get('window_start_step', '?')} "
          f"(end of fill), {runs['talus_window_1_thread']['particles']} particles, {r['cores']} cores")
    print(f"{'run':<42}{'M p-steps/s':>12}{'seconds':>10}{'list builds':>12}{'CPU/wall':>10}{'per CPU s':>10}{'load 1 min':>12}")
    for k, v in runs.items():
        secs = v.get("wall_clock_s", v.get("loop_s"))
        load = f"{v['load_1min_before']:.1f}-{v['load_1min_after']:.1f}"
        print(f"{names[k]:<42}{v['particle_steps_per_s'] / 1e6:>12.3f}{secs:>10.1f}{v['neighbor_builds']:>12}"
              f"{v['process_cpu_s'] / v['process_wall_s']:>10.2f}{v['particle_steps_per_cpu_s'] / 1e6:>10.3f}{load:>12}")
    print("(M p-steps/s: the engine's own time of its steps; CPU/wall: CPU seconds the whole process got over its"
          "\n wall time, below 1 per thread when the machine is shared; per CPU s: M particle-steps per CPU second of"
          "\n the whole process, set-up included)")
    print()
    for k, v in r["ratios"].items():
        t = r["targets"].get(k)
        tgt = f"(issue: >= {t['at_least']}: {'met' if t['met'] else 'NOT met'})" if t else ""
        print(f"  {k:<24}{v:>8.3f}  {tgt}")
    st = r["stage_seconds_window_1_thread"]
    print("\n  talus 1-thread window, seconds per stage: " + ", ".join(f"{k} {v:.1f}" for k, v in st.items()))
    lg = runs.get("liggghts_window_1_process")
    if lg:
        print("  LIGGGHTS window, seconds per stage: " + ", ".join(f"{k} {v:.1f}" for k, v in lg["stage_seconds"].items()))
    print(f"  talus windows (1 thread, 2 threads, 2 ranks) end in the same state: {r['talus_windows_same_state']}")
    mb = r.get("mass_below_kg", {"window_time_s": 0.0})
    print(f"  mass below the gate plane {mb['window_time_s']:.4f} s into the window: "
          + ", ".join(f"{names[k].split(',')[0]} {v:.4f} kg" for k, v in mb.items() if k != "window_time_s" and v is not None))


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m compare window", description="H1-paper discharge throughput from the end-of-fill checkpoint: talus and LIGGGHTS on the same window")
    ap.add_argument("--case", default="H1-paper", help="a case with a fill phase ending in a gate removal (default H1-paper)")
    ap.add_argument("--steps", type=int, default=8000, help="steps of the discharge window (default 8000)")
    ap.add_argument("--fill-steps", type=int, default=2000, help="steps of the fill reference (default 2000)")
    ap.add_argument("--checkpoint", type=Path, help="the end-of-fill checkpoint (default: made, and kept, in OUT/fill)")
    ap.add_argument("--engines", default="talus,liggghts", help="talus,liggghts (talus is always run)")
    ap.add_argument("--out", type=Path, help="default out/compare/window-CASE")
    ap.add_argument("--reuse", action="store_true", help="keep runs already finished in OUT (their figures are reused)")
    ap.add_argument("--repeat", type=int, default=1, metavar="N",
                    help="N rounds of the runs, their order alternating (forward, backward, ...); each ratio's median "
                         "over the rounds (compare/rounds.py)")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error(f"--repeat {a.repeat}: a number of rounds of at least 1")
    if a.repeat > 1 and a.reuse:
        ap.error("--repeat with --reuse: every round would reuse the same runs")
    engs = {e.strip() for e in a.engines.split(",") if e.strip()}
    if engs - {"talus", "liggghts"}:
        ap.error(f"--engines: unknown {sorted(engs - {'talus', 'liggghts'})} (talus, liggghts)")
    case = engines.case_path(a.case)
    if not case.exists():
        ap.error(f"no case {case}")
    if not TALUS.exists():
        print(f"compare: talus is not built: {TALUS} is missing (run `cargo build --release` or set TALUS_BIN)", file=sys.stderr)
        return 2
    if a.checkpoint and not a.checkpoint.exists():
        ap.error(f"--checkpoint: no file {a.checkpoint}")
    try:
        if "liggghts" in engs:
            engines.check_versions(["liggghts"])
        out = (a.out or Path("out") / "compare" / f"window-{a.case}").resolve()
        out.mkdir(parents=True, exist_ok=True)
        each = []
        for k in range(a.repeat):
            r = window(case, out, a.steps, a.fill_steps, a.checkpoint, "liggghts" in engs, a.reuse, k=k)
            print_table(r)
            if a.repeat > 1:
                print(f"(round {k + 1} of {a.repeat}, order: {', '.join(r['order'])})")
                (out / f"window-round-{k + 1}.json").write_text(json.dumps(r, indent=1))
                # the end-of-fill checkpoint made in round 1 serves the others
                a.checkpoint = a.checkpoint or Path(r["checkpoint"])
            each.append(r)
    except (engines.EngineError, ValueError, KeyError) as err:
        print(f"compare: {err}", file=sys.stderr)
        return 2
    if a.repeat > 1:
        from . import rounds
        r = {"case": each[0]["case"], "window_steps": a.steps, "fill_steps": a.fill_steps,
             **rounds.summarise([{"particle_steps_per_s": x["particle_steps_per_s"], "talus_over": x["ratios"],
                                  "order": x["order"]} for x in each])}
        r["targets"] = targets(r["talus_over_median"])
        rounds.print_summary(r)
        for k, t in r["targets"].items():
            print(f"  {k:<24} median {r['talus_over_median'][k]:.3f}  (issue: >= {t['at_least']}: "
                  f"{'met' if t['met'] else 'NOT met'})")
    (out / "window.json").write_text(json.dumps(r, indent=1))
    print(f"\nwritten: {out / 'window.json'}")
    return 0
