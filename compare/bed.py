"""Throughput on a dense settled bed: talus against LAMMPS and LIGGGHTS.

`python -m compare throughput bed-20k` (or bed-100k):

1. the bed: talus runs cases/bench/<bed>.toml (a lattice cloud poured into a box of five
   plane walls and settled under gravity) once; its last snapshot becomes
   out/bench/<bed>/bed.csv and bed.data (LAMMPS/LIGGGHTS data file), kept and reused
   while the case's values are unchanged;
2. the window: the same number of steps from that bed in talus (1 and 2 threads), LAMMPS
   (1 process and 2 MPI ranks, lammps_cases/bed.in) and LIGGGHTS (1 process,
   liggghts_cases/bed.in), with the case's walls, contact law, time step, skin and gravity.

Each engine's own timer of the stepping (talus's summary, the `Loop time` line of
LAMMPS and LIGGGHTS) gives particle-steps per second; set-up is excluded in all three.
The peak resident memory and CPU time of each process come from /usr/bin/time.
"""
import hashlib
import json
import math
import os
import subprocess
import tomllib
from pathlib import Path

from . import engines

ROOT = engines.ROOT
# steps timed per bed: tens of seconds per run on this 2-core machine
BEDS = {"bed-20k": 4000, "bed-100k": 2000}
TIME = "/usr/bin/time"


def case_path(bed):
    return ROOT / "cases" / "bench" / f"{bed}.toml"


def read_case(bed):
    with open(case_path(bed), "rb") as f:
        return tomllib.load(f)


def run_measured(cmd, log, cwd=ROOT):
    """Run `cmd` (output to `log`) under /usr/bin/time (Debian package `time`); returns its
    peak resident memory (bytes; under mpirun the largest single process), CPU seconds
    (user + system, summed over the process tree) and wall seconds. (Python's own wait4()
    would report at least the harness's own resident size: a forked child inherits it.)"""
    if not Path(TIME).exists():
        raise engines.EngineError(f"{TIME} is missing: run `bash scripts/install.sh` (Debian package `time`)")
    rep = Path(str(log) + ".time")
    with open(log, "w") as f:
        p = subprocess.run([TIME, "-f", "%M %e %U %S", "-o", rep, *cmd], cwd=cwd, stdout=f, stderr=subprocess.STDOUT)
    if p.returncode != 0:
        tail = Path(log).read_text()[-2000:]
        raise engines.EngineError(f"{' '.join(map(str, cmd))} failed (exit {p.returncode}); log {log}:\n{tail}")
    kib, wall, user, sys_ = rep.read_text().split()[-4:]
    return {"peak_rss_bytes": int(kib) * 1024, "cpu_s": float(user) + float(sys_), "process_wall_s": float(wall)}


def numbers(bed):
    """The numbers every engine is handed, from the talus case file."""
    c = read_case(bed)
    s, k = c["simulation"], c["contact"]
    if k.get("model") != "hooke" or "stiffness" not in k:
        raise ValueError(f"{case_path(bed)}: the bed comparison needs contact.model = \"hooke\" with explicit stiffness")
    mat = c["material"][0]
    planes = {}
    for w in c["wall"]:
        p, n = w["plane"]["point"], w["plane"]["normal"]
        axis = [i for i in range(3) if n[i] != 0.0]
        if len(axis) != 1:
            raise ValueError(f"wall {w['name']}: the bed comparison takes axis-aligned planes only")
        a = axis[0]
        planes["xyz"[a] + ("lo" if n[a] > 0 else "hi")] = p[a]
    if sorted(planes) != ["xhi", "xlo", "yhi", "ylo", "zlo"]:
        raise ValueError(f"{case_path(bed)}: expected a floor and four side walls, got {sorted(planes)}")
    g = s["gravity"]
    return {"dt": s["timestep"], "skin": s["skin"], "gravity": -g[2], "density": mat["density"],
            "mu": mat["friction"], **k["stiffness"], "planes": planes, "domain": s["domain"],
            "settle_time": sum(ph["duration"] for ph in c["phase"])}


def _case_hash(bed):
    """A hash of the case's values (not of its text: a comment changes nothing)."""
    c = read_case(bed)
    c.pop("compare", None)  # the comparisons' tolerances do not change the bed
    return hashlib.sha256(json.dumps(c, sort_keys=True).encode()).hexdigest()


