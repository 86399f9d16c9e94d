# SC: single collisions (CASES.md "SC"), the YADE 2023.02a side of cases/SC-*.toml.
#
# Run headless, one thread (YADE with several threads is not deterministic):
#
#   yade -j 1 -n -x yade_cases/SC.py --setup wall --model hertz --e 0.5 --out sc.csv
#
# See yade_cases/README.md for every option, the CSV columns, the timing
# convention and the YADE quirks this script works around.
#
# Set-ups (SI units, no gravity, material seed-soft: E = 1e6 Pa, nu = 0.3,
# rho = 2500 kg/m3, mu = 0.4, restitution e from --e):
#   wall     sphere r = 2 mm at (0, 0, 0.0021), v = (0, 0, -0.5), plane wall z = 0, 4 ms
#   pair     spheres r = 2 mm at (-+0.00205, 0, 0), v = (+-0.5, 0, 0), 3 ms
#   oblique  as wall, v = (0.5 sin a, 0, -0.5 cos a), a = --angle degrees, no spin, 4 ms

import argparse
import json
import math
import sys

# The names YADE puts in the script's namespace (O, utils, engines, functors)
# are used unqualified below, as in every YADE script.

R_SPHERE = 0.002
YOUNG = 1.0e6
POISSON = 0.3
DENSITY = 2500.0
MU = 0.4
SPEED = 0.5

SETUPS = {
    # name: (duration_s, characteristic velocity of LIGGGHTS model hooke, has a wall)
    "wall": (0.004, 0.5, True),
    "pair": (0.003, 1.0, False),
    "oblique": (0.004, 0.5, True),
}

# --wall-geom: how the plane z = 0 enters YADE, and the equivalent radius
# R* = R1 R2 / (R1 + R2) that Ip2_FrictMat_FrictMat_MindlinPhys then uses
# (R1 = ScGeom.refR1 set by the Ig2 functor for the wall or facet, R2 = r).
WALL_GEOMS = {
    # name: (body kind, Ig2 'hertzian' flag, R* / r)
    "flat": ("wall", True, 1e8 / (1e8 + 1)),  # utils.wall, refR1 = 1e8 r: R* = r (to 1e-8)
    "wall": ("wall", False, 0.5),  # utils.wall, refR1 = r: R* = r/2
    "facet": ("facet", False, 2.0 / 3.0),  # one utils.facet, refR1 = 2r: R* = 2r/3
    "facet-flat": ("facet", True, 1e8 / (1e8 + 1)),  # one utils.facet, refR1 = 1e8 r: R* = r
}


def parse_args(argv):
    p = argparse.ArgumentParser(prog="SC.py", description="YADE single-collision cases (talus SC-*).")
    p.add_argument("--setup", choices=sorted(SETUPS), default="wall")
    p.add_argument("--model", choices=["hertz", "hooke"], default="hertz")
    p.add_argument("--e", type=float, default=0.5, help="input restitution (Mindlin en = es = e; hooke default-derivation only)")
    p.add_argument("--angle", type=float, default=45.0, help="oblique: incidence angle from the wall normal, degrees")
    p.add_argument("--dt", type=float, default=5e-6, help="time step, s (O.dt, no time stepper)")
    p.add_argument("--duration", type=float, default=None, help="override the set-up's duration, s")
    p.add_argument("--wall-geom", choices=sorted(WALL_GEOMS), default="flat",
                   help="how the wall enters YADE (changes Mindlin's R*); default flat: R* = r")
    p.add_argument("--kn", type=float, default=None, help="hooke: wanted pair normal stiffness, N/m")
    p.add_argument("--kt", type=float, default=None, help="hooke: wanted pair tangential stiffness, N/m")
    p.add_argument("--gamman", type=float, default=None, help="hooke: wanted pair normal damping, kg/s")
    p.add_argument("--gammat", type=float, default=None, help="hooke: wanted pair tangential damping, kg/s")
    p.add_argument("--char-vel", type=float, default=None,
                   help="hooke defaults only: characteristic velocity V (default 0.5 wall/oblique, 1.0 pair)")
    p.add_argument("--vel-at", choices=["half", "step"], default="half",
                   help="half: record YADE's leapfrog velocities v(t-dt/2) (default); "
                        "step: record v(t-dt/2) + dt/2 F(t)/m (and the same for spin)")
    p.add_argument("--out", default="SC.csv", help="CSV time series")
    p.add_argument("--summary", default=None, help="also write the JSON summary to this file")
    return p.parse_args(argv)


def liggghts_hooke(m_eff, r_eff, v_char, e):
    """LIGGGHTS 3.8 model hooke (normal_model_hooke.h) at characteristic velocity v_char:
    kn = 16/15 sqrt(R*) E* (15 m* V^2 / (16 sqrt(R*) E*))^(1/5), kt = kn,
    gamma_n = gamma_t = sqrt(4 m* kn / (1 + (pi / ln e)^2))."""
    e_star = YOUNG / (2.0 * (1.0 - POISSON ** 2))
    kn = 16.0 / 15.0 * math.sqrt(r_eff) * e_star * (
        15.0 * m_eff * v_char ** 2 / (16.0 * math.sqrt(r_eff) * e_star)) ** 0.2
    ln_e = math.log(e)
    gn = 0.0 if ln_e == 0.0 else math.sqrt(4.0 * m_eff * kn / (1.0 + (math.pi / ln_e) ** 2))
    return kn, kn, gn, gn


