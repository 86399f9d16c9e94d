"""A/B benchmarks: this tree's talus against a baseline commit, alternated in one run.

    python3 -m compare ab --baseline REV [--workloads bed-20k,bed-20k-hooke,H1-small,H1-paper-window]
                          [--repeat N] [--threads T] [--steps N] [--out DIR]

A figure measured on another day means nothing on this machine (its speed moves by
10-50% from day to day, and not by the same amount for every binary). So a
performance change is judged against the build before it, in the same run:

1. the baseline: REV is checked out in a git worktree and built (`cargo build
   --release`); the binary is kept in out/ab/bin/<commit>/ and reused while that
   commit is the baseline. The current binary is this tree's, built first;
2. each workload's starting state: every binary makes its own (a bed settled from its
   lattice cloud, H1-paper's fill), kept in out/ab/state/<binary hash>/ and reused;
3. the rounds: each round runs the baseline and the current binary once per workload,
   the order alternating between rounds (A B, then B A, ...: ABBA), so a drift of the
   machine falls on both sides alike;
4. the figure: per workload, the median over the rounds of the ratio current /
   baseline of particle-steps per second measured within one round, with its range,
   and both binaries' time by stage of the step (the medians; where a binary reports it).

The workloads (each binary reads the same generated case file, written into
out/ab/cases/ in the form every talus since the first MPI release reads):

- bed-20k: 20,000 Hertz spheres (radii 0.975-1.175 mm, E 1 MPa, nu 0.3, e 0.5,
  mu 0.4) settled for 0.6 s in a closed box of six planes, then 3,000 steps; time
  step 20% of the smallest sphere's Rayleigh time; skin 1 mm;
- bed-20k-hooke: the same with cases/bench/bed-20k.toml's linear spring-dashpot
  (kn = kt = 200 N/m, gamma 0.016 kg/s, the LAMMPS `gran/hooke/history` bed);
- bed-100k, bed-100k-hooke: the same with 100,000 spheres, 1,000 steps;
- H1-small: the whole case (fill and discharge) from the lattice cloud;
- H1-paper-window: H1-paper's discharge, 2,000 steps from the end of each binary's
  own fill.

A baseline older than the thread pool runs on one thread whatever --threads says
(the report says so).
"""
import argparse
import functools
import hashlib
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from . import engines

ROOT = engines.ROOT
DEFAULT_WORKLOADS = ["bed-20k", "bed-20k-hooke", "H1-small", "H1-paper-window"]


class AbError(RuntimeError):
    pass


# ---------------------------------------------------------------- case files

def toml_text(case):
    """A case as TOML text: a dict of sections (dicts) and arrays of tables (lists of dicts)."""
    lines = []
    for name, sec in case.items():
        rows = sec if isinstance(sec, list) else [sec]
        for row in rows:
            lines.append(f"[[{name}]]" if isinstance(sec, list) else f"[{name}]")
            lines += [f"{k} = {engines.toml_value(v)}" for k, v in row.items()]
            lines.append("")
    return "\n".join(lines)


def rayleigh_time(r, e, nu, rho):
    """The Rayleigh time of a sphere (s): pi r sqrt(rho / G) / (0.1631 nu + 0.8766)."""
    g = e / (2.0 * (1.0 + nu))
    return math.pi * r * math.sqrt(rho / g) / (0.1631 * nu + 0.8766)