def make_bed(bed, nums):
    """Settle the bed with talus once (cached in out/bench/<bed>/ while the case is
    unchanged); returns (bed.csv, bed.data, bed info)."""
    import h5py
    import numpy as np
    d = ROOT / "out" / "bench" / bed
    meta_path, csv_path, data_path = d / "bed.json", d / "bed.csv", d / "bed.data"
    h = _case_hash(bed)
    if meta_path.exists() and csv_path.exists() and data_path.exists():
        meta = json.loads(meta_path.read_text())
        if meta.get("case_sha256") == h:
            return csv_path, data_path, meta
    d.mkdir(parents=True, exist_ok=True)
    settle = d / "settle"
    snaps = settle / "snapshots.h5"
    stamp = d / "settle.sha256"  # the case the settled run was made from
    if not (snaps.exists() and stamp.exists() and stamp.read_text().strip() == h):
        print(f"{bed}: settling the bed with talus ({case_path(bed).relative_to(ROOT)}), once", flush=True)
        engines._run([engines.TALUS, "run", case_path(bed), "--out", settle, "--quiet"], d / "settle.log")
        stamp.write_text(h + "\n")
    with h5py.File(snaps, "r") as f:
        g = f[sorted(f.keys())[-1]]
        t = float(g.attrs["time_s"])
        ids, pos, rad, vel = g["id"][:], g["position"][:], g["radius"][:], g["velocity"][:]
    if abs(t - nums["settle_time"]) > 1e-9:
        raise engines.EngineError(f"{snaps}: last snapshot at t = {t} s, expected the end of the settling ({nums['settle_time']} s)")
    # positions, radii and velocities to the bit; spins are not carried (every engine starts
    # with zero spin and no tangential history)
    with open(csv_path, "w") as f:
        f.write("id,x,y,z,radius,vx,vy,vz\n")
        for i in range(len(ids)):
            f.write("%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (ids[i], *pos[i], rad[i], *vel[i]))
    pl = nums["planes"]
    top = float((pos[:, 2] + rad).max())
    box = [pl["xlo"] - 0.002, pl["xhi"] + 0.002, pl["ylo"] - 0.002, pl["yhi"] + 0.002, pl["zlo"] - 0.002, top + 0.005]
    engines._run(["python3", ROOT / "liggghts_cases" / "csv_to_data.py", csv_path, data_path,
                  "--density", repr(nums["density"]), "--box", *map(repr, box)], d / "data.log")
    mass = nums["density"] * 4.0 / 3.0 * math.pi * rad ** 3
    # wall contacts: a particle touches a plane it is closer to than its radius
    x, y, z = pos[:, 0], pos[:, 1], pos[:, 2]
    walls = int(((x - pl["xlo"]) < rad).sum() + ((pl["xhi"] - x) < rad).sum() + ((y - pl["ylo"]) < rad).sum()
                + ((pl["yhi"] - y) < rad).sum() + ((z - pl["zlo"]) < rad).sum())
    meta = {"case_sha256": h, "particles": int(len(ids)), "settled_for_s": t, "bed_top_m": top,
            "bed_height_m": top - pl["zlo"], "max_speed_m_s": float(np.linalg.norm(vel, axis=1).max()),
            "mean_mass_kg": float(mass.mean()), "wall_contacts": walls, "box": box}
    meta_path.write_text(json.dumps(meta, indent=1))
    return csv_path, data_path, meta


def _talus_window(bed, csv_path, steps, threads, work):
    out = work / f"talus-t{threads}"
    cmd = [engines.TALUS, "run", case_path(bed), "--out", out, "--quiet", "--threads", str(threads), "--steps", str(steps),
           *engines.sets({"particles": {"material": read_case(bed)["particles"]["material"], "csv": str(csv_path),
                                        "overlap_tolerance": 0.2},
                          "phase": [{"name": "window", "duration": 1.0e3}],
                          "output": {"interval": 0.01}})]
    m = run_measured(cmd, work / f"talus-t{threads}.log")
    summ = json.loads((out / "summary.json").read_text())
    with open(out / "probes.csv") as f:
        f.readline()
        contacts0 = int(f.readline().split(",")[4])
    return summ, contacts0, m


def _from_log(log):
    """Touching pairs at the start and neighbour-list builds of the timed run, from a
    LAMMPS or LIGGGHTS log."""
    pairs, builds = None, None
    for line in Path(log).read_text().splitlines():
        if line.startswith("bed: touching pairs at the start"):
            pairs = int(round(float(line.split()[-1])))
        elif line.startswith("Neighbor list builds ="):
            builds = int(line.split("=")[1])  # the last run's (the timed one) comes last
    return pairs, builds


def lammps_vars(nums, meta, data, steps, style):
    """`-var` arguments of lammps_cases/bed.in. gran/hooke/history multiplies its damping by
    m* = mi mj/(mi+mj) (walls: mi): talus's absolute gamma is matched for two spheres of the
    bed's mean mass (pairs) and for one (walls)."""
    m = meta["mean_mass_kg"]
    pl = nums["planes"]
    v = {"data": data, "steps": steps, "style": style, "dt": nums["dt"], "skin": nums["skin"],
         "kn": nums["kn"], "kt": nums["kt"], "gamma_abs": nums["gamma_n"],
         "xgammat": nums["gamma_t"] / nums["gamma_n"] if nums["gamma_n"] else 0.0,
         "gamman": nums["gamma_n"] / (m / 2), "gammat": nums["gamma_t"] / (m / 2),
         "gamman_wall": nums["gamma_n"] / m, "gammat_wall": nums["gamma_t"] / m,
         "mu": nums["mu"], "density": nums["density"], "xlo": pl["xlo"], "xhi": pl["xhi"],
         "ylo": pl["ylo"], "yhi": pl["yhi"], "floor": pl["zlo"], "gravity": nums["gravity"]}
    return [a for k, x in v.items() for a in ("-var", k, repr(x) if isinstance(x, float) else str(x))]


def _lammps_window(nums, meta, data, steps, ranks, style, work):
    tag = f"lammps-{style}-p{ranks}"
    log = work / f"{tag}.log"
    mpi = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] if ranks > 1 else []
    m = run_measured([*mpi, "lmp", "-in", ROOT / "lammps_cases" / "bed.in", "-log", log, "-screen", "none",
                      *lammps_vars(nums, meta, data, steps, style)], work / f"{tag}.stdout")
    secs, n = engines.liggghts_loop_seconds(log)
    return secs, n, *_from_log(log), m


