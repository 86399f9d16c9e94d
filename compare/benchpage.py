"""docs/benchmarks.md, made from measured results, never typed by hand.

    python3 -m compare benchmarks record RESULT.json --as NAME --command "THE COMMAND THAT MADE IT"
    python3 -m compare benchmarks page [--check]

`record` copies a result of `python3 -m compare ab` (ab.json) or `python3 -m compare
throughput` (throughput.json) into docs/benchmarks/NAME.json, with the command that
made it, the machine (processor, cores, memory) and the date it was recorded. `page`
writes docs/benchmarks.md from every record there: one section per record, its command,
machine and date, and its table. `--check` writes nothing and exits 1 where the page is
not what the records make (a test runs it, so the page cannot drift from its data).
"""
import argparse
import json
import os
import sys
import time
from pathlib import Path

from .engines import ROOT

DOCS = ROOT / "docs"
RECORDS = DOCS / "benchmarks"
PAGE = DOCS / "benchmarks.md"


def machine():
    """This machine: processor model, cores, memory (from /proc)."""
    model, mem = "unknown", None
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem = int(line.split()[1]) * 1024
                break
    except OSError:
        pass
    return {"processor": model, "cores": os.cpu_count(), "memory_bytes": mem}


def record(result_path, name, command, records=RECORDS):
    result = json.loads(Path(result_path).read_text())
    if "workloads" not in result and "talus_over" not in result and "talus_over_median" not in result:
        raise ValueError(f"{result_path}: neither an ab.json of `compare ab` nor a throughput.json of `compare throughput`")
    records.mkdir(parents=True, exist_ok=True)
    out = records / f"{name}.json"
    out.write_text(json.dumps({"command": command, "machine": machine(), "recorded": time.strftime("%Y-%m-%d"),
                               "result": result}, indent=1) + "\n")
    return out


def ab_section(r):
    res = r["result"]
    lines = [f"A/B: the tree at {res['current']['commit']} against {res['baseline']['rev']} "
             f"({str(res['baseline']['commit'])[:12]}), {res['repeat']} rounds alternated ABBA, {res['threads']} thread(s).", ""]
    lines += [f"Note: {n}" for n in res.get("notes", [])]
    lines += ["| workload | current / baseline, median | range | per round | M particle-steps/s, current | baseline | same state |",
              "|---|---|---|---|---|---|---|"]
    for w in res["workloads"]:
        lo, hi = w["ratio_range"]
        same = "yes" if w["current"]["state_hashes"] == w["baseline"]["state_hashes"] else "no"
        lines.append(f"| {w['workload']} | **{w['ratio_median']:.3f}** | {lo:.3f}-{hi:.3f} | "
                     f"{' '.join(f'{x:.3f}' for x in w['ratios'])} | {w['current']['particle_steps_per_s_median'] / 1e6:.3f} | "
                     f"{w['baseline']['particle_steps_per_s_median'] / 1e6:.3f} | {same} |")
    return lines


def throughput_section(r):
    res = r["result"]
    rates = res.get("particle_steps_per_s_median", res.get("particle_steps_per_s", {}))
    ratios = res.get("talus_over_median", res.get("talus_over", {}))
    ranges = res.get("talus_over_range", {})
    rounds = res.get("rounds", 1)
    setup = res.get("setup", "?")
    what = f" (`cases/bench/{setup}.toml`: the linear spring-dashpot bed, LAMMPS `gran/hooke/history` and `granular`)" \
        if setup.startswith("bed-") else ""
    lines = [f"Throughput of {setup}{what}: {rounds} round(s), the runs' order alternating; each ratio the "
             "median of the ratios measured within a round.", "",
             "| run | M particle-steps/s (median) |", "|---|---|"]
    lines += [f"| {k} | {v / 1e6:.3f} |" for k, v in rates.items()]
    lines += ["", "| ratio | median | range |", "|---|---|---|"]
    for k, v in ratios.items():
        lo, hi = ranges.get(k, [v, v])
        lines.append(f"| {k if '/' in k else 'talus/' + k} | **{v:.2f}** | {lo:.2f}-{hi:.2f} |")
    return lines


def page(records=RECORDS):
    lines = ["# Benchmarks", "",
             "Made by `python3 -m compare benchmarks page` from the records in `docs/benchmarks/` (each the JSON "
             "result of the command shown, with the machine and date it was measured on). Speed on this kind of "
             "machine moves by 10-50% from day to day, so every figure here is a ratio of runs made in one session, "
             "alternated; a rate is for reference only. To add or refresh a figure: run the command, then "
             "`python3 -m compare benchmarks record RESULT.json --as NAME --command \"...\"` and "
             "`python3 -m compare benchmarks page`.", ""]
    for p in sorted(records.glob("*.json")):
        r = json.loads(p.read_text())
        m = r["machine"]
        mem = f", {m['memory_bytes'] / 2**30:.0f} GiB" if m.get("memory_bytes") else ""
        lines += [f"## {p.stem}", "", f"    {r['command']}", "",
                  f"Measured on {m['processor']}, {m['cores']} cores{mem} (the record keeps the date).", ""]
        lines += ab_section(r) if "workloads" in r["result"] else throughput_section(r)
        lines.append("")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m compare benchmarks", description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n\n", 1)[1])
    sub = ap.add_subparsers(dest="what", required=True)
    rec = sub.add_parser("record", help="copy a result into docs/benchmarks/ with its command")
    rec.add_argument("result", type=Path)
    rec.add_argument("--as", dest="name", required=True, help="the record's name (docs/benchmarks/NAME.json)")
    rec.add_argument("--command", required=True, help="the command that made the result")
    pg = sub.add_parser("page", help="write docs/benchmarks.md from the records")
    pg.add_argument("--check", action="store_true", help="write nothing; exit 1 where the page is not current")
    a = ap.parse_args(argv)
    try:
        if a.what == "record":
            print(f"wrote {record(a.result, a.name, a.command)}")
            return 0
        text = page()
    except (OSError, ValueError, KeyError) as e:
        print(f"compare benchmarks: {e}", file=sys.stderr)
        return 2
    if a.check:
        if not PAGE.exists() or PAGE.read_text() != text:
            print(f"compare benchmarks: {PAGE} is not what docs/benchmarks/ makes: run `python3 -m compare benchmarks page`",
                  file=sys.stderr)
            return 1
        print(f"{PAGE}: current")
        return 0
    PAGE.write_text(text)
    print(f"wrote {PAGE}")
    return 0
