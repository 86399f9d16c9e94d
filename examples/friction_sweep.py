"""Discharge rate against friction on a small hopper: the H1 hopper with 1,200
spheres of radius 2.9-3.5 mm (H1-small's count and size changed through
`overrides`), filled and discharged once per friction coefficient.

    python3 examples/friction_sweep.py [--out DIR] [--friction 0.2 0.4 0.6]

Writes DIR/friction_sweep.png (discharge rate against friction) and
DIR/friction_sweep.json ([[friction, rate_kg_s, discharged_kg], ...]).
"""

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import talus  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SMALL = [
    "particles.lattice.count=1200",
    "particles.lattice.radius_min=0.0029",
    "particles.lattice.radius_max=0.0035",
    "simulation.skin=0.0015",
    "phase.fill.duration=0.8",
    "phase.discharge.duration=0.8",
    "output.snapshot_interval=10.0",
]


def discharge(friction: float) -> dict:
    sim = talus.Simulation.from_file(ROOT / "cases" / "H1-small.toml", overrides=SMALL + [f"material[0].friction={friction}"])
    sim.run_phase()  # the fill; the gate is removed at its end
    assert not sim.walls["gate"].active
    s = sim.run()  # the discharge
    return {"friction": friction, "rate_kg_s": s["discharge_rate_kg_s"], "discharged_kg": s["discharged_mass_kg"], "total_kg": s["total_mass_kg"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/examples/friction_sweep")
    ap.add_argument("--friction", type=float, nargs="+", default=[0.2, 0.4, 0.6])
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for mu in a.friction:
        r = discharge(mu)
        print(f"friction {mu:.2f}: discharge rate {r['rate_kg_s']:.4f} kg/s, {r['discharged_kg']:.4f} of {r['total_kg']:.4f} kg discharged")
        rows.append(r)
    fig, ax = plt.subplots(figsize=(4.5, 3.5))
    ax.plot([r["friction"] for r in rows], [r["rate_kg_s"] for r in rows], "o-")
    ax.set_xlabel("sliding friction coefficient")
    ax.set_ylabel("discharge rate (kg/s)")
    ax.set_title("Small H1 hopper, 1,200 spheres")
    fig.tight_layout()
    fig.savefig(out / "friction_sweep.png", dpi=120)
    (out / "friction_sweep.json").write_text(json.dumps(rows, indent=1) + "\n")
    print(f"wrote {out / 'friction_sweep.png'}")


if __name__ == "__main__":
    main()