def main(argv):
    a = parse_args(argv)
    duration, v_char_default, has_wall = SETUPS[a.setup]
    if a.duration is not None:
        duration = a.duration
    if not (0.0 < a.e <= 1.0):
        raise SystemExit("--e must lie in (0, 1]")
    n_steps = int(round(duration / a.dt))

    mass = DENSITY * 4.0 / 3.0 * math.pi * R_SPHERE ** 3
    if has_wall:
        m_eff, r_eff_liggghts = mass, R_SPHERE  # LIGGGHTS flat wall: m* = m, R* = r
    else:
        m_eff, r_eff_liggghts = mass / 2.0, R_SPHERE / 2.0

    O.reset()
    O.dt = a.dt
    fric = math.atan(MU)

    # ---- materials and laws ----
    hooke_wanted = None
    if a.model == "hertz":
        mat = FrictMat(young=YOUNG, poisson=POISSON, density=DENSITY, frictionAngle=fric, label="seed-soft")
        ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(en=a.e, es=a.e)
        law2 = Law2_ScGeom_MindlinPhys_Mindlin()
    else:
        d = liggghts_hooke(m_eff, r_eff_liggghts, a.char_vel if a.char_vel else v_char_default, a.e)
        kn = a.kn if a.kn is not None else d[0]
        kt = a.kt if a.kt is not None else d[1]
        gn = a.gamman if a.gamman is not None else d[2]
        gt = a.gammat if a.gammat is not None else d[3]
        hooke_wanted = {"kn": kn, "kt": kt, "gamman": gn, "gammat": gt}
        # Ip2_ViscElMat_ViscElMat_ViscElPhys combines two materials' kn, ks, cn, cs in
        # series, 1/(1/a + 1/b); both bodies (sphere and sphere, or sphere and wall) carry
        # this one material, so each gets twice the wanted pair value.
        mat = ViscElMat(kn=2.0 * kn, ks=2.0 * kt, cn=2.0 * gn, cs=2.0 * gt,
                        frictionAngle=fric, density=DENSITY, label="seed-soft")
        ip2 = Ip2_ViscElMat_ViscElMat_ViscElPhys()
        law2 = Law2_ScGeom_ViscElPhys_Basic()
    mat_id = O.materials.append(mat)

    # ---- bodies ----
    spheres = []
    if a.setup == "pair":
        for x, vx in ((-0.00205, SPEED), (0.00205, -SPEED)):
            b = utils.sphere((x, 0.0, 0.0), R_SPHERE, material=mat_id)
            b.state.vel = Vector3(vx, 0.0, 0.0)
            spheres.append(O.bodies.append(b))
    else:
        ang = math.radians(a.angle) if a.setup == "oblique" else 0.0
        b = utils.sphere((0.0, 0.0, 0.0021), R_SPHERE, material=mat_id)
        b.state.vel = Vector3(SPEED * math.sin(ang), 0.0, -SPEED * math.cos(ang))
        b.state.angVel = Vector3(0.0, 0.0, 0.0)
        spheres.append(O.bodies.append(b))

    wall_kind, hertzian, rstar_ratio = WALL_GEOMS[a.wall_geom]
    wall_id = None
    if has_wall:
        if wall_kind == "wall":
            w = utils.wall(0.0, axis=2, sense=0, material=mat_id)
        else:
            # One large triangle whose interior holds every contact point: a sphere on the
            # shared edge of two coplanar facets would be counted twice by YADE.
            w = utils.facet([Vector3(-0.1, -0.1, 0.0), Vector3(0.1, -0.1, 0.0), Vector3(0.0, 0.1, 0.0)],
                            material=mat_id)
        wall_id = O.bodies.append(w)

    # ---- engines: the recorder sits between the force loop and the integrator ----
    state = {"rows": [], "phys": None, "vel_at": a.vel_at}

    def record():
        # k dt with k = O.iter (O.time is the same sum of dt, up to accumulated rounding)
        row = [O.iter * O.dt]
        for sid in spheres:
            s = O.bodies[sid].state
            f = O.forces.f(sid, True)
            v = s.vel
            w_ = s.angVel
            if state["vel_at"] == "step":
                tq = O.forces.t(sid, True)
                v = v + f * (0.5 * O.dt / s.mass)
                w_ = Vector3(w_[0] + 0.5 * O.dt * tq[0] / s.inertia[0],
                             w_[1] + 0.5 * O.dt * tq[1] / s.inertia[1],
                             w_[2] + 0.5 * O.dt * tq[2] / s.inertia[2])
            row += [s.pos[0], s.pos[1], s.pos[2], v[0], v[1], v[2], w_[0], w_[1], w_[2], f[0], f[1], f[2]]
        state["rows"].append(row)
        if state["phys"] is None:
            for I in O.interactions:
                if I.isReal:
                    state["phys"] = describe_interaction(I)
                    state["phys"]["first_step"] = O.iter
                    break

    # PyRunner commands run in YADE's __main__ namespace.
    import __main__
    __main__._sc_record = record

    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb(), Bo1_Facet_Aabb()]),
        InteractionLoop(
            [Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(hertzian=hertzian),
             Ig2_Facet_Sphere_ScGeom(hertzian=hertzian)],
            [ip2],
            [law2],
        ),
        PyRunner(command="_sc_record()", iterPeriod=1, initRun=True, label="sc_recorder"),
        NewtonIntegrator(damping=0.0, gravity=(0.0, 0.0, 0.0)),
    ]

    # n_steps + 1 force evaluations give rows at t = 0, dt, ..., n_steps*dt.
    O.run(n_steps + 1, True)

    rows = state["rows"]
    if len(rows) != n_steps + 1:
        raise RuntimeError("recorded %d rows, expected %d" % (len(rows), n_steps + 1))
    cols = ["time_s"]
    for k in range(1, len(spheres) + 1):
        p = "p%d_" % k
        cols += [p + "x_m", p + "y_m", p + "z_m", p + "vx_m_s", p + "vy_m_s", p + "vz_m_s",
                 p + "wx_rad_s", p + "wy_rad_s", p + "wz_rad_s", p + "fx_n", p + "fy_n", p + "fz_n"]
    with open(a.out, "w") as fh:
        fh.write(",".join(cols) + "\n")
        for row in rows:
            fh.write(",".join("%.17g" % float(x) for x in row) + "\n")

    summary = summarise(a, rows, mass, m_eff, rstar_ratio if has_wall else 0.5, n_steps)
    summary["phys"] = state["phys"]
    summary["hooke_wanted"] = hooke_wanted
    summary["wall_geom"] = a.wall_geom if has_wall else None
    summary["command"] = " ".join(["SC.py"] + list(argv))
    text = json.dumps(summary, sort_keys=True)
    print("SC-SUMMARY " + text)
    if a.summary:
        with open(a.summary, "w") as fh:
            fh.write(json.dumps(summary, sort_keys=True, indent=1) + "\n")