def bed_case(count, hooke):
    """A settled-bed workload's case: a lattice cloud poured into a closed box of six
    planes; the phase is long, the runs are cut by --steps. Returns (case, settle steps)."""
    mat = {"name": "seed-soft", "youngs_modulus": 1.0e6, "poisson_ratio": 0.3, "density": 2500.0,
           "restitution": 0.5, "friction": 0.4}
    side = 0.025 * math.sqrt(count / 20000.0)  # the same depth for 100,000 spheres
    if hooke:
        rmin, rmax, skin = 0.0010, 0.0012, 0.0002
        dt = 2.0e-5
        contact = {"model": "hooke", "convention": "liggghts",
                   "stiffness": {"kn": 200.0, "kt": 200.0, "gamma_n": 0.016, "gamma_t": 0.016}}
    else:
        rmin, rmax, skin = 0.000975, 0.001175, 0.001
        dt = 0.2 * rayleigh_time(rmin, mat["youngs_modulus"], mat["poisson_ratio"], mat["density"])
        contact = {"model": "hertz", "convention": "talus"}
    top = 0.17
    planes = [("floor", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), ("lid", [0.0, 0.0, top], [0.0, 0.0, -1.0]),
              ("x_lo", [-side, 0.0, 0.0], [1.0, 0.0, 0.0]), ("x_hi", [side, 0.0, 0.0], [-1.0, 0.0, 0.0]),
              ("y_lo", [0.0, -side, 0.0], [0.0, 1.0, 0.0]), ("y_hi", [0.0, side, 0.0], [0.0, -1.0, 0.0])]
    inner = side - 0.0015
    case = {
        "simulation": {"timestep": dt, "gravity": [0.0, 0.0, -9.81], "integrator": "verlet", "skin": skin,
                       "domain": {"lo": [-side - 0.005, -side - 0.005, -0.005], "hi": [side + 0.005, side + 0.005, top + 0.005]}},
        "contact": contact,
        "material": [mat],
        "particles": {"material": "seed-soft",
                      "lattice": {"count": count, "radius_min": rmin, "radius_max": rmax, "lo": [-inner, -inner, 0.0015],
                                  "hi_xy": [inner, inner], "spacing": 2.1, "seed": 11}},
        "wall": [{"name": n, "material": "seed-soft", "plane": {"point": p, "normal": nv}} for n, p, nv in planes],
        "phase": [{"name": "run", "duration": 1.0e3}],
        "output": {"interval": 0.01},
    }
    return case, int(math.ceil(0.6 / dt))


def copy_h1(name, dest):
    """cases/NAME.toml without its [compare] section (older binaries refuse it), beside
    a copy of the meshes it reads."""
    text = (ROOT / "cases" / f"{name}.toml").read_text()
    out, skip = [], False
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("[") and not s.startswith("[["):
            skip = s == "[compare]"
        elif s.startswith("[["):
            skip = False
        if not skip:
            out.append(line)
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copytree(ROOT / "cases" / "meshes", dest / "meshes", dirs_exist_ok=True)
    path = dest / f"{name}.toml"
    path.write_text("\n".join(out) + "\n")
    return path


class Workload:
    """One workload: its case file (the same for both binaries), how a binary makes its
    starting state (`prepare`: the extra arguments of the timed run), the timed run's steps."""

    def __init__(self, name, case_file, steps, prepare=None):
        self.name, self.case_file, self.steps, self._prepare = name, case_file, steps, prepare

    def prepare(self, binary, state_dir, threads):
        return self._prepare(binary, state_dir, threads) if self._prepare else []


def workloads(names, cases_dir, steps=None):
    """The named workloads, their case files written into `cases_dir`. `steps`: the timed
    run's steps (and, for the beds, the settling's) instead of the defaults (tests)."""
    cases_dir.mkdir(parents=True, exist_ok=True)
    out = []
    for name in names:
        if name in ("bed-20k", "bed-20k-hooke", "bed-100k", "bed-100k-hooke"):
            count = 100000 if name.startswith("bed-100k") else 20000
            case, settle = bed_case(count, name.endswith("-hooke"))
            settle = steps or settle
            path = cases_dir / f"{name}.toml"
            path.write_text(f"# A/B workload {name} (compare/ab.py)\n" + toml_text(case))

            def prep(binary, state_dir, threads, path=path, settle=settle):
                ck = state_dir / "settle" / "checkpoint.bin"
                if not ck.exists():
                    print(f"ab: settling {path.stem} with {binary} ({settle} steps), once", flush=True)
                    run_talus(binary, path, state_dir / "settle", ["--steps", str(settle)], threads, state_dir / "settle.log")
                return ["--restart", str(ck)]

            out.append(Workload(name, path, steps or (1000 if count > 20000 else 3000), prep))
        elif name == "H1-small":
            out.append(Workload(name, copy_h1("H1-small", cases_dir), steps))
        elif name == "H1-paper-window":
            path = copy_h1("H1-paper", cases_dir)

            def prep(binary, state_dir, threads, path=path):
                ck = state_dir / "fill" / "checkpoint_after_fill.bin"
                if not ck.exists():
                    print(f"ab: H1-paper's fill with {binary}, once (about 10 min)", flush=True)
                    run_talus(binary, path, state_dir / "fill", ["--steps", "12500"], threads, state_dir / "fill.log")
                if not ck.exists():
                    raise AbError(f"{state_dir / 'fill'}: the fill did not end within 12,500 steps (no checkpoint_after_fill.bin)")
                return ["--restart", str(ck)]

            out.append(Workload(name, path, steps or 2000, prep))
        else:
            raise AbError(f"--workloads: unknown workload `{name}` (known: bed-20k, bed-20k-hooke, bed-100k, "
                          "bed-100k-hooke, H1-small, H1-paper-window)")
    return out