def _liggghts_window(nums, data, steps, work):
    log = work / "liggghts.log"
    pl = nums["planes"]
    v = {"data": data, "steps": steps, "dt": nums["dt"], "skin": nums["skin"], "kn": nums["kn"], "kt": nums["kt"],
         "gamman_abs": nums["gamma_n"], "gammat_abs": nums["gamma_t"], "mu": nums["mu"], "density": nums["density"],
         "xlo": pl["xlo"], "xhi": pl["xhi"], "ylo": pl["ylo"], "yhi": pl["yhi"], "floor": pl["zlo"],
         "gravity": nums["gravity"]}
    args = [a for k, x in v.items() for a in ("-var", k, repr(x) if isinstance(x, float) else str(x))]
    m = run_measured(["liggghts", "-in", ROOT / "liggghts_cases" / "bed.in", "-log", log, "-screen", "none", *args],
                     work / "liggghts.stdout")
    secs, n = engines.liggghts_loop_seconds(log)
    return secs, n, *_from_log(log), m


def throughput(bed, engs, out, max_steps=None, k=0):
    """Particle-steps per second on the settled bed: talus (1 and 2 threads), LAMMPS
    (gran/hooke/history on 1 process and 2 ranks; pair_style granular, the exact law, on
    1 process), LIGGGHTS (1 process); the same bed, steps, time step and skin in each.
    `k`: the round (compare/rounds.py: odd rounds run them in the reverse order)."""
    from . import rounds
    nums = numbers(bed)
    steps = max_steps or BEDS[bed]
    csv_path, data, meta = make_bed(bed, nums)
    n = meta["particles"]
    work = out
    work.mkdir(parents=True, exist_ok=True)
    load = [os.getloadavg()[0]]
    contacts = {}

    def talus(threads):
        def run():
            summ, contacts["talus"], m = _talus_window(bed, csv_path, steps, threads, work)
            return summ["particle_steps_per_s"], {**m, "loop_s": summ["wall_clock_s"],
                                                  "neighbor_builds": summ["neighbor_builds"]}, None
        return run

    def lammps(style, ranks):
        def run():
            secs, k, p, nb, m = _lammps_window(nums, meta, data, steps, ranks, style, work)
            return n * k / secs, {**m, "loop_s": secs, "neighbor_builds": nb}, p
        return run

    def liggghts():
        secs, k, p, nb, m = _liggghts_window(nums, data, steps, work)
        return n * k / secs, {**m, "loop_s": secs, "neighbor_builds": nb}, p

    jobs = []
    if "talus" in engs:
        jobs += [("talus_1_thread", talus(1)), ("talus_2_threads", talus(2))]
    if "lammps" in engs:
        jobs += [("lammps_1_process", lammps("hooke_history", 1)), ("lammps_2_ranks", lammps("hooke_history", 2)),
                 ("lammps_granular_1_process", lammps("granular", 1))]
    if "liggghts" in engs:
        jobs += [("liggghts_1_process", liggghts)]
    done, ran = rounds.run_jobs(jobs, k)
    rate = {key: v[0] for key, v in done.items()}
    res = {key: v[1] for key, v in done.items()}
    mem = {key: v[1]["peak_rss_bytes"] / n for key, v in done.items() if key.startswith("talus")}
    pairs = {key: v[2] for key, v in done.items() if not key.startswith("talus")}
    talus_contacts = contacts.get("talus")
    load.append(os.getloadavg()[0])
    ratios = {}
    for a, b in (("talus_1_thread", "lammps_1_process"), ("talus_2_threads", "lammps_2_ranks"),
                 ("talus_1_thread", "lammps_granular_1_process"), ("talus_1_thread", "liggghts_1_process"),
                 ("talus_2_threads", "liggghts_1_process")):
        if a in rate and b in rate:
            ratios[f"{a}/{b}"] = rate[a] / rate[b]
    # contention shows as CPU / wall below 1 (the machine is shared); particle-steps per CPU
    # second (whole process, set-up included; under mpirun every rank's CPU, waiting included)
    # is less sensitive to it
    per_cpu = {k: n * steps / res[k]["cpu_s"] for k in rate}
    cpu_ratios = {}
    for key in ratios:
        a, b = key.split("/")
        cpu_ratios[key] = per_cpu[a] / per_cpu[b]
    bed_info = dict(meta)
    if "talus" in engs:
        walls = meta["wall_contacts"]
        bed_info.update({"contacts_at_start_talus": talus_contacts, "pair_contacts": talus_contacts - walls,
                         "contacts_per_particle": (2 * (talus_contacts - walls) + walls) / n,
                         "pair_contacts_per_particle": 2 * (talus_contacts - walls) / n})
    bed_info["pair_contacts_reference"] = pairs
    return {"setup": bed, "particles": n, "steps": steps, "timestep_s": nums["dt"], "skin_m": nums["skin"],
            "contact": {"kn_n_m": nums["kn"], "kt_n_m": nums["kt"], "gamma_n_kg_s": nums["gamma_n"],
                        "gamma_t_kg_s": nums["gamma_t"], "mu": nums["mu"],
                        "lammps_gran_hooke_history_gamma_1_s": {
                            "pairs": nums["gamma_n"] / (meta["mean_mass_kg"] / 2),
                            "walls": nums["gamma_n"] / meta["mean_mass_kg"]}},
            "bed": bed_info, "particle_steps_per_s": rate, "talus_over": ratios,
            "particle_steps_per_cpu_s": per_cpu, "talus_over_per_cpu_s": cpu_ratios,
            "note": "particle_steps_per_s from each engine's own timer of the stepping (talus summary.json "
                    "wall_clock_s, the Loop time of LAMMPS and LIGGGHTS); talus's neighbor_builds count its "
                    "2 builds at set-up, LAMMPS's and LIGGGHTS's those of the timed run only",
            "peak_rss_bytes_per_particle": mem, "runs": res, "load_average_1min_before_after": load, "order": ran}


