"""Running the three engines on one set-up; each returns the path of its raw time series."""
import re
import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TALUS = ROOT / "target" / "release" / "talus"
REQUIRED = {"liggghts": "3.8.0", "yade": "2023.02a"}


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
        if shutil.which(eng) is None:
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


def _sub(text, pattern, repl, what):
    new, n = re.subn(pattern, repl, text, count=1, flags=re.M)
    if n != 1:
        raise EngineError(f"talus case template: cannot set {what}")
    return new


def talus_sc_case(run, convention, dt):
    """talus's own SC case file with this run's numbers."""
    name = {"SC-wall": "SC-wall.toml", "SC-pair": "SC-pair.toml", "SC-oblique": "SC-oblique.toml"}[run.setup]
    text = (ROOT / "cases" / name).read_text()
    text = _sub(text, r"^restitution = .*$", f"restitution = {run.e!r}", "restitution")
    text = _sub(text, r"^convention = .*$", f'convention = "{convention}"', "convention")
    text = _sub(text, r"^timestep = .*$", f"timestep = {dt!r}", "timestep")
    text = _sub(text, r"^interval = .*$", f"interval = {dt!r}", "output interval")
    if run.model == "hooke":
        h = run.hooke
        text = _sub(
            text, r'^model = "hertz"$',
            f'model = "hooke"\nstiffness = {{ kn = {h.kn!r}, kt = {h.kt!r}, gamma_n = {h.gamma_n!r}, gamma_t = {h.gamma_t!r} }}',
            "model")
    if run.setup == "SC-oblique":
        import math
        a = math.radians(run.angle)
        text = _sub(text, r"velocity = \[[^\]]*\]", f"velocity = [{0.5 * math.sin(a)!r}, 0.0, {-0.5 * math.cos(a)!r}]", "velocity")
    return text


def run_talus_sc(run, convention, work, dt):
    work.mkdir(parents=True, exist_ok=True)
    case = work / f"talus-{convention}.toml"
    case.write_text(talus_sc_case(run, convention, dt))
    out = work / f"talus-{convention}"
    _run([TALUS, "run", case, "--out", out, "--quiet"], work / f"talus-{convention}.log")
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


def talus_h1_case(setup, convention):
    text = (ROOT / "cases" / f"{setup}.toml").read_text()
    text = _sub(text, r"^convention = .*$", f'convention = "{convention}"', "convention")
    text = _sub(text, r"^snapshot_interval = .*$", "snapshot_interval = 1000.0", "snapshots")
    text = text.replace('stl = "meshes/', f'stl = "{ROOT}/cases/meshes/')
    return text


def run_talus_h1(setup, convention, work, max_steps=None, ranks=1):
    """talus on H1 (on `ranks` MPI ranks if more than one); returns (probes.csv, summary dict)."""
    import json
    work.mkdir(parents=True, exist_ok=True)
    case = work / f"talus-{convention}.toml"
    case.write_text(talus_h1_case(setup, convention))
    tag = f"talus-{convention}" + (f"-p{ranks}" if ranks > 1 else "")
    out = work / tag
    extra = ["--steps", str(max_steps)] if max_steps else []
    mpi = ["mpirun", "--allow-run-as-root", "-n", str(ranks)] if ranks > 1 else []
    _run([*mpi, TALUS, "run", case, "--out", out, "--quiet", *extra], work / f"{tag}.log")
    return out / "probes.csv", json.loads((out / "summary.json").read_text())


def run_liggghts_h1(setup, work, fill_time, discharge_time, dt, skin):
    """LIGGGHTS on H1 from talus's own initial cloud; returns (probes.csv, fill_end.csv, log)."""
    work.mkdir(parents=True, exist_ok=True)
    cloud = work / "cloud.csv"
    _run([TALUS, "cloud", ROOT / "cases" / f"{setup}.toml", "--out", cloud], work / "cloud.log")
    data = work / "cloud.data"
    _run(["python3", ROOT / "liggghts_cases" / "csv_to_data.py", cloud, data], work / "data.log")
    probes, fill_end, log = work / "liggghts.csv", work / "liggghts_fill_end.csv", work / "liggghts.log"
    _run(["liggghts", "-in", ROOT / "liggghts_cases" / "H1.in", "-log", log, "-var", "cloud", data,
          "-var", "out", probes, "-var", "out_fill_end", fill_end, "-var", "fill_time", repr(fill_time),
          "-var", "discharge_time", repr(discharge_time), "-var", "dt", repr(dt), "-var", "skin", repr(skin)],
         work / "liggghts.stdout")
    return probes, fill_end, log


def liggghts_loop_seconds(log):
    """Sum of LIGGGHTS's `Loop time` lines (the time stepping, set-up excluded) and steps."""
    secs, steps = 0.0, 0
    for line in Path(log).read_text().splitlines():
        m = re.match(r"Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps", line)
        if m:
            secs += float(m.group(1))
            steps += int(m.group(2))
    return secs, steps


def run_yade_h1(setup, work, fill_time, discharge_time, dt, skin):
    """YADE on H1 from talus's own initial cloud; returns (probes.csv, fill_end.csv, wall seconds)."""
    import time
    work.mkdir(parents=True, exist_ok=True)
    cloud = work / "cloud.csv"
    _run([TALUS, "cloud", ROOT / "cases" / f"{setup}.toml", "--out", cloud], work / "cloud.log")
    probes, fill_end = work / "yade.csv", work / "yade_fill_end.csv"
    t0 = time.perf_counter()
    _run(["yade", "-n", "-j", "1", "-x", ROOT / "yade_cases" / "H1.py", "--cloud", cloud, "--out", probes,
          "--out-fill-end", fill_end, "--fill-time", repr(fill_time), "--discharge-time", repr(discharge_time),
          "--dt", repr(dt), "--skin", repr(skin)], work / "yade.log")
    return probes, fill_end, time.perf_counter() - t0
