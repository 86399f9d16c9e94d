"""docs/benchmarks.md is made from its records (compare/benchpage.py)."""
import json

from compare import benchpage


def test_the_page_is_made_from_the_records_and_the_shipped_page_is_current(tmp_path):
    ab = {"baseline": {"rev": "abc", "commit": "abcdef0123456789", "binary": "x"}, "current": {"commit": "fed", "binary": "y"},
          "threads": 1, "repeat": 3, "notes": [],
          "workloads": [{"workload": "bed-20k", "ratio_median": 1.234, "ratio_range": [1.2, 1.3], "ratios": [1.2, 1.234, 1.3],
                         "current": {"particle_steps_per_s_median": 3.0e6, "state_hashes": ["h"]},
                         "baseline": {"particle_steps_per_s_median": 2.4e6, "state_hashes": ["h"]}}]}
    res = tmp_path / "ab.json"
    res.write_text(json.dumps(ab))
    records = tmp_path / "records"
    benchpage.record(res, "bed-ab", "python3 -m compare ab --baseline abc", records)
    text = benchpage.page(records)
    assert "## bed-ab" in text and "python3 -m compare ab --baseline abc" in text
    assert "| bed-20k | **1.234** | 1.200-1.300 |" in text
    # the repository's own page is what its records make
    assert benchpage.main(["page", "--check"]) == 0
