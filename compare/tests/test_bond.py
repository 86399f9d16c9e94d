"""`python -m compare bond`: the cohesive pile's angle of repose against the Bond number
(compare/bond.py). The study itself (three levels, ensembles against LIGGGHTS, about 2.5 min)
runs in scripts/compare_all.sh; here its Bond number is checked against talus itself."""
import math
import subprocess
import tomllib

import pytest

from compare import bond, engines

PILE = tomllib.loads((engines.ROOT / "cases" / "pile.toml").read_text())


def test_the_resting_overlap_is_the_one_talus_settles_a_sphere_to(tmp_path):
    """One sphere of the pile's mean radius and material settles on a floor of that material,
    without cohesion and with sjkr of energy density K: its overlap at rest is the Bond number's
    delta within 0.5% in both (Hertz's E* at a wall and sjkr's area at a wall as talus computes
    them), and the floor carries the weight."""
    r, m, g, delta = bond.resting(PILE)
    mat = next(x for x in PILE["material"] if x["name"] == "seed-soft")
    k = 2.0e4

    def settle(cohesion):
        case = tmp_path / f"one-{int(cohesion)}.toml"
        coh = f'cohesion = {{ model = "sjkr", energy_density = {cohesion!r} }}\n' if cohesion else ""
        case.write_text(f"""
[simulation]
timestep_rayleigh_fraction = 0.2
gravity = [0.0, 0.0, -{g!r}]
integrator = "verlet"
skin = 0.0005
domain = {{ lo = [-0.01, -0.01, -0.001], hi = [0.01, 0.01, 0.01] }}

[contact]
model = "hertz"
convention = "talus"
{coh}
[[material]]
name = "m"
youngs_modulus = {mat['youngs_modulus']!r}
poisson_ratio = {mat['poisson_ratio']!r}
density = {mat['density']!r}
restitution = 0.5
friction = 0.5

[particles]
material = "m"
list = [{{ id = 1, position = [0.0, 0.0, {r!r}], radius = {r!r} }}]

[[wall]]
name = "floor"
material = "m"
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }}

[[phase]]
name = "rest"
duration = 0.3

[output]
interval = 0.01
final_state = true
""")
        out = tmp_path / f"out-{int(cohesion)}"
        subprocess.run([str(engines.TALUS), "run", str(case), "--out", str(out), "--quiet"], check=True,
                       capture_output=True, text=True)
        lines = (out / "final.csv").read_text().splitlines()
        row = dict(zip(lines[0].split(","), lines[1].split(",")))
        probes = (out / "probes.csv").read_text().splitlines()
        last = dict(zip(probes[0].split(","), probes[-1].split(",")))
        return r - float(row["z"]), abs(float(last["floor_force_z_n"]))

    overlap, load = settle(0.0)
    assert overlap == pytest.approx(delta, rel=5e-3)
    assert load == pytest.approx(m * g, rel=1e-3)
    # with cohesion the sphere sinks until the elastic force carries weight and pull: the
    # overlap the Bond number takes; the floor's load is still the weight
    _, _, _, delta_k = bond.resting(PILE, k)
    overlap_k, load_k = settle(k)
    assert overlap_k > 2.0 * overlap
    assert overlap_k == pytest.approx(delta_k, rel=5e-3)
    assert load_k == pytest.approx(m * g, rel=1e-3)
    assert bond.bond_number(PILE, k) == pytest.approx(k * math.pi * (2.0 * r * overlap_k - overlap_k ** 2) / (m * g), rel=1e-2)
    assert bond.bond_number(PILE, 0.0) == 0.0


def test_levels_and_engines_are_checked():
    with pytest.raises(SystemExit):
        bond.main(["--levels", "20000,10000"])
    with pytest.raises(SystemExit):
        bond.main(["--levels", "0"])
    with pytest.raises(SystemExit):
        bond.main(["--engines", "liggghts,talus"])
