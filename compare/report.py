"""Markdown report and PNG plots."""
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

CONVENTION_NOTE = """talus is compared with each reference in that reference's convention
(`convention = "liggghts"` or `"yade"`, see ARCHITECTURE.md): LIGGGHTS lets the normal
force go tensile at the end of a contact, caps friction at mu |F_n| and keeps the total
shear displacement; YADE clips the normal force at zero, keeps an incremental shear
force and maps e to damping by Thornton et al.'s (2013) fit. `talus[talus]` is talus's
own convention (the Coulomb cap on the elastic normal force)."""


def write_sc_report(out, setup, model, results, failures):
    """report.md and its plot, and results.json (the results and failures, for
    docs/validation.md: compare/validation.py)."""
    from . import tolerances
    table = dict(tolerances.SC)
    if setup == "SC-oblique":
        table.update(tolerances.SC_OBLIQUE)
    (out / "results.json").write_text(json.dumps(
        {"setup": setup, "model": model, "tolerances": table, "results": results, "failures": failures},
        indent=1, default=float) + "\n")
    lines = [f"# {setup}, model {model}", "", CONVENTION_NOTE, ""]
    for row in results:
        names = list(row["engines"])
        keys = list(next(iter(row["engines"].values())).keys())
        lines += [f"## {row['run']}", "", "| figure | " + " | ".join(names) + " |",
                  "|---|" + "---|" * len(names)]
        for k in keys:
            lines.append(f"| {k} | " + " | ".join(f"{row['engines'][n].get(k, float('nan')):.6g}" for n in names) + " |")
        for ref in ("liggghts", "yade"):
            c = row.get(f"check_vs_{ref}")
            if c:
                bad = [k for k, v in c.items() if not v["ok"]]
                lines.append("")
                lines.append(f"talus vs {ref}: " + ("all figures within tolerance" if not bad else "outside: " + ", ".join(bad)))
        for key, v in (row.get("references_disagree") or {}).items():
            lines.append("")
            lines.append(f"LIGGGHTS ({v['liggghts']:.6g}) and YADE ({v['yade']:.6g}) disagree on {key}: {v['why']}.")
        lines.append("")
    lines += ["## Result", "", "all within tolerance" if not failures else "\n".join(f"- {f}" for f in failures), ""]
    # plot: restitution out vs in (wall, pair) or tangential restitution vs angle (oblique)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    names = sorted({n for r in results for n in r["engines"]})
    for n in names:
        if setup == "SC-oblique":
            xs = [r["angle"] for r in results if n in r["engines"]]
            ys = [r["engines"][n].get("tangential_restitution") for r in results if n in r["engines"]]
            ax.set_xlabel("incidence angle (deg)")
            ax.set_ylabel("tangential restitution")
        else:
            xs = [r["e"] for r in results if n in r["engines"]]
            ys = [r["engines"][n]["restitution"] for r in results if n in r["engines"]]
            ax.set_xlabel("restitution in")
            ax.set_ylabel("restitution out")
        ax.plot(xs, ys, "o-", label=n, alpha=0.8)
    if setup != "SC-oblique":
        ax.plot([0, 1], [0, 1], "k:", lw=0.8)
    ax.legend(fontsize=8)
    ax.set_title(f"{setup}, {model}")
    fig.tight_layout()
    png = out / f"{setup}-{model}.png"
    fig.savefig(png, dpi=100)
    lines += [f"![{setup} {model}]({png.name})", ""]
    (out / "report.md").write_text("\n".join(lines))
