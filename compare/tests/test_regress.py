"""python -m compare regress: a golden file written, matched, and missed for the right reasons."""

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "cases"


def regress(*args):
    return subprocess.run([sys.executable, "-m", "compare", "regress", *map(str, args)], cwd=ROOT, capture_output=True, text=True)


def copy_case(tmp, name, edit=lambda t: t):
    p = tmp / name
    p.write_text(edit((CASES / name).read_text()))
    return p


def test_a_golden_file_matches_its_own_run_and_junit_lists_every_check(tmp_path):
    case = copy_case(tmp_path, "SC-wall.toml")
    g = tmp_path / "g.json"
    r = regress(case, "--golden", g, "--update-golden")
    assert r.returncode == 0 and g.exists(), r.stderr
    r = regress(case, "--golden", g, "--junit", tmp_path / "j.xml")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "same bits" in r.stdout
    suite = ET.parse(tmp_path / "j.xml").getroot().find("testsuite")
    names = {tc.get("name") for tc in suite.iter("testcase")}
    assert {"restitution", "max_overlap_m", "p1_vz_m_s", "plate_force_z_n"} <= names
    assert suite.get("failures") == "0"


def test_changed_physics_fails_naming_the_figure_and_the_column(tmp_path):
    case = copy_case(tmp_path, "SC-wall.toml")
    g = tmp_path / "g.json"
    assert regress(case, "--golden", g, "--update-golden").returncode == 0
    case.write_text(case.read_text().replace("restitution = 0.5", "restitution = 0.49"))
    r = regress(case, "--golden", g, "--junit", tmp_path / "j.xml")
    assert r.returncode == 1
    assert "OUTSIDE TOLERANCE: restitution" in r.stdout and "p1_vz_m_s" in r.stdout
    failed = [tc.get("name") for tc in ET.parse(tmp_path / "j.xml").getroot().iter("testcase") if tc.find("failure") is not None]
    assert "restitution" in failed


def test_a_small_change_within_a_loose_tolerance_passes_and_windows_are_checked(tmp_path):
    loose = "figure_rel = 1e-6\nseries_range = 1e-6\nwindow_mean = 1e-6"
    case = copy_case(tmp_path, "SC-wall.toml", lambda t: t.replace(loose, "figure_rel = 0.05\nseries_range = 0.5\nwindow_mean = 0.001\nwindows = [[0.003, 0.004]]\nignore = [\"contacts\"]"))
    g = tmp_path / "g.json"
    assert regress(case, "--golden", g, "--update-golden").returncode == 0
    case.write_text(case.read_text().replace("restitution = 0.5", "restitution = 0.49"))
    r = regress(case, "--golden", g)
    # the figures move by less than 5%, the series by less than half their range; after
    # the rebound (the window) the sphere's height grows at another speed
    assert r.returncode == 1, r.stdout
    bad = [line for line in r.stdout.splitlines() if "OUTSIDE" in line]
    assert bad and all("mean over [0.003, 0.004]" in line for line in bad), r.stdout


def test_missing_golden_other_steps_and_bad_tolerances_are_errors(tmp_path):
    case = copy_case(tmp_path, "SC-wall.toml")
    r = regress(case, "--golden", tmp_path / "none.json")
    assert r.returncode == 2 and "--update-golden" in r.stderr
    g = tmp_path / "g.json"
    assert regress(case, "--golden", g, "--update-golden", "--steps", "100").returncode == 0
    r = regress(case, "--golden", g)
    assert r.returncode == 2 and "100 steps" in r.stderr
    bad = copy_case(tmp_path, "SC-wall.toml", lambda t: t.replace("figure_rel = 1e-6", "figure_rel = -1"))
    r = regress(bad, "--golden", g)
    assert r.returncode == 2 and "compare.figure_rel = -1" in r.stderr
