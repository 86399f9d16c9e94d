"""Throughput in rounds: `python -m compare throughput TARGET --repeat N`.

This machine is shared and noisy: one engine's rate moves by 10-30% between runs
minutes apart. A ratio is only meaningful between runs made close together, so each
round runs every engine once, and the rounds alternate the order of the runs
(forward, then backward: A B C, C B A, A B C, ...), so that a drift of the machine
falls on both sides of every ratio alike. The figure reported is each ratio's median
over the rounds (of the ratios computed within a round, never of rates from different
rounds), with its smallest and largest value beside it.
"""
import statistics


def order(jobs, k):
    """Round k's order of the runs: the jobs as given in even rounds, reversed in odd ones."""
    return list(jobs) if k % 2 == 0 else list(reversed(jobs))


def run_jobs(jobs, k):
    """Runs round k's jobs (name, callable) in its order; returns the results by name, in
    the jobs' own order, and the names in the order they ran."""
    done = {}
    ran = []
    for name, job in order(jobs, k):
        done[name] = job()
        ran.append(name)
    return {name: done[name] for name, _ in jobs}, ran


def summarise(rounds):
    """The median over the rounds of every rate and every within-round ratio, with each
    ratio's range. `rounds`: each round's result (dicts with `particle_steps_per_s` and
    `talus_over`, and `order`, the runs in the order they ran)."""
    if not rounds:
        raise ValueError("summarise: no rounds")
    keys = [k for k in rounds[0]["talus_over"]]
    for i, r in enumerate(rounds):
        if list(r["talus_over"]) != keys:
            raise ValueError(f"summarise: round {i} has ratios {sorted(r['talus_over'])}, round 0 {sorted(keys)}")
    rates = {k: statistics.median(r["particle_steps_per_s"][k] for r in rounds) for k in rounds[0]["particle_steps_per_s"]}
    ratios = {k: statistics.median(r["talus_over"][k] for r in rounds) for k in keys}
    spread = {k: [min(r["talus_over"][k] for r in rounds), max(r["talus_over"][k] for r in rounds)] for k in keys}
    return {
        "rounds": len(rounds),
        "particle_steps_per_s_median": rates,
        "talus_over_median": ratios,
        "talus_over_range": spread,
        "each_round": [{"order": r.get("order"), "particle_steps_per_s": r["particle_steps_per_s"],
                        "talus_over": r["talus_over"]} for r in rounds],
        "note": "talus_over_median: the median over the rounds of each ratio measured within one round; the rounds "
                "alternate the order of the runs (forward, backward, ...); particle_steps_per_s_median is for "
                "reference only (rates of different rounds are not compared)",
    }


def print_summary(s):
    print(f"\nover {s['rounds']} rounds (the runs' order alternating), each ratio measured within a round:")
    print(f"  {'ratio':<50}{'median':>8}{'min':>8}{'max':>8}   per round")
    for k, v in s["talus_over_median"].items():
        lo, hi = s["talus_over_range"][k]
        each = " ".join(f"{r['talus_over'][k]:.2f}" for r in s["each_round"])
        print(f"  {label(k):<50}{v:>8.2f}{lo:>8.2f}{hi:>8.2f}   {each}")


def label(k):
    """A ratio's name as printed: a bare engine name (H1's `talus_over` keys talus's
    one-process run over that engine) is written `talus/ENGINE`."""
    return k if "/" in k else f"talus/{k}"