def print_table(r):
    n = r["particles"]
    print(f"\n{r['setup']}: {n} spheres, {r['steps']} steps of {r['timestep_s']:g} s, skin {r['skin_m']:g} m")
    b = r["bed"]
    if "contacts_per_particle" in b:
        print(f"  bed {b['bed_height_m'] * 1e3:.1f} mm deep; at the start {b['contacts_at_start_talus']} contacts "
              f"({b['pair_contacts']} pairs + {b['wall_contacts']} walls): {b['contacts_per_particle']:.2f} per particle")
    print(f"  {'engine':<28}{'M particle-steps/s':>20}{'per CPU s':>11}{'CPU/wall':>10}{'peak RSS B/particle':>21}{'list builds':>13}")
    for k, v in r["particle_steps_per_s"].items():
        run = r["runs"][k]
        print(f"  {k:<28}{v / 1e6:>20.3f}{r['particle_steps_per_cpu_s'][k] / 1e6:>11.3f}"
              f"{run['cpu_s'] / run['process_wall_s']:>10.2f}{run['peak_rss_bytes'] / n:>21.0f}{run.get('neighbor_builds', '-'):>13}")
    print(f"  {'ratio':<50}{'wall':>8}{'per CPU s':>11}")
    for k, v in r["talus_over"].items():
        print(f"  {k:<50}{v:>8.2f}{r['talus_over_per_cpu_s'][k]:>11.2f}")
