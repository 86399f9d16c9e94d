"""docs/validation.md is made from the comparisons' outputs and the tests' output (compare/validation.py)."""
import json

from compare import validation

SINGLE = {  # python -m compare CASE.toml --replicas 1 (compare/case.py)
    "case": "cases/SC-wall.toml", "engines": {},
    "checks": {
        "liggghts": [{"kind": "figure", "name": "restitution", "deviation": 1e-9, "tolerance": 1e-6, "ok": True},
                     {"kind": "series", "name": "force_z_n", "deviation": 0.03, "tolerance": 0.05, "ok": True}],
        "yade": [{"kind": "figure", "name": "restitution", "deviation": 0.002, "tolerance": 0.001, "ok": False},
                 {"kind": "window", "name": "force_z_n@[0,1]", "deviation": float("nan"), "tolerance": 0, "ok": False},
                 {"kind": "series", "name": "force_z_n", "deviation": 0.01, "tolerance": 0.05, "ok": True}]},
    "references": {"checks": [{"kind": "figure", "name": "restitution", "deviation": 0.1, "tolerance": 0.02, "ok": False}],
                   "explained": []},
}
ENSEMBLE = {  # python -m compare CASE.toml (compare/ensemble.py)
    "case": "cases/squeeze.toml", "replicas": 4, "replicas_differ_by": "x", "perturb": [],
    "references": {"liggghts": {"divergence_time_s": 0.1, "checks": [
        {"kind": "window mean", "name": "lid_force_z_n", "window": "late", "deviation": 0.08, "tolerance": 0.1, "ok": True},
        {"kind": "figure", "name": "height_m", "window": "", "deviation": 0.3, "tolerance": 0.1, "ok": True},
        {"kind": "series", "name": "ke_j", "window": "before t_d", "deviation": 1e-12, "tolerance": 0.05, "ok": True}]}},
}
SC_RESULTS = {  # python -m compare SC-wall --model hooke (compare/report.py, results.json)
    "setup": "SC-wall", "model": "hooke", "failures": [],
    "results": [{"run": "e0.5", "e": 0.5, "angle": 0.0, "engines": {},
                 "check_vs_liggghts": {"restitution": {"ok": True, "diff": 2e-7},
                                       "max_overlap_m": {"ok": True, "diff": -5e-7}}},
                {"run": "e0.9", "e": 0.9, "angle": 0.0, "engines": {},
                 "check_vs_liggghts": {"restitution": {"ok": True, "diff": 1e-8},
                                       "max_overlap_m": {"ok": True, "diff": 1e-9}}}],
}


def write(d, folder, name, data):
    (d / folder).mkdir(parents=True)
    (d / folder / name).write_text(json.dumps(data))


def test_the_page_has_a_row_per_comparison_with_its_largest_deviation(tmp_path):
    d = tmp_path / "compare"
    write(d, "case-SC-wall", "figures.json", SINGLE)
    write(d, "case-squeeze", "figures.json", ENSEMBLE)
    write(d, "SC-wall-hooke", "results.json", SC_RESULTS)
    (d / "throughput-bed-20k").mkdir()  # not a comparison: skipped
    out = tmp_path / "validation.md"
    assert validation.main(["--no-cargo", "--compare-dir", str(d), "--out", str(out)]) == 0
    text = out.read_text()
    rows = [line for line in text.splitlines() if line.startswith("| ") and not line.startswith("| folder")]
    assert rows == [
        "| SC-wall-hooke | SC-wall --model hooke (hand-written decks) | single run | talus[liggghts] vs liggghts "
        "| 4 of 4 | 0.5 (5e-07 of 1e-06) | e0.5: max_overlap_m (rel) |",
        "| case-SC-wall | cases/SC-wall.toml | single run | talus[liggghts] vs liggghts | 2 of 2 "
        "| 0.6 (0.03 of 0.05) | force_z_n (series) |",
        "| case-SC-wall | cases/SC-wall.toml | single run | talus[yade] vs yade | 1 of 3 **outside** "
        "| inf (nan of 0) | force_z_n@[0,1] (window) |",
        "| case-squeeze | cases/squeeze.toml | ensembles of 4 | talus[liggghts] vs liggghts | 3 of 3 "
        "| 3 (0.3 of 0.1) | height_m (figure) |",
        "| case-SC-wall | cases/SC-wall.toml | single run | liggghts vs yade | 0 of 1 **outside** "
        "| 5 (0.1 of 0.02) | restitution (figure) |",
    ]
    assert "3 comparison folders; 10 of 12 checks of talus against a reference within tolerance." in text
    assert "Not run for this page (`--no-cargo`)" in text
    assert f"python3 -m compare validation --out {out} --compare-dir {d} --no-cargo" in text
    # the same outputs give the same page
    assert validation.main(["--no-cargo", "--compare-dir", str(d), "--out", str(out)]) == 0
    assert out.read_text() == text


CARGO_OUTPUT = """   Compiling talus v0.1.0
    Finished `release` profile [optimized] target(s) in 1.00s
     Running tests/demo.rs (target/release/deps/demo-0123)

running 3 tests
test a_prints_its_figures ... pull-off 6.28e-4 N, ratio 1.00000
  second line
ok
test b_is_silent ... ok
test c_fails ... thread 'c_fails' panicked at tests/demo.rs:20:5:
off by 2%
note: run with `RUST_BACKTRACE=1` environment variable to display a backtrace
FAILED

failures:
    c_fails

test result: FAILED. 2 passed; 1 failed; 0 ignored; 0 measured; 0 filtered out; finished in 3.21s
"""
SOURCE = """//! Demo tests (issue 14, part 1). More words.

/// Prints its figures. And more.
#[test]
fn a_prints_its_figures() {}

#[test]
fn b_is_silent() {}

/// Fails, e.g. by 2%: on purpose.
#[test]
#[ignore = "never"]
fn c_fails() {}
"""


def test_each_test_has_its_purpose_result_and_printed_figures(tmp_path):
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "demo.rs").write_text(SOURCE)
    res = validation.test_results("ci", files=["demo"], runner=lambda name, profile: (101, CARGO_OUTPUT), root=tmp_path)
    text = "\n".join(validation.tests_section(res, "cargo test"))
    assert "### tests/demo.rs\n\nDemo tests.\n" in text
    assert "| `a_prints_its_figures` | Prints its figures. | pass |" in text
    assert "| `b_is_silent` | b is silent | pass |" in text
    assert "| `c_fails` | Fails, e.g. by 2%: on purpose. | **FAIL** |" in text
    assert "```\npull-off 6.28e-4 N, ratio 1.00000\n  second line\n```" in text
    assert "```\n(failed:)\noff by 2%\n```" in text
    assert "2 of 3 tests passed." in text
    assert "finished in" not in text and "`b_is_silent`:" not in text
