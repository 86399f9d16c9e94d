"""Ensemble verdicts (compare/ensemble.py): the test, the divergence time, the windows,
and both directions of the power check on a chaotic case against LIGGGHTS."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from compare import ensemble

ROOT = Path(__file__).resolve().parents[2]


def test_welch_agrees_within_scatter_plus_margin_and_differs_beyond():
    rng = np.random.default_rng(1)
    a = 10.0 + rng.normal(0, 1.0, 6)
    b = 10.0 + rng.normal(0, 1.0, 6)
    assert ensemble.welch(a, b, 0.1)["agrees"]
    # a shift of 5 standard deviations of the scatter, with a margin of 0.1
    w = ensemble.welch(a + 5.0, b, 0.1)
    assert not w["agrees"] and w["p"] < 0.05
    # the same shift inside a margin of 6 agrees
    assert ensemble.welch(a + 5.0, b, 6.0)["agrees"]
    # what it detects with 80% power: more than the margin, less than the shift it found
    assert 0.1 < w["detectable"] < 5.0


def test_welch_without_scatter_is_the_margin_alone():
    assert ensemble.welch([1.0, 1.0], [1.05, 1.05], 0.1)["agrees"]
    assert not ensemble.welch([1.0, 1.0], [1.2, 1.2], 0.1)["agrees"]
    assert ensemble.welch([1.0], [1.2], 0.3)["detectable"] == 0.3


def series(t, y, phase="a"):
    return {"time_s": np.asarray(t, float), "c": np.asarray(y, float), "phase": np.array([phase] * len(t))}


def test_the_divergence_time_is_where_replicas_spread_past_half_the_tolerance():
    t = np.linspace(0.0, 1.0, 101)
    base = np.sin(6 * t)
    # the replica parts from replica 0 exponentially: 1e-9 growing 100-fold every 0.1 s
    runs = [(series(t, base), {}), (series(t, base + 1e-9 * 100 ** (t / 0.1)), {})]
    tol = {"series": {}, "series_range": 0.05}
    td = ensemble.divergence_time(runs, ["c"], {"c": 2.0}, tol)
    # 1e-9 * 100^(t/0.1) > 0.5 * 0.05 * 2 at t = 0.1 * log(5e7) / log(100)
    assert td == pytest.approx(0.1 * np.log(0.05e9) / np.log(100.0), abs=0.011)
    assert ensemble.divergence_time(runs[:1] * 2, ["c"], {"c": 2.0}, tol) is None


def test_windows_are_the_phases_cut_at_the_divergence_time():
    t = np.linspace(0.0, 1.0, 101)
    s = series(t, t)
    s["phase"] = np.where(t < 0.4, "fall", "squeeze")
    tol = {"windows": []}
    w = ensemble.windows_after(tol, s, 0.25)
    assert [x[0] for x in w] == ["phase fall", "phase squeeze"]
    assert w[0][1] == 0.25 and w[1][1] == pytest.approx(0.4)
    # never parted: no statistics windows, the whole run step by step
    assert ensemble.windows_after(tol, s, None) == []
    assert [x[0] for x in ensemble.windows_after({"windows": [[0.5, 0.9]]}, s, 0.2)] == ["[0.5, 0.9] s"]


def compare_squeeze(tmp_path, *extra):
    """The squeeze case cut short (0.15 s of fall, 0.15 s of squeeze), 3 replicas per engine,
    against LIGGGHTS; LIGGGHTS's replicas are kept in DIR and reused by the next call."""
    cmd = [sys.executable, "-m", "compare", str(ROOT / "cases" / "squeeze.toml"), "--engines", "talus,liggghts",
           "--replicas", "3", "--set", "phase[0].duration=0.15", "--set", "phase[1].duration=0.15",
           "--out", str(tmp_path / "cmp"), "--reuse", *extra]
    r = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    figs = json.loads((tmp_path / "cmp" / "figures.json").read_text()) if (tmp_path / "cmp" / "figures.json").exists() else None
    return r, figs


def test_a_chaotic_case_agrees_by_ensembles_and_a_real_change_is_found(tmp_path):
    r, f = compare_squeeze(tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    lig = f["references"]["liggghts"]
    # the replicas part early in the fall; the statistics come from both phases
    assert lig["divergence_time_s"] is not None and lig["divergence_time_s"] < 0.15
    assert [w["name"] for w in lig["windows"]] == ["phase fall", "phase squeeze"]
    assert (tmp_path / "cmp" / "report.md").exists() and (tmp_path / "cmp" / "plots" / "x_hi_force_x_n.png").exists()
    # a null change (restitution changed by 1e-12) agrees
    r, _ = compare_squeeze(tmp_path, "--perturb", "material[0].restitution=0.600000000001")
    assert r.returncode == 0, r.stdout + r.stderr
    # the grains' friction 0.5 -> 0.3 is found, and so is their restitution 0.6 -> 0.3
    for change in ("material[0].friction=0.3", "material[0].restitution=0.3"):
        r, f = compare_squeeze(tmp_path, "--perturb", change)
        assert r.returncode == 1, change + ": " + r.stdout + r.stderr
        assert "DIFFERS" in r.stdout
        assert f["perturb"] == [change]
