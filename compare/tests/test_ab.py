"""`python -m compare ab`: the A/B benchmark against a baseline binary (compare/ab.py)."""
import json
import tomllib

import pytest

from compare import ab, engines


def test_rounds_alternate_abba():
    assert [ab.order(k) for k in range(4)] == [["baseline", "current"], ["current", "baseline"]] * 2


def test_the_ratio_is_the_median_of_within_round_ratios():
    def run(rate):
        return {"particle_steps_per_s": rate, "stage_seconds": {"forces": rate / 1e6}, "state_hash": "h"}
    # the rates drift by round; the ratios within a round are 2, 3, 4 (median 3), while the
    # medians of the rates (4 and 1.5) would give 2.67
    rounds = [{"order": ab.order(k), "current": run(c), "baseline": run(b)}
              for k, (c, b) in enumerate([(2.0, 1.0), (6.0, 2.0), (8.0, 2.0)])]
    s = ab.summarise("w", rounds)
    assert s["ratio_median"] == 3.0
    assert s["ratio_range"] == [2.0, 4.0]
    assert s["current"]["stage_seconds_median"] == {"forces": 6.0 / 1e6}


def test_workload_cases_are_valid_toml_without_the_compare_section(tmp_path):
    ws = ab.workloads(["bed-20k", "bed-20k-hooke", "H1-small"], tmp_path)
    hertz = tomllib.loads(ws[0].case_file.read_text())
    assert hertz["contact"]["model"] == "hertz" and len(hertz["wall"]) == 6
    # 20% of the Rayleigh time of a 0.975 mm sphere of E = 1 MPa, nu = 0.3, rho = 2500 (H1-small's
    # case file gives 1.07e-4 s for its 1.95 mm spheres: twice as large)
    assert hertz["simulation"]["timestep"] == pytest.approx(0.2 * 2.668e-4, rel=1e-3)
    assert tomllib.loads(ws[1].case_file.read_text())["contact"]["stiffness"]["kn"] == 200.0
    h1 = tomllib.loads(ws[2].case_file.read_text())
    assert "compare" not in h1 and h1["analysis"]["kind"] == "hopper"
    assert (tmp_path / "meshes" / "hopper.stl").exists()


def test_a_short_ab_of_a_binary_against_itself(tmp_path, capsys):
    # the same binary on both sides: the same states, ratios near 1 (timing noise aside)
    talus = str(engines.TALUS)
    code = ab.main(["--baseline", "HEAD", "--baseline-bin", talus, "--current-bin", talus, "--workloads", "bed-20k-hooke",
                    "--steps", "40", "--repeat", "2", "--out", str(tmp_path)])
    assert code == 0
    r = json.loads((tmp_path / "ab.json").read_text())
    w = r["workloads"][0]
    assert w["workload"] == "bed-20k-hooke" and len(w["ratios"]) == 2
    assert w["orders"] == [["baseline", "current"], ["current", "baseline"]]
    assert w["current"]["state_hashes"] == w["baseline"]["state_hashes"] and len(w["current"]["state_hashes"]) == 1
    assert all(0.2 < x < 5.0 for x in w["ratios"]), w["ratios"]
    assert "forces" in w["current"]["stage_seconds_median"]
    assert "current/baseline" in capsys.readouterr().out


def test_bad_arguments_are_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        ab.main(["--baseline", "HEAD", "--repeat", "0"])
    assert e.value.code == 2 and "--repeat 0" in capsys.readouterr().err
    talus = str(engines.TALUS)
    code = ab.main(["--baseline", "HEAD", "--baseline-bin", talus, "--current-bin", talus, "--workloads", "bed-7",
                    "--out", str(tmp_path)])
    assert code == 2 and "unknown workload `bed-7`" in capsys.readouterr().err
    code = ab.main(["--baseline", "no-such-rev-xyz", "--workloads", "H1-small", "--out", str(tmp_path)])
    assert code == 2 and "no-such-rev-xyz" in capsys.readouterr().err
