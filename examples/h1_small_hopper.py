"""The H1-small hopper (5,000 spheres, CASES.md) from Python: fill, gate
removed, discharge; a callback samples the mass that has left the hopper every
0.01 s, and the discharge is plotted with the rate talus fits.

    python3 examples/h1_small_hopper.py [--out DIR] [--threads N]

Writes the same files as `talus run cases/H1-small.toml --out DIR`, plus
DIR/discharge.png and DIR/discharge.csv (t_s, mass_below_kg).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import talus  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/examples/h1_small")
    ap.add_argument("--threads", type=int, default=None)
    a = ap.parse_args()
    out = Path(a.out)
    sim = talus.Simulation.from_file(ROOT / "cases" / "H1-small.toml", threads=a.threads)
    samples = []

    def sample(s: talus.Simulation) -> None:
        below = s.positions[:, 2] < 0.0
        samples.append((s.time, float(s.masses[below].sum()), s.phase))

    sim.every(max(1, round(0.01 / sim.dt)), sample)
    summary = sim.run(out=out)
    t = np.array([x[0] for x in samples])
    m = np.array([x[1] for x in samples])
    t0 = summary["fill_end_time_s"]
    rate = summary["discharge_rate_kg_s"]
    print(f"{summary['particles']} spheres, {summary['steps']} steps, {summary['particle_steps_per_s']:.3e} particle-steps/s")
    print(f"fill ended at {t0:.3f} s; floor + gate carried {summary['fill_end_force_balance']:.4f} of the weight")
    print(f"discharge rate {rate:.4f} kg/s; {summary['discharged_mass_kg']:.4f} of {summary['total_mass_kg']:.4f} kg discharged")
    np.savetxt(out / "discharge.csv", np.c_[t, m], delimiter=",", header="t_s,mass_below_kg", comments="", fmt="%.9e")
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    ax.plot(t, m, label="mass below the orifice (callback)")
    ax.axvline(t0, color="0.6", ls="--", lw=1, label="gate removed")
    tt = np.linspace(t0, t[-1], 50)
    ax.plot(tt, np.clip(rate * (tt - t0), 0, summary["total_mass_kg"]), "k:", label=f"fitted rate {rate:.3f} kg/s")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("mass (kg)")
    ax.set_title("H1-small from Python")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "discharge.png", dpi=120)
    print(f"wrote {out / 'discharge.png'}")


if __name__ == "__main__":
    main()
