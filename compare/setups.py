"""The canonical set-ups of ../shared/CASES.md, as numbers the harness hands to every engine.
The material (seed-soft), the SC sphere and time step are read from talus's own case file,
so each number exists once."""
from dataclasses import dataclass, field
from pathlib import Path
import math
import tomllib

with open(Path(__file__).resolve().parent.parent / "cases" / "SC-wall.toml", "rb") as _f:
    _SC = tomllib.load(_f)
_SEED_SOFT = _SC["material"][0]
E = _SEED_SOFT["youngs_modulus"]
NU = _SEED_SOFT["poisson_ratio"]
RHO = _SEED_SOFT["density"]
MU = _SEED_SOFT["friction"]
R = _SC["particles"]["list"][0]["radius"]  # SC sphere radius (m)
DT_SC = _SC["simulation"]["timestep"]  # SC time step (s): < 1/200 of the ~1.1-1.5 ms contacts
E_SWEEP = [0.1, 0.3, 0.5, 0.7, 0.9]
ANGLES = [10, 30, 45, 60, 80]
OBLIQUE_E = 0.5


def sphere_mass(r=R):
    return RHO * 4.0 / 3.0 * math.pi * r ** 3


def y_eff():
    """Y* of two seed-soft bodies (particle-particle and particle-wall alike)."""
    return 1.0 / (2.0 * (1.0 - NU ** 2) / E)


@dataclass
class Hooke:
    kn: float
    kt: float
    gamma_n: float
    gamma_t: float


def hooke_coefficients(setup: str, e: float) -> Hooke:
    """kn, kt, gamma_n, gamma_t derived once, as LIGGGHTS `model hooke` derives them
    at the impact speed (wall: V = 0.5 m/s, R* = R, m* = m; pair: V = 1.0 m/s relative,
    R* = R/2, m* = m/2), then handed to every engine as absolute values."""
    m = sphere_mass()
    if setup == "SC-pair":
        r_eff, m_eff, v = R / 2, m / 2, 1.0
    else:
        r_eff, m_eff, v = R, m, 0.5
    s = math.sqrt(r_eff)
    kn = 16.0 / 15.0 * s * y_eff() * (15.0 * m_eff * v * v / (16.0 * s * y_eff())) ** 0.2
    if e >= 1.0:
        g = 0.0
    else:
        g = math.sqrt(4.0 * m_eff * kn / (1.0 + (math.pi / math.log(e)) ** 2))
    return Hooke(kn, kn, g, g)


@dataclass
class Run:
    """One single-collision run: set-up, model, restitution, angle (oblique)."""
    setup: str
    model: str
    e: float
    angle: float = 0.0
    hooke: Hooke = field(default=None)

    @property
    def label(self):
        a = f"-a{self.angle:g}" if self.setup == "SC-oblique" else ""
        return f"{self.setup}-{self.model}-e{self.e:g}{a}"


def sc_runs(setup: str, model: str):
    if setup == "SC-oblique":
        runs = [Run(setup, model, OBLIQUE_E, a) for a in ANGLES]
    else:
        runs = [Run(setup, model, e) for e in E_SWEEP]
    if model == "hooke":
        for r in runs:
            r.hooke = hooke_coefficients(setup, r.e)
    return runs