def describe_interaction(I):
    g, ph = I.geom, I.phys
    d = {"id1": I.id1, "id2": I.id2, "refR1": float(g.refR1), "refR2": float(g.refR2),
         "phys_class": ph.__class__.__name__, "tan_friction": float(ph.tangensOfFrictionAngle)}
    if isinstance(ph, MindlinPhys):
        e_star = YOUNG / (2.0 * (1.0 - POISSON ** 2))
        d.update({"kno": float(ph.kno), "kso": float(ph.kso), "betan": float(ph.betan), "betas": float(ph.betas),
                  "r_star_from_kno": (3.0 * float(ph.kno) / (4.0 * e_star)) ** 2})
    else:
        d.update({"kn": float(ph.kn), "ks": float(ph.ks), "cn": float(ph.cn), "cs": float(ph.cs)})
    return d


def summarise(a, rows, mass, m_eff, rstar_ratio, n_steps):
    r = R_SPHERE
    s = {"setup": a.setup, "model": a.model, "e_in": a.e, "dt": a.dt, "steps": n_steps,
         "mass": mass, "m_eff": m_eff, "r_star_expected": rstar_ratio * r}
    if a.setup == "pair":
        # normal = x; relative velocity of sphere 2 w.r.t. sphere 1
        vn0 = rows[0][1 + 3] - rows[0][13 + 3]
        vn1 = rows[-1][13 + 3] - rows[-1][1 + 3]
        overl = [2 * r - (row[13] - row[1]) for row in rows]
        fn = [-row[1 + 9] for row in rows]  # force on sphere 1 is in -x
        s["symmetry_max_abs"] = max(
            max(abs(row[1] + row[13]), abs(row[4] + row[16]), abs(row[10] + row[22])) for row in rows)
    else:
        vn0 = -rows[0][6]
        vn1 = rows[-1][6]
        overl = [r - row[3] for row in rows]
        fn = [row[12] for row in rows]
        s["vt_in"] = rows[0][4]
        s["vt_out"] = rows[-1][4]
        s["wy_out"] = rows[-1][8]
        s["vt_ratio"] = rows[-1][4] / rows[0][4] if rows[0][4] != 0 else None
        s["impulse_t"] = mass * (rows[-1][4] - rows[0][4])
        s["impulse_n"] = mass * (rows[-1][6] - rows[0][6])
    contact = [i for i, f in enumerate(fn) if f != 0.0]
    s["e_out"] = vn1 / vn0
    s["peak_overlap"] = max(overl)
    s["peak_normal_force"] = max(fn)
    s["contact_steps"] = len(contact)
    s["contact_duration"] = len(contact) * a.dt
    s["first_contact_t"] = rows[contact[0]][0] if contact else None
    s["last_contact_t"] = rows[contact[-1]][0] if contact else None
    s["min_normal_force"] = min(fn)
    return s


main(sys.argv[1:])
