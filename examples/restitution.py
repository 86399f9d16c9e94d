"""The SC restitution curve: a sphere hits a plate head-on (SC-wall), e_out
against the restitution coefficient e_in of the material, for the Hertz and
the Hooke model (talus convention: LIGGGHTS's damping mapping).

    python3 examples/restitution.py [--out DIR]

Writes DIR/restitution.png and DIR/restitution.json ({model: [[e_in, e_out], ...]}).
"""

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import talus  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
E_IN = [0.1, 0.3, 0.5, 0.7, 0.9]


def curve(case: str) -> list:
    points = []
    for e in E_IN:
        sim = talus.Simulation.from_file(ROOT / "cases" / case, overrides=[f"material[0].restitution={e}"])
        summary = sim.run()
        points.append([e, summary["restitution"]])
    return points


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/examples/restitution")
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    curves = {"hertz": curve("SC-wall.toml"), "hooke": curve("SC-wall-hooke.toml")}
    fig, ax = plt.subplots(figsize=(4.5, 4))
    ax.plot([0, 1], [0, 1], color="0.7", lw=1, label="e_out = e_in")
    for (model, pts), mark in zip(curves.items(), "os"):
        ax.plot([p[0] for p in pts], [p[1] for p in pts], mark + "-", label=model)
        for e_in, e_out in pts:
            print(f"{model:5}  e_in {e_in:.2f}  e_out {e_out:.4f}")
    ax.set_xlabel("e_in (material restitution)")
    ax.set_ylabel("e_out (rebound / impact speed)")
    ax.set_title("SC-wall: head-on impact on a plate")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "restitution.png", dpi=120)
    (out / "restitution.json").write_text(json.dumps(curves, indent=1) + "\n")
    print(f"wrote {out / 'restitution.png'}")


if __name__ == "__main__":
    main()