# ---------------------------------------------------------------- binaries

def git(*args, cwd=ROOT):
    p = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        raise AbError(f"git {' '.join(args)}: {p.stderr.strip()}")
    return p.stdout.strip()


def file_hash(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:16]


def build_baseline(rev, cache):
    """The talus binary of commit REV: built once in a git worktree (the build directory
    shared by every baseline, so dependencies are built once), kept in cache/bin/<commit>/."""
    sha = git("rev-parse", "--verify", f"{rev}^{{commit}}")
    binary = cache / "bin" / sha / "talus"
    if binary.exists():
        return sha, binary
    # outside this repository: cargo would take a commit whose Cargo.toml has no
    # [workspace] of its own for a member of this tree's workspace
    import tempfile
    src = Path(tempfile.gettempdir()) / "talus-ab-src" / sha
    if src.exists():
        subprocess.run(["git", "worktree", "remove", "--force", str(src)], cwd=ROOT, capture_output=True)
        shutil.rmtree(src, ignore_errors=True)
    subprocess.run(["git", "worktree", "prune"], cwd=ROOT, capture_output=True)
    git("worktree", "add", "--detach", str(src), sha)
    try:
        print(f"ab: building the baseline {rev} ({sha[:12]}) in {src}", flush=True)
        env = {**os.environ, "CARGO_TARGET_DIR": str(cache / "target")}
        log = cache / f"build-{sha[:12]}.log"
        with open(log, "w") as f:
            p = subprocess.run(["cargo", "build", "--release", "--bin", "talus"], cwd=src, env=env, stdout=f, stderr=subprocess.STDOUT)
        if p.returncode != 0:
            raise AbError(f"building {rev} failed (exit {p.returncode}); log {log}:\n{log.read_text()[-2000:]}")
        binary.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(cache / "target" / "release" / "talus", binary)
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(src)], cwd=ROOT, capture_output=True)
    return sha, binary


def current_binary(cache, given=None):
    """This tree's binary (built first unless given), copied out so that a rebuild while
    the rounds run changes nothing; named by its hash."""
    if given is None:
        p = subprocess.run(["cargo", "build", "--release", "--quiet", "--bin", "talus"], cwd=ROOT)
        if p.returncode != 0:
            raise AbError("cargo build --release failed")
        given = ROOT / "target" / "release" / "talus"
    given = Path(given)
    if not given.exists():
        raise AbError(f"{given}: no such binary")
    h = file_hash(given)
    binary = cache / "bin" / f"current-{h}" / "talus"
    if not binary.exists():
        binary.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(given, binary)
    return binary


@functools.lru_cache(maxsize=None)
def supports_threads(binary):
    """Whether a binary's `talus run` takes --threads (asked once per binary)."""
    p = subprocess.run([binary, "run", "--help"], capture_output=True, text=True)
    return "--threads" in p.stdout


# ---------------------------------------------------------------- runs

