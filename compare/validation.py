"""docs/validation.md: every cross-check and closed-form test with its current figure,
made by this script from the test and comparison outputs, never typed by hand.

    python3 -m compare validation [--out docs/validation.md] [--compare-dir out/compare]
                                  [--cargo-profile ci|release] [--no-cargo]

1. Closed-form and physics tests: runs `cargo test --profile PROFILE --test NAME --
   --nocapture --test-threads=1` for each file of TEST_FILES and reports every test
   function of it: its name, its purpose (the first sentence of the doc comment above
   its `#[test]`, read from the source; a test without one is described by its name,
   read as words), pass or fail, and the figures it printed, verbatim. `--no-cargo` skips this
   part (the page says so).
2. Comparisons against the reference codes: every COMPARE_DIR/*/figures.json that
   `python3 -m compare CASE.toml` (single runs, compare/case.py; ensembles,
   compare/ensemble.py) or the hand-written set-ups (SC-*, H1-*, compare/__main__.py)
   wrote, and every results.json of the hand-written SC set-ups (compare/report.py):
   for each comparison the case, the engines, how many checks are within tolerance,
   and the largest deviation as a fraction of its tolerance, named.

The page holds no dates, commits or timings, and everything on it is sorted, so the
same outputs give the same page.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

from . import tolerances
from .engines import ROOT

DEFAULT_OUT = Path("docs/validation.md")
DEFAULT_COMPARE_DIR = Path("out/compare")
DEFAULT_PROFILE = "ci"

# The integration tests that check the physics against closed forms or peer figures
# (tests/NAME.rs), in one place. Input checks, durability, MPI and storage-order tests
# (bit-for-bit sameness, not physics) are not listed.
TEST_FILES = [
    "adhesion",             # DMT and JKR pull-off against 4 pi gamma R and 3 pi gamma R
    "drag",                 # the drag paper's trends over seeded beds
    "ellipses",             # ellipses and dumbbells against the rigid-body impulse solution
    "fields",               # coarse-grained fields against static balance
    "hopper_and_restart",   # H1-small: walls + gate carry the weight
    "integrators",          # energy conservation, order of convergence
    "periodic",             # periodic faces, Haff's law for a cooling gas
    "rolling",              # rolling resistance against its closed forms
    "single_collisions",    # restitution, Hertz and linear contact closed forms
    "two_d",                # 2D discs against Hertz with the curved radius
    "wall_motion",          # turning walls, the turntable's 2/7, the servo wall
    "walls",                # moving and removed walls, a shared STL edge
]

STATUS = {"ok": "pass", "FAILED": "**FAIL**", "ignored": "ignored"}
_TEST_LINE = re.compile(r"^test (\S+) \.\.\. ?(.*)$")
_PANIC = re.compile(r"^thread '.*' panicked at ")
# libtest's own lines, not the test's: a slow test's notice (a timing), the summary
_NOISE = re.compile(r"^test \S+ has been running for over \d+ seconds$|^test result: |^running \d+ tests?$")
_ABBREVIATIONS = ("e.g.", "i.e.", "cf.", "vs.", "etc.")


# ------------------------------------------------------------------ the tests' sources

def first_sentence(text):
    """The first sentence of a doc comment (up to its first '.', '!' or '?' followed by
    a space or the end, abbreviations such as e.g. excepted), on one line, without the
    issue numbers it cites (`(issue 14, part 1)`: the page names none)."""
    text = " ".join(text.split())
    text = re.sub(r"\s*\([^()]*\bissues?\s+#?\d+[^()]*\)", "", text)
    text = re.sub(r",?\s*\bissues?\s+#?\d+\b", "", text)
    for m in re.finditer(r"[.!?](\s|$)", text):
        head = text[: m.start() + 1]
        if head.endswith(_ABBREVIATIONS):
            continue
        return head
    return text


def doc_comments(source):
    """{test function name: the first sentence of its doc comment, or None}, for every
    `#[test]` function of a Rust source (doc lines `///` above the function, among its
    attributes)."""
    lines = source.splitlines()
    out = {}
    for i, line in enumerate(lines):
        if line.strip() != "#[test]":
            continue
        # the function: the first `fn NAME` after the attribute
        name = None
        for j in range(i + 1, min(i + 20, len(lines))):
            m = re.match(r"\s*(?:pub\s+)?(?:async\s+)?fn\s+(\w+)", lines[j])
            if m:
                name = m.group(1)
                break
        if name is None:
            continue
        doc = []
        k = i - 1  # the doc lines and attributes just above #[test]
        while k >= 0:
            s = lines[k].strip()
            if s.startswith("///"):
                doc.insert(0, s[3:].strip())
            elif not (s.startswith("#[") or s.startswith("//")):
                break
            k -= 1
        for j in range(i + 1, len(lines)):  # and any between #[test] and fn
            s = lines[j].strip()
            if s.startswith("///"):
                doc.append(s[3:].strip())
            elif not s.startswith("#["):
                break
        out[name] = first_sentence(" ".join(doc)) if doc else None
    return out


def name_as_sentence(name):
    """A test without a doc comment is described by its name: `walls_hold` -> `walls hold`
    (not capitalised: a name's first word may be a symbol, `dmt`, `h1`)."""
    return " ".join(name.split("_"))


def file_purpose(source):
    """The first sentence of a test file's `//!` comment."""
    doc = [s.strip()[3:].strip() for s in source.splitlines() if s.strip().startswith("//!")]
    return first_sentence(" ".join(doc)) if doc else ""


# ------------------------------------------------------------------ cargo test output

def parse_libtest(text):
    """{test name: {"status": ok|FAILED|ignored, "lines": [printed lines], "panic": [message]}}
    from `cargo test ... -- --nocapture --test-threads=1` with stderr merged into stdout:
    each test's `test NAME ... ` line, what it printed, then its status."""
    tests = {}
    current = None
    in_panic = False
    for raw in text.splitlines():
        line = raw.rstrip()
        m = _TEST_LINE.match(line)
        if m and not _NOISE.match(line):
            name, rest = m.group(1), m.group(2)
            current = tests.setdefault(name, {"status": None, "lines": [], "panic": []})
            in_panic = False
            if not rest:
                continue
            line = rest  # what the test printed first, on its `test NAME ... ` line
        if current is None:
            continue
        if line in STATUS or line.startswith("ignored, "):  # `ignored, REASON` for #[ignore = "REASON"]
            current["status"] = line.split(",")[0]
            current = None
            continue
        if _NOISE.match(line):
            continue
        if _PANIC.match(line):
            in_panic = True
            continue
        if in_panic:
            if line.startswith("note: run with `RUST_BACKTRACE") or line.startswith("stack backtrace:"):
                in_panic = False
                continue
            current["panic"].append(line)
        else:
            current["lines"].append(line)
    return tests


def run_test_file(name, profile):
    """(exit code, merged output) of one test file's run."""
    cmd = ["cargo", "test", "--profile", profile, "--test", name, "--", "--nocapture", "--test-threads=1"]
    env = dict(os.environ, RUST_BACKTRACE="0", CARGO_TERM_COLOR="never")
    print("validation: " + " ".join(cmd), file=sys.stderr, flush=True)
    p = subprocess.run(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return p.returncode, p.stdout


def test_results(profile, files=TEST_FILES, runner=run_test_file, root=ROOT):
    """For each test file: its purpose, its tests with purpose, status and printed lines."""
    out = []
    for name in sorted(files):
        src = (root / "tests" / f"{name}.rs").read_text()
        docs = doc_comments(src)
        code, text = runner(name, profile)
        ran = parse_libtest(text)
        by_leaf = {k.rsplit("::", 1)[-1]: v for k, v in ran.items()}
        tests = []
        for t in sorted(docs):
            r = ran.get(t) or by_leaf.get(t) or {"status": None, "lines": [], "panic": []}
            tests.append({"name": t, "purpose": docs[t] or name_as_sentence(t),
                          "status": r["status"], "lines": r["lines"], "panic": r["panic"]})
        out.append({"file": name, "purpose": file_purpose(src), "exit": code, "tests": tests,
                    "built": "running " in text})
    return out


# ------------------------------------------------------------------ comparison outputs

def _ratio(dev, tol):
    """A deviation as a fraction of its tolerance (inf where it cannot be measured)."""
    try:
        dev, tol = abs(float(dev)), float(tol)
    except (TypeError, ValueError):
        return math.inf
    if math.isnan(dev):
        return math.inf
    if tol == 0:
        return 0.0 if dev == 0 else math.inf
    return dev / tol


def _case_label(case):
    p = Path(str(case))
    if p.is_absolute():
        try:
            return str(p.relative_to(ROOT))
        except ValueError:
            return p.name
    return str(p)


def _check(name, kind, dev, tol, ok):
    return {"name": name, "kind": kind, "deviation": dev, "tolerance": tol, "ok": bool(ok),
            "ratio": _ratio(dev, tol)}


def _case_checks(cs):
    out = []
    for c in cs:
        name = c["name"] + (f" @ {c['window']}" if c.get("window") else "")
        out.append(_check(name, c.get("kind", ""), c.get("deviation"), c.get("tolerance"), c.get("ok")))
    return out


def _sc_rows(data):
    """The hand-written SC set-ups (figures.json with `runs`, results.json with `results`)."""
    table = dict(tolerances.SC)
    table.update(tolerances.SC_OBLIQUE)
    table.update({k: tuple(v) for k, v in (data.get("tolerances") or {}).items()})
    runs = data.get("results", data.get("runs")) or []
    refs = sorted({k[len("check_vs_"):] for r in runs for k in r if k.startswith("check_vs_")})
    rows = []
    for ref in refs:
        checks = []
        for r in runs:
            for key, c in (r.get(f"check_vs_{ref}") or {}).items():
                kind, tol = table[key][0], table[key][1]
                checks.append(_check(f"{r['run']}: {key}", kind, c.get("diff"), tol, c.get("ok")))
        rows.append({"case": f"{data.get('setup', '?')} --model {data.get('model', '?')} (hand-written decks)",
                     "how": "single run", "engines": f"talus[{ref}] vs {ref}", "checks": checks})
    return rows


def _h1_rows(data):
    """The hand-written H1 set-ups (compare/h1.py): the discharge rate and the walls' share
    of the weight of talus against each reference, and each engine's force balance."""
    eng = data.get("engines", {})
    rows = []
    for tname, ref in sorted(tuple(p) for p in data.get("pairs", [])):
        t, g = eng[tname], eng[ref]
        checks = []
        if t.get("discharge_rate_kg_s") and g.get("discharge_rate_kg_s"):
            dr = t["discharge_rate_kg_s"] / g["discharge_rate_kg_s"] - 1.0
            checks.append(_check("discharge_rate_kg_s", "rel", dr, tolerances.H1_DISCHARGE_RATE_REL,
                                 abs(dr) <= tolerances.H1_DISCHARGE_RATE_REL))
        if "wall_share" in t and "wall_share" in g:
            ds = t["wall_share"] - g["wall_share"]
            checks.append(_check("wall_share", "abs", ds, tolerances.H1_FORCE_SPLIT_OF_WEIGHT,
                                 abs(ds) <= tolerances.H1_FORCE_SPLIT_OF_WEIGHT))
        for n in (tname, ref):
            if "force_balance" in eng[n]:
                fb = eng[n]["force_balance"] - 1.0
                checks.append(_check(f"{n}: force_balance", "abs", fb, tolerances.H1_BALANCE,
                                     abs(fb) <= tolerances.H1_BALANCE))
        rows.append({"case": f"{data.get('setup', '?')} (hand-written decks)", "how": "single run",
                     "engines": f"{tname} vs {ref}", "checks": checks})
    return rows


def comparison_rows(data):
    """(rows of talus against a reference, rows of the references against each other)
    of one figures.json or results.json."""
    if "results" in data or "runs" in data:
        return _sc_rows(data), []
    if "pairs" in data:
        return _h1_rows(data), []
    case = _case_label(data.get("case", "?"))
    if "replicas" in data:  # an ensemble (compare/ensemble.py)
        how = f"ensembles of {data['replicas']}"
        rows = [{"case": case, "how": how, "engines": f"talus[{ref}] vs {ref}", "checks": _case_checks(r.get("checks", []))}
                for ref, r in sorted(data.get("references", {}).items())]
        return rows, []
    rows = [{"case": case, "how": "single run", "engines": f"talus[{ref}] vs {ref}", "checks": _case_checks(cs)}
            for ref, cs in sorted(data.get("checks", {}).items())]
    cross = []
    if "references" in data and "checks" in data["references"]:
        cross.append({"case": case, "how": "single run", "engines": "liggghts vs yade",
                      "checks": _case_checks(data["references"]["checks"])})
    return rows, cross


def read_comparisons(compare_dir):
    """Every comparison in the folders of compare_dir: (rows, cross rows, unreadable),
    each row with its folder. A folder's figures.json is read, else its results.json."""
    rows, cross, bad = [], [], []
    d = Path(compare_dir)
    folders = sorted(p for p in d.iterdir() if p.is_dir()) if d.is_dir() else []
    for f in folders:
        path = next((f / n for n in ("figures.json", "results.json") if (f / n).is_file()), None)
        if path is None:
            continue
        try:
            r, c = comparison_rows(json.loads(path.read_text()))
        except (ValueError, KeyError, TypeError, IndexError) as e:
            bad.append((f.name, f"{path.name}: {type(e).__name__}: {e}"))
            continue
        for row in r + c:
            row["folder"] = f.name
        rows += r
        cross += c
    key = lambda r: (r["folder"], r["engines"])  # noqa: E731
    return sorted(rows, key=key), sorted(cross, key=key), bad


# ------------------------------------------------------------------ the page

def _g(x):
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf"
    return f"{x:.3g}"


def _cell(s):
    return str(s).replace("|", "\\|")


def worst(checks):
    """The check of largest deviation relative to its tolerance (the first by name among equals)."""
    if not checks:
        return None
    return min(checks, key=lambda c: (-c["ratio"], c["name"]))


def comparison_table(rows, caption_ok="within tolerance"):
    lines = ["| folder | case | compared | engines | " + caption_ok + " | largest deviation / tolerance | of |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        n_ok = sum(c["ok"] for c in r["checks"])
        n = len(r["checks"])
        mark = "" if n_ok == n else " **outside**"
        w = worst(r["checks"])
        if w is None:
            big, of = "-", "no checks"
        else:
            big = f"{_g(w['ratio'])} ({_g(abs(float(w['deviation'])) if w['deviation'] is not None else 'nan')} of {_g(w['tolerance'])})"
            of = f"{w['name']}" + (f" ({w['kind']})" if w["kind"] else "")
        lines.append(f"| {_cell(r['folder'])} | {_cell(r['case'])} | {r['how']} | {_cell(r['engines'])} | "
                     f"{n_ok} of {n}{mark} | {big} | {_cell(of)} |")
    return lines


def tests_section(results, command):
    lines = ["## Closed-form and physics tests", ""]
    if results is None:
        lines += ["Not run for this page (`--no-cargo`). Without `--no-cargo` the page lists every test of "
                  + ", ".join(f"`tests/{f}.rs`" for f in sorted(TEST_FILES)) + ".", ""]
        return lines
    n = sum(len(f["tests"]) for f in results)
    passed = sum(t["status"] == "ok" for f in results for t in f["tests"])
    lines += [f"Each file was run by `{command}` (`--nocapture`, so what a test prints is shown as it printed it). "
              f"{passed} of {n} tests passed. A test's purpose is the first sentence of its doc comment, or, "
              "where it has none, its name read as words.", ""]
    for f in results:
        lines += [f"### tests/{f['file']}.rs", ""]
        if f["purpose"]:
            lines += [f["purpose"], ""]
        if not f["built"]:
            lines += [f"**Did not run** (cargo exited {f['exit']} before running any test).", ""]
        lines += ["| test | purpose | result |", "|---|---|---|"]
        for t in f["tests"]:
            st = STATUS.get(t["status"], "**not run**")
            lines.append(f"| `{t['name']}` | {_cell(t['purpose'])} | {st} |")
        lines.append("")
        for t in f["tests"]:
            if not t["lines"] and not t["panic"]:
                continue
            lines += [f"`{t['name']}`:", "", "```"] + t["lines"]
            if t["panic"]:
                lines += ["(failed:)"] + t["panic"]
            lines += ["```", ""]
    return lines


def comparisons_section(compare_dir, rows, cross, bad):
    lines = ["## Comparisons against the reference codes", ""]
    folders = sorted({r["folder"] for r in rows + cross})
    lines += [f"Read from `{compare_dir}`: the figures.json of every folder that `python3 -m compare CASE.toml` "
              "or a hand-written set-up (`python3 -m compare SC-wall --model hertz`, ...) wrote, or its results.json "
              "(`scripts/compare_all.sh` writes them all). talus runs in each reference's convention (`talus[liggghts]` "
              "against LIGGGHTS, and so on). A deviation is measured as the comparison measures it (relative to the "
              "figure, to the series' range, or absolute: compare/case.py, compare/ensemble.py, compare/tolerances.py); "
              "`largest deviation / tolerance` is the largest over the comparison's checks, named in the last column. "
              "In an ensemble a check passes by a statistical test, so a mean difference can exceed its margin and pass.",
              ""]
    if not folders:
        lines += [f"No comparison outputs were found in `{compare_dir}`.", ""]
    else:
        n = sum(len(r["checks"]) for r in rows)
        n_ok = sum(c["ok"] for r in rows for c in r["checks"])
        lines += [f"{len(folders)} comparison folders; {n_ok} of {n} checks of talus against a reference within tolerance.", ""]
        lines += comparison_table(rows) + [""]
    if cross:
        lines += ["### The reference codes against each other", "",
                  "Where a comparison ran both LIGGGHTS and YADE, LIGGGHTS is checked against YADE with the same "
                  "tolerances; a disagreement is reported, not a failure (the two codes differ by their conventions; "
                  "each folder's report.md names the convention that explains it).", ""]
        lines += comparison_table(cross, "agree") + [""]
    if bad:
        lines += ["### Outputs that could not be read", "", "| folder | why |", "|---|---|"]
        lines += [f"| {_cell(f)} | {_cell(w)} |" for f, w in sorted(bad)] + [""]
    return lines


def page(command, test_command, results, compare_dir, rows, cross, bad):
    lines = ["# Validation", "",
             "Every closed-form and physics test of talus and every comparison against LIGGGHTS, YADE and LAMMPS, "
             "each with its current figure. This page is made by a script from the tests' output and the "
             "comparisons' figures.json files, never typed by hand; to make it again, run the comparisons "
             "(`scripts/compare_all.sh`, or `python3 -m compare CASE.toml` for one) and then:", "",
             f"    {command}", ""]
    lines += tests_section(results, test_command)
    lines += comparisons_section(compare_dir, rows, cross, bad)
    return "\n".join(lines).rstrip() + "\n"


def command_of(a):
    cmd = "python3 -m compare validation"
    if Path(a.out) != DEFAULT_OUT:
        cmd += f" --out {a.out}"
    if Path(a.compare_dir) != DEFAULT_COMPARE_DIR:
        cmd += f" --compare-dir {a.compare_dir}"
    if a.no_cargo:
        cmd += " --no-cargo"
    elif a.cargo_profile != DEFAULT_PROFILE:
        cmd += f" --cargo-profile {a.cargo_profile}"
    return cmd


def main(argv=None, runner=run_test_file):
    ap = argparse.ArgumentParser(prog="python -m compare validation", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"the page (default {DEFAULT_OUT})")
    ap.add_argument("--compare-dir", type=Path, default=DEFAULT_COMPARE_DIR,
                    help=f"the comparisons' output folders (default {DEFAULT_COMPARE_DIR}, scripts/compare_all.sh's)")
    ap.add_argument("--cargo-profile", choices=["ci", "release"], default=DEFAULT_PROFILE,
                    help="the cargo profile of the tests (default ci, scripts/test.sh's)")
    ap.add_argument("--no-cargo", action="store_true", help="do not run the tests; the page says they were not run")
    a = ap.parse_args(argv)
    compare_dir = a.compare_dir if a.compare_dir.is_absolute() else Path.cwd() / a.compare_dir
    results = None if a.no_cargo else test_results(a.cargo_profile, runner=runner)
    rows, cross, bad = read_comparisons(compare_dir)
    test_command = (f"cargo test --profile {a.cargo_profile} --test NAME -- --nocapture --test-threads=1")
    text = page(command_of(a), test_command, results, a.compare_dir, rows, cross, bad)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(text)
    if results is not None:
        n = sum(len(f["tests"]) for f in results)
        ok = sum(t["status"] == "ok" for f in results for t in f["tests"])
        print(f"tests: {ok} of {n} passed")
    n = sum(len(r["checks"]) for r in rows)
    print(f"comparisons: {len(rows)} (talus against a reference), {sum(c['ok'] for r in rows for c in r['checks'])} of {n} checks within tolerance")
    print(f"written: {a.out}")
    return 0
