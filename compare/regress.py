"""python -m compare regress CASE.toml [--golden FILE] [--update-golden] [--junit FILE] [--out DIR] [--steps N]

Physics regression for a user's CI: runs talus alone on a case and checks its figures
against a golden file written by an earlier run (`--update-golden` writes it), with the
tolerances of the case's `[compare]` section:

- every numeric figure of summary.json (host and timing figures left out), relative to
  the golden value: `figure_rel` (default 0.02), per figure `figures.NAME`;
- every probe column of probes.csv: the largest deviation over the run, as a fraction
  of the golden column's range: `series_range` (default 0.05), per column `series.NAME`;
- each column's mean over each window of `windows = [[t0, t1], ...]`, as a fraction of
  its range: `window_mean` (default 0.02), per column `window_means.NAME`;
- `ignore = [...]` leaves figures or columns out; `regress_steps = N` cuts the run to N
  steps (long cases in CI); `--steps` overrides it.

A drag case (`cases/drag/*.toml`, run by `talus drag`) is checked on its summary figures.
The state hash is reported (same bits or not) but not required: tolerances, not bits,
decide. Exit 0 when everything is within tolerance, 1 when something is not, 2 when the
run or the golden file cannot be used. `--junit FILE` writes one JUnit test case per
figure, column and window.
"""

import argparse
import csv
import json
import math
import subprocess
import sys
import tempfile
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TALUS = ROOT / "target" / "release" / "talus"

# figures of summary.json that describe the host or the run's bookkeeping, not the physics
NOT_PHYSICS = {
    "wall_clock_s", "particle_steps_per_s", "stage_seconds", "threads", "ranks", "grid", "balance",
    "rebalances", "neighbor_builds", "case", "steps_this_run", "state_hash", "stopped_by_signal",
}
SERIES_KEYS = {"time_s", "step", "phase"}
DEFAULTS = {"figure_rel": 0.02, "series_range": 0.05, "window_mean": 0.02}


class RegressError(RuntimeError):
    pass


def read_case(path):
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise RegressError(f"cannot read {path}: {e.strerror}")
    except tomllib.TOMLDecodeError as e:
        raise RegressError(f"{path}: {e}")


def tolerances(case):
    c = dict(DEFAULTS)
    c.update({k: v for k, v in case.get("compare", {}).items()})
    c.setdefault("figures", {})
    c.setdefault("series", {})
    c.setdefault("windows", [])
    c.setdefault("window_means", {})
    c.setdefault("ignore", [])
    return c