def run_talus(binary, case, out, extra, threads, log):
    """`talus run CASE --out OUT --quiet EXTRA` (and --threads where the binary has it);
    returns its summary.json."""
    cmd = [str(binary), "run", str(case), "--out", str(out), "--quiet", *extra]
    if supports_threads(binary):
        cmd += ["--threads", str(threads)]
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "w") as f:
        p = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env={**os.environ, "RAYON_NUM_THREADS": str(threads)})
    if p.returncode != 0:
        raise AbError(f"{' '.join(cmd)} failed (exit {p.returncode}); log {log}:\n{Path(log).read_text()[-2000:]}")
    return json.loads((Path(out) / "summary.json").read_text())


def timed_run(binary, w, extra, threads, work):
    """One timed run of workload `w`: its particle-steps per second, stage seconds, wall
    seconds, steps and state hash."""
    args = [*extra] + (["--steps", str(w.steps)] if w.steps else [])
    s = run_talus(binary, w.case_file, work / "run", args, threads, work / "run.log")
    return {"particle_steps_per_s": s["particle_steps_per_s"], "wall_clock_s": s["wall_clock_s"],
            "steps": s.get("steps_this_run"), "stage_seconds": s.get("stage_seconds"),
            "state_hash": s.get("state_hash"), "neighbor_builds": s.get("neighbor_builds")}


def order(k):
    """Round k's order: baseline first in even rounds, current first in odd ones (ABBA)."""
    return ["baseline", "current"] if k % 2 == 0 else ["current", "baseline"]


def median_stages(runs):
    keys = [k for k in (runs[0].get("stage_seconds") or {})]
    if not keys or any(not r.get("stage_seconds") for r in runs):
        return None
    return {k: statistics.median(r["stage_seconds"][k] for r in runs) for k in keys}


def summarise(name, rounds):
    """The median over the rounds of the within-round ratio current / baseline, its
    range, and both binaries' medians."""
    ratios = [r["current"]["particle_steps_per_s"] / r["baseline"]["particle_steps_per_s"] for r in rounds]
    side = {}
    for b in ("current", "baseline"):
        runs = [r[b] for r in rounds]
        side[b] = {"particle_steps_per_s_median": statistics.median(x["particle_steps_per_s"] for x in runs),
                   "stage_seconds_median": median_stages(runs),
                   "state_hashes": sorted({x["state_hash"] for x in runs if x.get("state_hash")})}
    return {"workload": name, "ratio_median": statistics.median(ratios), "ratio_range": [min(ratios), max(ratios)],
            "ratios": ratios, "orders": [r["order"] for r in rounds], **side, "rounds": rounds}


