"""A case built from a Python dict: spheres dropped into a square box onto a
floor plane; once settled, the contact forces on each sphere and the load on
each wall are read back.

    python3 examples/dict_pile.py [--out DIR] [--count N]

Prints the floor's load against the pile's weight and writes DIR/pile.json.
"""

import argparse
import json
from pathlib import Path

import numpy as np

import talus

G = 9.81


def pile_case(count: int, friction: float = 0.5) -> dict:
    """A box 40 mm square, spheres of radius 1.8 to 2.2 mm on a loose lattice above its floor."""
    half = 0.02
    return {
        "simulation": {
            "timestep_rayleigh_fraction": 0.2,
            "gravity": [0.0, 0.0, -G],
            "skin": 0.0005,
            "domain": {"lo": [-0.03, -0.03, -0.01], "hi": [0.03, 0.03, 0.3]},
        },
        "contact": {"model": "hertz"},
        "material": [
            {"name": "glass", "youngs_modulus": 5.0e6, "poisson_ratio": 0.3, "density": 2500.0, "restitution": 0.3, "friction": friction}
        ],
        "particles": {
            "material": "glass",
            "lattice": {
                "count": count,
                "radius_min": 0.0018,
                "radius_max": 0.0022,
                "lo": [-half + 0.0025, -half + 0.0025, 0.003],
                "hi_xy": [half - 0.0025, half - 0.0025],
                "spacing": 2.2,
                "seed": 7,
            },
        },
        "wall": [
            {"name": "floor", "material": "glass", "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}},
            {"name": "xlo", "material": "glass", "plane": {"point": [-half, 0, 0], "normal": [1, 0, 0]}},
            {"name": "xhi", "material": "glass", "plane": {"point": [half, 0, 0], "normal": [-1, 0, 0]}},
            {"name": "ylo", "material": "glass", "plane": {"point": [0, -half, 0], "normal": [0, 1, 0]}},
            {"name": "yhi", "material": "glass", "plane": {"point": [0, half, 0], "normal": [0, -1, 0]}},
        ],
        "phase": [{"name": "settle", "duration": 3.0, "kinetic_energy_fraction": 1e-7, "settle_extra": 0.1}],
        "output": {"interval": 0.01},
    }


def settle(count: int) -> dict:
    sim = talus.Simulation.from_dict(pile_case(count), name="dict-pile")
    sim.run()
    m = sim.masses
    weight = float(m.sum() * G)
    # contact force on each sphere: the total force less its weight
    contact = sim.forces - np.outer(m, [0.0, 0.0, -G])
    walls = {name: sim.walls[name].force.tolist() for name in sim.walls}
    return {
        "particles": int(sim.particle_count),
        "time_s": sim.time,
        "weight_n": weight,
        "walls_n": walls,
        "floor_load_over_weight": -walls["floor"][2] / weight,
        "largest_contact_force_n": float(np.linalg.norm(contact, axis=1).max()),
        "mean_contact_force_n": float(np.linalg.norm(contact, axis=1).mean()),
        "contacts": int(sim.contacts),
        "pile_height_m": float((sim.positions[:, 2] + sim.radii).max()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/examples/dict_pile")
    ap.add_argument("--count", type=int, default=400)
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    r = settle(a.count)
    print(f"{r['particles']} spheres settled at t = {r['time_s']:.3f} s, {r['contacts']} contacts, pile {1000 * r['pile_height_m']:.1f} mm high")
    print(f"weight {r['weight_n']:.5f} N; floor carries {-r['walls_n']['floor'][2]:.5f} N ({r['floor_load_over_weight']:.4f} of it)")
    for name, f in r["walls_n"].items():
        print(f"  wall {name:5} force [{f[0]: .3e}, {f[1]: .3e}, {f[2]: .3e}] N")
    print(f"contact force per sphere: mean {r['mean_contact_force_n']:.3e} N, largest {r['largest_contact_force_n']:.3e} N")
    (out / "pile.json").write_text(json.dumps(r, indent=1) + "\n")


if __name__ == "__main__":
    main()
