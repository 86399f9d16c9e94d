"""yade_cases/H1.py --checkpoint-every: a YADE H1 run killed after a checkpoint and resumed
writes the same files, byte for byte, as a run that was never stopped; a checkpoint is
refused for other arguments (naming the argument), and a finished run is not run again.

A short H1-like run: the lowest 2,000 spheres of H1-small's cloud, 0.2 s of fill (the
spheres land on the gate at about 0.11 s) and 0.03 s of discharge, a checkpoint step every
300 steps; about 15 s per run on one core."""

import csv
import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from compare import engines

ROOT = Path(__file__).resolve().parents[2]
H1 = ROOT / "yade_cases" / "H1.py"

pytestmark = pytest.mark.skipif(shutil.which("yade") is None or not engines.TALUS.exists(),
                                reason="needs yade (scripts/install.sh) and target/release/talus")

SPHERES = 2000
CHECKPOINT_STEPS = 300
KILL_AFTER_STEP = 1200  # a checkpoint with the spheres on the gate (contacts, shear history)


def cloud(tmp_path):
    full = tmp_path / "cloud_full.csv"
    subprocess.run([str(engines.TALUS), "cloud", str(ROOT / "cases" / "H1-small.toml"), "--out", str(full)],
                   check=True, capture_output=True)
    lines = full.read_text().splitlines(keepends=True)
    path = tmp_path / "cloud.csv"
    path.write_text("".join(lines[:1 + SPHERES]))  # ids 1..2000, the lowest layers
    return path


def h1_cmd(cloud_csv, out_dir, *extra, fill_time="0.2"):
    return ["yade", "-n", "-j", "1", "-x", str(H1), "--cloud", str(cloud_csv), "--out", str(out_dir / "probes.csv"),
            "--out-fill-end", str(out_dir / "fill_end.csv"), "--summary", str(out_dir / "summary.json"),
            "--fill-time", fill_time, "--discharge-time", "0.03", "--checkpoint-steps", str(CHECKPOINT_STEPS), *extra]


def run(cmd, **kw):
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300, **kw)


def checkpoint(out_dir):
    try:
        return json.loads((out_dir / "probes.csv.ckpt.json").read_text())
    except (OSError, ValueError):  # not written yet (it is replaced atomically, never torn)
        return None


def test_a_killed_and_resumed_yade_h1_run_writes_what_an_unstopped_run_writes(tmp_path):
    c = cloud(tmp_path)
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir()
    two.mkdir()

    # the run never stopped: checkpoint steps (in-memory save/load round trips) but no file
    r = run(h1_cmd(c, one, "--checkpoint-every", "1e9"))
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    done = checkpoint(one)
    assert done["finished"] and not list(one.glob("*.bin.gz"))

    # piece 1: a checkpoint file at every checkpoint step; killed (SIGKILL) after the
    # checkpoint of step KILL_AFTER_STEP
    p = subprocess.Popen(h1_cmd(c, two, "--checkpoint-every", "1e-9"), cwd=ROOT, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        t_end = time.time() + 240
        while time.time() < t_end and p.poll() is None:
            ck = checkpoint(two)
            if ck and ck["iter"] >= KILL_AFTER_STEP:
                break
            time.sleep(0.2)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    ck = checkpoint(two)
    assert ck and not ck["finished"] and ck["iter"] >= KILL_AFTER_STEP and ck["iter"] % CHECKPOINT_STEPS == 0, ck
    # the state file it names (the kill may also have left the next save's file, which
    # the resumed run deletes)
    assert (two / ck["state"]).exists()
    # a row torn by the kill: the resume must cut the CSV back to the checkpoint's rows
    with open(two / "probes.csv", "a") as fh:
        fh.write("0.99,9999,fill,0.1")
    rows_at_kill = (two / "probes.csv").read_text().count("\n") - 1
    assert rows_at_kill >= len(ck["st"]["rows"])

    # other arguments: refused, naming the argument; the checkpoint is untouched
    r = run(h1_cmd(c, two, "--checkpoint-every", "1e9", fill_time="0.21"))
    assert r.returncode != 0 and "--fill-time" in r.stdout + r.stderr, r.stdout[-2000:] + r.stderr[-2000:]
    assert checkpoint(two) == ck

    # piece 2: resumed to the end (another --checkpoint-every: it does not change the run)
    r = run(h1_cmd(c, two, "--checkpoint-every", "1e9"))
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "resuming from" in r.stdout and f"at step {ck['iter']}" in r.stdout

    # bit-identical: every probe row and the fill-end row
    a, b = (one / "probes.csv").read_bytes(), (two / "probes.csv").read_bytes()
    assert a == b
    assert (one / "fill_end.csv").read_bytes() == (two / "fill_end.csv").read_bytes()
    rows = list(csv.DictReader(open(two / "probes.csv")))
    steps = [int(r["step"]) for r in rows]
    assert steps == sorted(set(steps)) and steps[0] == 0 and len(steps) == len(set(steps))
    s1, s2 = json.loads((one / "summary.json").read_text()), json.loads((two / "summary.json").read_text())
    assert s2["resumed_at_steps"] == [ck["iter"]] and s1["resumed_at_steps"] == []
    assert steps[-1] == s1["fill_steps"] + s1["discharge_steps"] - (s1["fill_steps"] + s1["discharge_steps"]) % s1["out_every"]
    timing = ("elapsed_s", "particle_steps_per_s", "command", "resumed_at_steps")
    assert {k: v for k, v in s1.items() if k not in timing} == {k: v for k, v in s2.items() if k not in timing}
    assert checkpoint(two)["finished"] and not list(two.glob("*.bin.gz"))

    # finished: the same command again does nothing and keeps the files
    r = run(h1_cmd(c, two, "--checkpoint-every", "1e9"))
    assert r.returncode == 0 and "finished already" in r.stdout, r.stdout[-2000:]
    assert (two / "probes.csv").read_bytes() == b
