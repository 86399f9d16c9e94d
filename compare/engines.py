"""Running the three engines on one set-up; each returns the path of its raw time series."""
import json
import os
import re
import shutil
import subprocess
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# TALUS_BIN: another build of talus (a long comparison can run from a copy while the tree is rebuilt)
TALUS = Path(os.environ.get("TALUS_BIN", ROOT / "target" / "release" / "talus"))
REQUIRED = {"liggghts": "3.8.0", "yade": "2023.02a", "lammps": "20220106"}
# the binary of each Debian package, where its name differs (lammps 20220106 is LAMMPS 29 Sep 2021)
BINARY = {"lammps": "lmp"}


class EngineError(RuntimeError):
    pass


def check_versions(engines):
    """Fail with a clear message if a reference code is missing or not the expected version."""
    for eng in engines:
        if eng == "talus":
            if not TALUS.exists():
                raise EngineError(f"talus is not built: {TALUS} is missing (run `cargo build --release`)")
            continue
        want = REQUIRED[eng]
        if shutil.which(BINARY.get(eng, eng)) is None:
            raise EngineError(f"{eng} is not installed: run `bash scripts/install.sh` (Debian package `{eng}` {want})")
        try:
            ver = subprocess.run(["dpkg-query", "-W", "-f=${Version}", eng], capture_output=True, text=True, check=True).stdout
        except (OSError, subprocess.CalledProcessError):
            raise EngineError(f"cannot read the version of the Debian package `{eng}`")
        if not ver.startswith(want):
            raise EngineError(f"{eng} {ver} is installed; the comparisons are set up for {want}")


def _run(cmd, log, cwd=ROOT):
    with open(log, "w") as f:
        p = subprocess.run(cmd, cwd=cwd, stdout=f, stderr=subprocess.STDOUT)
    if p.returncode != 0:
        tail = Path(log).read_text()[-2000:]
        raise EngineError(f"{' '.join(map(str, cmd))} failed (exit {p.returncode}); log {log}:\n{tail}")


def _done_marker(work, tag, args):
    """A finished run's arguments, written next to its output: `compare --resume` reuses the
    output of a run whose marker holds the same arguments."""
    import json
    (Path(work) / f"{tag}.done.json").write_text(json.dumps({k: str(v) for k, v in args.items()}, sort_keys=True) + "\n")


def _is_done(work, tag, args):
    import json
    p = Path(work) / f"{tag}.done.json"
    try:
        return json.loads(p.read_text()) == {k: str(v) for k, v in args.items()}
    except (OSError, ValueError):
        return False


def case_path(setup):
    """The talus case file of a set-up."""
    return ROOT / "cases" / f"{setup}.toml"


def read_case(setup):
    """A talus case file as a dict (tomllib)."""
    with open(case_path(setup), "rb") as f:
        return tomllib.load(f)


def toml_value(v):
    """A Python value as a TOML value for `talus run --set KEY=VALUE` (and case files)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    return repr(float(v)) if isinstance(v, float) else repr(v)


def sets(values):
    """`--set KEY=VALUE` arguments for talus from a dict of dotted keys."""
    return [a for k, v in values.items() for a in ("--set", f"{k}={toml_value(v)}")]


def talus_sc_sets(run, convention, dt):
    """The changes to talus's own SC case file for this run (applied with --set)."""
    v = {"material[0].restitution": run.e, "contact.convention": convention,
         "simulation.timestep": dt, "output.interval": dt}
    if run.model == "hooke":
        h = run.hooke
        v["contact.model"] = "hooke"
        v["contact.stiffness"] = {"kn": h.kn, "kt": h.kt, "gamma_n": h.gamma_n, "gamma_t": h.gamma_t}
    if run.setup == "SC-oblique":
        import math
        a = math.radians(run.angle)
        v["particles.list[0].velocity"] = [0.5 * math.sin(a), 0.0, -0.5 * math.cos(a)]
    return v


def run_talus_sc(run, convention, work, dt):
    work.mkdir(parents=True, exist_ok=True)
    out = work / f"talus-{convention}"
    _run([TALUS, "run", case_path(run.setup), "--out", out, "--quiet", *sets(talus_sc_sets(run, convention, dt))],
         work / f"talus-{convention}.log")
    return out / "probes.csv"


def run_liggghts_sc(run, work, dt):
    work.mkdir(parents=True, exist_ok=True)
    out = work / "liggghts.csv"
    setup = run.setup.split("-")[1]
    cmd = ["liggghts", "-in", ROOT / "liggghts_cases" / "SC.in", "-log", work / "liggghts.log",
           "-var", "setup", setup, "-var", "model", run.model, "-var", "e", repr(run.e),
           "-var", "angle", repr(run.angle), "-var", "dt", repr(dt), "-var", "out", out]
    if run.model == "hooke":
        h = run.hooke
        cmd += ["-var", "kn", repr(h.kn), "-var", "kt", repr(h.kt), "-var", "gamman", repr(h.gamma_n),
                "-var", "gammat", repr(h.gamma_t)]
    _run(cmd, work / "liggghts.stdout")
    return out


def run_yade_sc(run, work, dt):
    work.mkdir(parents=True, exist_ok=True)
    out = work / "yade.csv"
    setup = run.setup.split("-")[1]
    cmd = ["yade", "-n", "-j", "1", "-x", ROOT / "yade_cases" / "SC.py", "--setup", setup, "--model", run.model,
           "--e", repr(run.e), "--angle", repr(run.angle), "--dt", repr(dt), "--out", out]
    if run.model == "hooke":
        h = run.hooke
        cmd += ["--kn", repr(h.kn), "--kt", repr(h.kt), "--gamman", repr(h.gamma_n), "--gammat", repr(h.gamma_t)]
    _run(cmd, work / "yade.log")
    return out