def run_talus(case_path, case, out, steps):
    """Run talus on the case into `out`; returns (figures, series, state_hash)."""
    if not TALUS.exists():
        raise RegressError(f"talus is not built: {TALUS} is missing (run `cargo build --release`)")
    drag = "drag" in case
    cmd = [str(TALUS), "drag" if drag else "run", str(case_path), "--out", str(out)]
    if not drag:
        cmd.append("--quiet")
        if steps:
            cmd += ["--steps", str(steps)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RegressError(f"{' '.join(cmd)} failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    summary = json.loads((out / "summary.json").read_text())
    figures = {}
    for k, v in summary.items():
        if k in NOT_PHYSICS or isinstance(v, (str, dict, list)) or v is None:
            continue
        figures[k] = v
    if case.get("analysis", {}).get("kind") == "drag" and not steps and (out / "probes.csv").exists():
        from .case import drag_figures, read_probes

        figures.update(drag_figures(read_probes(out / "probes.csv"), case))
    if case.get("analysis", {}).get("kind") == "pile" and not steps:
        from .case import pile_figures, read_final

        figures.update(pile_figures(*read_final(out), case))
    series = {}
    probes = out / "probes.csv"
    if probes.exists():
        with open(probes, newline="") as f:
            rows = list(csv.reader(f))
        head, body = rows[0], rows[1:]
        for j, name in enumerate(head):
            if name in ("step", "phase"):
                continue
            series[name] = [float(r[j]) for r in body]
    return figures, series, summary.get("state_hash")


def check(golden, figures, series, tol):
    """Every check as (kind, name, ok, measured deviation, tolerance, message)."""
    out = []
    ignore = set(tol["ignore"])
    for k in sorted(set(golden["figures"]) | set(figures)):
        if k in ignore:
            continue
        if k not in figures or k not in golden["figures"]:
            where = "this run" if k not in figures else "the golden file"
            out.append(("figure", k, False, math.nan, 0.0, f"{k}: missing from {where}"))
            continue
        a, b = figures[k], golden["figures"][k]
        t = tol["figures"].get(k, tol["figure_rel"])
        if isinstance(b, bool) or isinstance(a, bool):
            ok = a == b
            out.append(("figure", k, ok, 0.0 if ok else 1.0, t, f"{k} = {a}, golden {b}"))
            continue
        scale = abs(b) if b != 0 else 1.0
        dev = abs(a - b) / scale if not (a == b) else 0.0
        ok = dev <= t
        out.append(("figure", k, ok, dev, t, f"{k} = {a:.9g}, golden {b:.9g} (relative {dev:.3g}, tolerance {t:g})"))
    gs = golden.get("series", {})
    if gs:
        t_g, t_a = gs.get("time_s", []), series.get("time_s", [])
        if len(t_g) != len(t_a) or any(abs(x - y) > 1e-9 * max(1.0, abs(y)) for x, y in zip(t_a, t_g)):
            out.append(("series", "time_s", False, math.nan, 0.0,
                        f"probe times differ: {len(t_a)} rows against the golden {len(t_g)} (another interval or run length?)"))
            return out
        for col in gs:
            if col in SERIES_KEYS or col in ignore:
                continue
            if col not in series:
                out.append(("series", col, False, math.nan, 0.0, f"{col}: missing from this run's probes"))
                continue
            a, b = series[col], gs[col]
            rng = max(b) - min(b)
            scale = rng if rng > 0 else max(max(abs(x) for x in b), 1e-300)
            dev = max((abs(x - y) for x, y in zip(a, b)), default=0.0) / scale
            t = tol["series"].get(col, tol["series_range"])
            out.append(("series", col, dev <= t, dev, t, f"{col}: largest deviation {dev:.3g} of the range (tolerance {t:g})"))
            for w0, w1 in tol["windows"]:
                idx = [i for i, x in enumerate(t_g) if w0 <= x <= w1]
                if not idx and t_g and w0 > t_g[-1]:
                    # the window lies past a run cut short for regression (regress_steps):
                    # the series check above covers what was run
                    continue
                if not idx:
                    out.append(("window", f"{col}@[{w0},{w1}]", False, math.nan, 0.0, f"window [{w0}, {w1}] s holds no probe row"))
                    continue
                ma = sum(a[i] for i in idx) / len(idx)
                mb = sum(b[i] for i in idx) / len(idx)
                d = abs(ma - mb) / scale
                tw = tol["window_means"].get(col, tol["window_mean"])
                out.append(("window", f"{col}@[{w0},{w1}]", d <= tw, d, tw,
                            f"{col} mean over [{w0}, {w1}] s: {ma:.9g}, golden {mb:.9g} ({d:.3g} of the range, tolerance {tw:g})"))
    return out


def write_junit(path, case_name, results, seconds):
    fails = sum(1 for r in results if not r[2])
    suite = ET.Element("testsuite", name=f"talus regress {case_name}", tests=str(len(results)), failures=str(fails),
                       errors="0", time=f"{seconds:.3f}")
    for kind, name, ok, dev, t, msg in results:
        tc = ET.SubElement(suite, "testcase", classname=f"{case_name}.{kind}", name=name, time="0")
        if not ok:
            f = ET.SubElement(tc, "failure", message=msg, type="OutsideTolerance")
            f.text = msg
    suites = ET.Element("testsuites")
    suites.append(suite)
    ET.ElementTree(suites).write(path, encoding="utf-8", xml_declaration=True)


def default_golden(case_path):
    return case_path.parent / "golden" / f"{case_path.stem}.json"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m compare regress", description=__doc__.splitlines()[2])
    ap.add_argument("case", type=Path)
    ap.add_argument("--golden", type=Path, help="golden file (default: golden/<case name>.json beside the case)")
    ap.add_argument("--update-golden", action="store_true", help="write the golden file from this run")
    ap.add_argument("--junit", type=Path, help="write JUnit XML here")
    ap.add_argument("--out", type=Path, help="talus's output folder (default: a temporary one)")
    ap.add_argument("--steps", type=int, help="run this many steps (default: the case's compare.regress_steps, else all)")
    a = ap.parse_args(argv)
    import time

    t0 = time.time()
    try:
        case = read_case(a.case)
        tol = tolerances(case)
        steps = a.steps or tol.get("regress_steps")
        golden_path = a.golden or default_golden(a.case)
        with tempfile.TemporaryDirectory() as tmp:
            out = a.out or Path(tmp)
            figures, series, state_hash = run_talus(a.case, case, out, steps)
        if a.update_golden:
            golden_path.parent.mkdir(parents=True, exist_ok=True)
            g = {"case": a.case.name, "steps": steps, "state_hash": state_hash, "figures": figures, "series": series}
            golden_path.write_text(json.dumps(g, indent=0) + "\n")
            print(f"regress {a.case.name}: wrote {golden_path} ({len(figures)} figures, {len(series)} probe columns)")
            return 0
        if not golden_path.exists():
            raise RegressError(f"no golden file {golden_path}: write one with --update-golden")
        golden = json.loads(golden_path.read_text())
        if golden.get("steps") != steps:
            raise RegressError(f"{golden_path} was written from {golden.get('steps') or 'all'} steps, this run makes {steps or 'all'}")
    except RegressError as e:
        print(f"compare regress: {e}", file=sys.stderr)
        return 2
    results = check(golden, figures, series, tol)
    bad = [r for r in results if not r[2]]
    same = "same bits" if state_hash == golden.get("state_hash") else f"differs ({state_hash} against {golden.get('state_hash')})"
    print(f"regress {a.case.name}: {len(results) - len(bad)} of {len(results)} checks within tolerance; state hash {same}")
    for r in bad:
        print(f"  OUTSIDE TOLERANCE: {r[5]}")
    if a.junit:
        write_junit(a.junit, a.case.stem, results, time.time() - t0)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
