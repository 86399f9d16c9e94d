"""python -m compare throughput --repeat N: the rounds alternate the order of the runs,
and each figure is the median of the ratios measured within a round."""

import pytest

from compare import __main__ as cli
from compare import engines, h1, rounds


def test_odd_rounds_run_the_jobs_backward_and_results_keep_the_jobs_order():
    ran = []
    jobs = [(name, (lambda name=name: ran.append(name) or len(name))) for name in ("a", "bb", "ccc")]
    res, order = rounds.run_jobs(jobs, 0)
    assert order == ["a", "bb", "ccc"] and ran == order
    ran.clear()
    res, order = rounds.run_jobs(jobs, 1)
    assert order == ["ccc", "bb", "a"] and ran == order
    assert list(res) == ["a", "bb", "ccc"] and res == {"a": 1, "bb": 2, "ccc": 3}
    assert rounds.order(jobs, 2) == jobs


def _round(talus, other):
    return {"particle_steps_per_s": {"talus": talus, "other": other}, "talus_over": {"other": talus / other},
            "order": ["talus", "other"]}


def test_the_figure_is_the_median_of_the_ratios_within_rounds_not_the_ratio_of_median_rates():
    # the machine drifts: the rates move together, the ratio within a round much less
    each = [_round(10.0, 5.0), _round(4.0, 2.5), _round(6.0, 2.5)]
    s = rounds.summarise(each)
    assert s["rounds"] == 3
    assert s["talus_over_median"]["other"] == pytest.approx(2.0, rel=1e-15)
    assert s["talus_over_range"]["other"] == [pytest.approx(1.6), pytest.approx(2.4)]
    # the median rates' ratio would be 6 / 2.5 = 2.4: not what is reported
    med = s["particle_steps_per_s_median"]
    assert med["talus"] / med["other"] == pytest.approx(2.4)
    assert [r["talus_over"]["other"] for r in s["each_round"]] == [2.0, 1.6, 2.4]
    # an even number of rounds: the middle two's mean
    assert rounds.summarise(each + [_round(3.0, 1.0)])["talus_over_median"]["other"] == pytest.approx(2.2)


def test_rounds_with_different_ratios_are_refused():
    other = {"particle_steps_per_s": {"talus": 1.0}, "talus_over": {"else": 1.0}}
    with pytest.raises(ValueError, match="round 1"):
        rounds.summarise([_round(2.0, 1.0), other])
    with pytest.raises(ValueError, match="no rounds"):
        rounds.summarise([])


def _fake_h1(monkeypatch, calls):
    summ = {"particles": 100, "steps": 1000, "timestep_s": 1e-5, "fill_end_time_s": 0.004,
            "particle_steps_per_s": 4.0e6}

    def talus(setup, convention, work, max_steps=None, ranks=1, threads=None, reuse=False):
        calls.append(("talus", ranks, threads))
        s = dict(summ)
        s["particle_steps_per_s"] = {(1, 1): 4.0e6, (2, None): 7.0e6, (1, 2): 6.0e6}[(ranks, threads)]
        return None, s

    def liggghts(setup, work, fill, discharge, dt, skin, reuse=False):
        calls.append(("liggghts", fill, discharge))
        return None, None, "log"

    monkeypatch.setattr(engines, "run_talus_h1", talus)
    monkeypatch.setattr(engines, "run_liggghts_h1", liggghts)
    monkeypatch.setattr(engines, "liggghts_loop_seconds", lambda log: (50.0, 1000))
    monkeypatch.setattr(h1, "_case_numbers", lambda setup: {"skin": 1e-3, "discharge": 0.5})
    return summ


def test_h1_rounds_reverse_and_a_backward_round_takes_the_fill_end_from_an_earlier_round(monkeypatch, tmp_path):
    calls = []
    _fake_h1(monkeypatch, calls)
    r0, first = h1.throughput("H1-small", ["talus", "liggghts"], tmp_path, k=0)
    assert r0["order"] == ["talus", "liggghts", "talus_2_ranks", "talus_2_threads"]
    assert calls[1] == ("liggghts", 0.004, 0.5)
    # LIGGGHTS: 100 particles x 1000 steps / 50 s = 2,000 particle-steps/s
    assert r0["talus_over"]["liggghts"] == pytest.approx(4.0e6 / 2.0e3)
    assert r0["talus_over"]["talus_2_threads/talus"] == pytest.approx(1.5)
    calls.clear()
    r1, _ = h1.throughput("H1-small", ["talus", "liggghts"], tmp_path, k=1, first=first)
    assert r1["order"] == ["talus_2_threads", "talus_2_ranks", "liggghts", "talus"]
    assert calls[2] == ("liggghts", 0.004, 0.5) and calls[3] == ("talus", 1, 1)
    assert r1["talus_over"] == r0["talus_over"]
    # backward without talus's summary: LIGGGHTS would not know where the fill ends
    with pytest.raises(ValueError, match="before talus"):
        h1.throughput("H1-small", ["talus", "liggghts"], tmp_path, k=1)


@pytest.mark.parametrize("argv", [["throughput", "H1-small", "--repeat", "0"], ["SC-wall", "--repeat", "2"]])
def test_repeat_is_refused_outside_throughput_or_below_one(argv, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    assert "--repeat" in capsys.readouterr().err


def test_the_window_in_two_rounds_on_h1_small(tmp_path):
    """`compare window --repeat 2` on H1-small (its own end-of-fill checkpoint, made once):
    the second round runs backward, every talus window ends in the same state, and the
    figures are the medians of the rounds' ratios."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    r = subprocess.run([sys.executable, "-m", "compare", "window", "--case", "H1-small", "--steps", "100",
                        "--fill-steps", "100", "--engines", "talus", "--repeat", "2", "--out", tmp_path],
                       cwd=root, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    rounds_ = [json.loads((tmp_path / f"window-round-{k}.json").read_text()) for k in (1, 2)]
    assert rounds_[1]["order"] == list(reversed(rounds_[0]["order"]))
    assert all(x["talus_windows_same_state"] for x in rounds_)
    assert rounds_[0]["runs"]["talus_window_1_thread"]["state_hash"] == rounds_[1]["runs"]["talus_window_1_thread"]["state_hash"]
    s = json.loads((tmp_path / "window.json").read_text())
    assert s["rounds"] == 2
    for k, v in s["talus_over_median"].items():
        each = [x["ratios"][k] for x in rounds_]
        assert v == pytest.approx(sum(each) / 2, rel=1e-12)
        assert s["talus_over_range"][k] == [min(each), max(each)]
        assert s["targets"][k]["met"] == (v >= s["targets"][k]["at_least"])


def test_the_summary_names_a_bare_engine_ratio_talus_over_it(capsys):
    each = [{"particle_steps_per_s": {"talus": 4.0, "liggghts": 2.0, "talus_2_threads": 6.0},
             "talus_over": {"liggghts": 2.0, "talus_2_threads/talus": 1.5}, "order": []}]
    rounds.print_summary({"setup": "x", **rounds.summarise(each)})
    lines = capsys.readouterr().out.splitlines()
    assert any(line.split()[:2] == ["talus/liggghts", "2.00"] for line in lines)
    assert any(line.split()[:2] == ["talus_2_threads/talus", "1.50"] for line in lines)