def run_talus_h1(setup, convention, work, max_steps=None, ranks=1, threads=None, reuse=False):
    """talus on H1 (on `ranks` MPI ranks if more than one, `threads` per rank, default: the
    cores shared among the ranks); returns (probes.csv, summary dict). With `reuse`, a
    finished run of the same arguments in `work` is not run again."""
    import json
    work.mkdir(parents=True, exist_ok=True)
    tag = f"talus-{convention}" + (f"-p{ranks}" if ranks > 1 else "") + (f"-t{threads}" if threads else "")
    out = work / tag
    extra = ["--steps", str(max_steps)] if max_steps else []
    extra += sets({"contact.convention": convention, "output.snapshot_interval": 1000.0})
    if threads:
        extra += ["--threads", str(threads)]
    mpi = ["mpirun", "--allow-run-as-root", "-n", str(ranks)] if ranks > 1 else []
    cmd = [*mpi, TALUS, "run", case_path(setup), "--out", out, "--quiet", *extra]
    args = {"command": " ".join(map(str, cmd))}
    if not (reuse and _is_done(work, tag, args) and (out / "summary.json").exists()):
        _run(cmd, work / f"{tag}.log")
        _done_marker(work, tag, args)
    return out / "probes.csv", json.loads((out / "summary.json").read_text())


def run_liggghts_h1(setup, work, fill_time, discharge_time, dt, skin, reuse=False):
    """LIGGGHTS on H1 from talus's own initial cloud; returns (probes.csv, fill_end.csv, log).
    With `reuse`, a finished run of the same arguments in `work` is not run again."""
    work.mkdir(parents=True, exist_ok=True)
    probes, fill_end, log = work / "liggghts.csv", work / "liggghts_fill_end.csv", work / "liggghts.log"
    args = {"setup": setup, "fill_time": repr(fill_time), "discharge_time": repr(discharge_time), "dt": repr(dt),
            "skin": repr(skin)}
    if reuse and _is_done(work, "liggghts", args) and probes.exists() and fill_end.exists():
        return probes, fill_end, log
    cloud = work / "cloud.csv"
    _run([TALUS, "cloud", ROOT / "cases" / f"{setup}.toml", "--out", cloud], work / "cloud.log")
    data = work / "cloud.data"
    _run(["python3", ROOT / "liggghts_cases" / "csv_to_data.py", cloud, data], work / "data.log")
    _run(["liggghts", "-in", ROOT / "liggghts_cases" / "H1.in", "-log", log, "-var", "cloud", data,
          "-var", "out", probes, "-var", "out_fill_end", fill_end, "-var", "fill_time", repr(fill_time),
          "-var", "discharge_time", repr(discharge_time), "-var", "dt", repr(dt), "-var", "skin", repr(skin)],
         work / "liggghts.stdout")
    _done_marker(work, "liggghts", args)
    return probes, fill_end, log


def liggghts_loop_seconds(log):
    """Sum of LIGGGHTS's (or LAMMPS's) `Loop time` lines (the time stepping, set-up
    excluded) and steps."""
    secs, steps = 0.0, 0
    for line in Path(log).read_text().splitlines():
        m = re.match(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps", line)
        if m:
            secs += float(m.group(1))
            steps += int(m.group(2))
    return secs, steps


# --resume: YADE saves its whole state this often (wall time, s); COMPARE_YADE_CHECKPOINT_S
# sets another period (a test of the resume, say)
YADE_CHECKPOINT_SECONDS = float(os.environ.get("COMPARE_YADE_CHECKPOINT_S", "600"))


def run_yade_h1(setup, work, fill_time, discharge_time, dt, skin, resume=False):
    """YADE on H1 from talus's own initial cloud; returns (probes.csv, fill_end.csv, wall seconds).
    With `resume`, YADE checkpoints itself (yade_cases/H1.py --checkpoint-every) and an
    unfinished run in `work` continues from its last checkpoint (a finished one is kept);
    the wall seconds are then the YADE run's own, summed over its pieces."""
    import json
    import time
    work.mkdir(parents=True, exist_ok=True)
    cloud = work / "cloud.csv"
    if not (resume and cloud.exists()):  # a resumed run checks the cloud's sha256 against its checkpoint
        _run([TALUS, "cloud", ROOT / "cases" / f"{setup}.toml", "--out", cloud], work / "cloud.log")
    probes, fill_end = work / "yade.csv", work / "yade_fill_end.csv"
    cmd = ["yade", "-n", "-j", "1", "-x", ROOT / "yade_cases" / "H1.py", "--cloud", cloud, "--out", probes,
           "--out-fill-end", fill_end, "--fill-time", repr(fill_time), "--discharge-time", repr(discharge_time),
           "--dt", repr(dt), "--skin", repr(skin)]
    if not resume:
        t0 = time.perf_counter()
        _run(cmd, work / "yade.log")
        return probes, fill_end, time.perf_counter() - t0
    summary = work / "yade_summary.json"
    cmd += ["--checkpoint-every", repr(YADE_CHECKPOINT_SECONDS), "--summary", summary]
    log = work / "yade.log"
    # every piece's log is kept (yade.log.1, .2, ...)
    n = 1
    while log.with_name(f"yade.log.{n}").exists():
        n += 1
    _run(cmd, log.with_name(f"yade.log.{n}"))
    shutil.copyfile(log.with_name(f"yade.log.{n}"), log)
    return probes, fill_end, json.loads(summary.read_text())["elapsed_s"]