def print_result(r):
    lo, hi = r["ratio_range"]
    each = " ".join(f"{x:.3f}" for x in r["ratios"])
    print(f"  {r['workload']:<18} current/baseline {r['ratio_median']:.3f} (range {lo:.3f}-{hi:.3f}; rounds {each}); "
          f"M particle-steps/s {r['current']['particle_steps_per_s_median'] / 1e6:.3f} against "
          f"{r['baseline']['particle_steps_per_s_median'] / 1e6:.3f}")
    c, b = r["current"]["stage_seconds_median"], r["baseline"]["stage_seconds_median"]
    if c:
        parts = [f"{k} {c[k]:.2f}" + (f" / {b[k]:.2f}" if b and k in b else "") for k in c if c[k] > 0.005]
        print(f"  {'':<18} stages (s, current" + (" / baseline" if b else "") + "): " + ", ".join(parts))


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="python -m compare ab",
        description="A/B benchmark: this tree's talus against a baseline commit, the runs alternated (ABBA) "
                    "in one session; per workload the median of the within-round ratios current/baseline.",
        epilog=__doc__.split("\n\n", 2)[2] if __doc__ else None,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", required=True, metavar="REV", help="the commit to compare against (any git revision)")
    ap.add_argument("--workloads", default=",".join(DEFAULT_WORKLOADS),
                    help=f"comma-separated (default {','.join(DEFAULT_WORKLOADS)}; also bed-100k, bed-100k-hooke)")
    ap.add_argument("--repeat", type=int, default=3, metavar="N", help="rounds (default 3)")
    ap.add_argument("--threads", type=int, default=1, metavar="T", help="threads per run (default 1)")
    ap.add_argument("--steps", type=int, metavar="N",
                    help="the timed runs' steps (and the beds' settling) instead of each workload's own (quick checks)")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "ab", help="the cache and the results (default out/ab)")
    ap.add_argument("--baseline-bin", type=Path, metavar="PATH", help="use this binary as the baseline instead of building REV")
    ap.add_argument("--current-bin", type=Path, metavar="PATH", help="use this binary as the current one instead of building the tree")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error(f"--repeat {a.repeat}: a number of rounds of at least 1")
    if a.threads < 1:
        ap.error(f"--threads {a.threads}: at least 1")
    if a.steps is not None and a.steps < 1:
        ap.error(f"--steps {a.steps}: at least 1")
    names = [w.strip() for w in a.workloads.split(",") if w.strip()]
    cache = a.out.resolve()
    try:
        ws = workloads(names, cache / "cases", a.steps)
        if a.baseline_bin:
            base_sha, base = a.baseline, a.baseline_bin.resolve()
            if not base.exists():
                raise AbError(f"--baseline-bin {a.baseline_bin}: no such binary")
        else:
            base_sha, base = build_baseline(a.baseline, cache)
        cur = current_binary(cache, a.current_bin)
        bins = {"baseline": base, "current": cur}
        notes = []
        if a.threads > 1 and not supports_threads(base):
            notes.append(f"the baseline {a.baseline} has no thread pool: it runs on one thread")
        results = []
        for w in ws:
            starts = {}
            for b, binary in bins.items():
                state = cache / "state" / file_hash(binary) / f"{w.name}-{file_hash(w.case_file)}-s{a.steps or 0}-t{a.threads}"
                starts[b] = w.prepare(binary, state, a.threads)
            rounds = []
            for k in range(a.repeat):
                r = {"order": order(k)}
                for b in r["order"]:
                    work = cache / "runs" / w.name / f"round{k + 1}-{b}"
                    shutil.rmtree(work, ignore_errors=True)
                    r[b] = timed_run(bins[b], w, starts[b], a.threads, work)
                rounds.append(r)
                print(f"ab: {w.name} round {k + 1} of {a.repeat} ({' then '.join(r['order'])}): current/baseline "
                      f"{r['current']['particle_steps_per_s'] / r['baseline']['particle_steps_per_s']:.3f}", flush=True)
            results.append(summarise(w.name, rounds))
    except (AbError, engines.EngineError) as err:
        print(f"compare ab: {err}", file=sys.stderr)
        return 2
    head = git("rev-parse", "--short", "HEAD")
    dirty = bool(git("status", "--porcelain", "--untracked-files=no"))
    report = {"baseline": {"rev": a.baseline, "commit": base_sha, "binary": str(base)},
              "current": {"commit": head + ("+changes" if dirty else ""), "binary": str(cur)},
              "threads": a.threads, "repeat": a.repeat, "date": time.strftime("%Y-%m-%d %H:%M"),
              "machine": {"cores": os.cpu_count(), "load_average_1min": os.getloadavg()[0]},
              "notes": notes, "workloads": results,
              "note": "ratio: particle-steps per second of the current binary over the baseline's, measured within "
                      "one round (the two runs back to back, the order alternating between rounds); the median "
                      "over the rounds and its range"}
    cache.mkdir(parents=True, exist_ok=True)
    (cache / "ab.json").write_text(json.dumps(report, indent=1))
    print(f"\nA/B: current {report['current']['commit']} against baseline {a.baseline} ({str(base_sha)[:12]}), "
          f"{a.repeat} rounds (ABBA), {a.threads} thread(s)")
    for n in notes:
        print(f"  note: {n}")
    for r in results:
        print_result(r)
    print(f"\nwritten: {cache / 'ab.json'}")
    return 0
