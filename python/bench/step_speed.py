"""Stepping from Python against the command line: the same case and steps,
run alternately (best of `--repeat` each), as particle-steps per second.

    python3 python/bench/step_speed.py [--steps 2000] [--repeat 3] [--threads 1]

Two comparisons, one row per size, each the command line's and Python's
throughput and their ratio (Python / CLI; 1.00 means no cost):
- `step(n)`: `talus run --steps n` (summary.json `particle_steps_per_s`, the
  stepping loop, writing its probes) against `sim.step(n)` timed around the
  call (no files);
- `run(out)`: a whole short case (a fill of `--steps` steps) by `talus run`
  and by `sim.run(out=...)`, both writing the same files, each figure the
  summary's own `particle_steps_per_s`.
"""

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

import talus

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "cases" / "H1-small.toml"
TALUS = ROOT / "target" / "release" / "talus"


def cli_rate(over, steps, threads, out):
    args = [str(TALUS), "run", str(CASE), "--out", str(out), "--quiet", "--steps", str(steps), "--threads", str(threads)]
    for o in over:
        args += ["--set", o]
    subprocess.run(args, check=True, capture_output=True)
    return json.loads((out / "summary.json").read_text())["particle_steps_per_s"]


def py_rate(over, steps, threads):
    sim = talus.Simulation.from_file(CASE, threads=threads, overrides=over)
    sim.step(1)  # the first forces and lists, as the CLI's setup
    t = time.perf_counter()
    sim.step(steps)
    return sim.particle_count * steps / (time.perf_counter() - t)


def run_rates(over, steps, threads, out):
    """The whole case cut to a fill of `steps` steps, by the CLI and by run(out)."""
    sim = talus.Simulation.from_file(CASE, threads=threads, overrides=over)
    dt = sim.dt
    over = over + [f"phase.fill.duration={steps * dt}", f"phase.discharge.duration={dt}"]
    c = cli_rate(over, 10**9, threads, out / "cli")
    sim = talus.Simulation.from_file(CASE, threads=threads, overrides=over)
    p = sim.run(out=out / "py")["particle_steps_per_s"]
    return c, p


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    print(f"{'how':>8} {'particles':>9} {'CLI M/s':>9} {'Python M/s':>10} {'Python/CLI':>10}")
    with tempfile.TemporaryDirectory() as d:
        for count in (1000, 5000):
            over = [f"particles.lattice.count={count}", "output.snapshot_interval=100.0"]
            c, p = [], []
            for _ in range(a.repeat):
                c.append(cli_rate(over, a.steps, a.threads, Path(d)))
                p.append(py_rate(over, a.steps, a.threads))
            print(f"{'step(n)':>8} {count:9d} {max(c) / 1e6:9.3f} {max(p) / 1e6:10.3f} {max(p) / max(c):10.3f}", flush=True)
            c, p = [], []
            for _ in range(a.repeat):
                x, y = run_rates(over, a.steps, a.threads, Path(d))
                c.append(x)
                p.append(y)
            print(f"{'run(out)':>8} {count:9d} {max(c) / 1e6:9.3f} {max(p) / 1e6:10.3f} {max(p) / max(c):10.3f}", flush=True)


if __name__ == "__main__":
    main()
