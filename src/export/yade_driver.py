# ---- The driver of every exported YADE script (talus src/export/yade_driver.py).
# It reads only C (above) and particles.csv / meshes/, and writes probes.csv with
# the columns of talus's probes.csv, on talus's row steps.
#
# Time: YADE's NewtonIntegrator is leapfrog; iteration k evaluates F_k at x_k. The
# probe hook runs between the force loop and the integrator, so a row at
# iteration k holds talus's end-of-step-k state (x_k, F_k), with the step
# velocities v_k = v(k-1/2) + dt/2 (F_k/m + g). At iteration 0 every body carries
# v_0 (the contact laws see it, as talus's first force evaluation does); after the
# row the hook sets v(-1/2) = v_0 - dt/2 (F_0/m + g), so that leapfrog from there
# is velocity Verlet from v_0.
#
# Phases and removals run between O.run chunks, with talus's step rules ported
# in the same floating-point operations (k*dt, the same comparisons).
import csv
import math
import sys

import __main__
from yade import ymport

dt = C["dt"]
iv = C["interval"]
two_d = C["dimension"] == 2
hertz = C["model"] == "hertz"
g = Vector3(*C["gravity"])
ZERO = Vector3(0.0, 0.0, 0.0)
O.reset()
O.dt = dt
lo, hi = Vector3(*C["domain"][0]), Vector3(*C["domain"][1])
periodic = C["periodic"]
if any(periodic):
    # YADE's cell is periodic along every axis: along one talus bounds, twice the
    # domain's length, so no sphere meets another's image there. YADE keeps
    # positions unwrapped; the outputs give them back inside talus's domain.
    O.periodic = True
    O.cell.setBox(Vector3(*[(hi[c] - lo[c]) * (1 if periodic[c] else 2) for c in range(3)]))


def wrap(x):
    """A position brought into talus's domain along the periodic axes."""
    return Vector3(*[lo[c] + math.fmod(math.fmod(x[c] - lo[c], hi[c] - lo[c]) + (hi[c] - lo[c]), hi[c] - lo[c]) if periodic[c] else x[c] for c in range(3)])


def proj(v):
    """A velocity or force as the case's dimension lets it be (2D: x-y)."""
    return Vector3(v[0], v[1], 0.0) if two_d else Vector3(v[0], v[1], v[2])


def proj_w(w):
    """A spin or torque as the case's dimension lets it be (2D: about z)."""
    return Vector3(0.0, 0.0, w[2]) if two_d else Vector3(w[0], w[1], w[2])


# ---- materials: C["materials"] in order; the particles' first, then one per wall
mats = []
for m in C["materials"]:
    phi = math.atan(m["mu"])
    if hertz:
        mat = FrictMat(young=m["E"], poisson=m["nu"], density=m["rho"], frictionAngle=phi, label=m["name"])
    else:
        kn, ks, cn, cs = m["viscel"]
        mat = ViscElMat(kn=kn, ks=ks, cn=cn, cs=cs, density=m["rho"], frictionAngle=phi, label=m["name"])
    mats.append(O.materials.append(mat))
if hertz:
    # YADE does not mix restitution: every pair of materials gets talus's mixed e
    matches = [(mats[a], mats[b], e) for a, b, e in C["en"]]
    ip2 = Ip2_FrictMat_FrictMat_MindlinPhys(en=MatchMaker(matches=matches), es=MatchMaker(matches=matches))
    law2 = Law2_ScGeom_MindlinPhys_Mindlin()
else:
    ip2, law2 = Ip2_ViscElMat_ViscElMat_ViscElPhys(), Law2_ScGeom_ViscElPhys_Basic()

# ---- particles: talus id -> body id; clump members wait for their clump
members = {t for c in C["clumps"] for t in c["members"]}
free = []          # [body id, talus id, mass, inertia] of free spheres
pending = {}
info = {}          # talus id -> (mass, inertia, radius)
with open("particles.csv", newline="") as fh:
    for r in csv.DictReader(fh):
        t = int(r["id"])
        f = {k: float(v) for k, v in r.items() if k not in ("id", "material")}
        b = utils.sphere((f["x"], f["y"], f["z"]), f["radius"], material=mats[int(r["material"])])
        b.state.mass = f["mass"]
        b.state.inertia = Vector3(f["inertia"], f["inertia"], f["inertia"])
        b.state.vel = Vector3(f["vx"], f["vy"], f["vz"])
        b.state.angVel = Vector3(f["wx"], f["wy"], f["wz"])
        info[t] = (f["mass"], f["inertia"], f["radius"])
        if t in members:
            pending[t] = b
            continue
        if two_d:
            b.state.blockedDOFs = "zXY"
        free.append([O.bodies.append(b), t, f["mass"], f["inertia"]])
bid = {t: b for b, t, _, _ in free}
clumps = []        # [clump body id, [(member body id, talus id)], mass, inertia about z]
for c in C["clumps"]:
    cid, mem = O.bodies.appendClumped([pending[t] for t in c["members"]])
    s = O.bodies[cid].state           # appendClumped zeroed the clump's velocities
    s.mass = c["mass"]
    s.vel = Vector3(*c["vel"])
    s.angVel = Vector3(0.0, 0.0, c["omega_z"])
    if two_d:
        s.blockedDOFs = "zXY"
    if abs(s.inertia[2] - c["inertia"]) > 1e-9 * c["inertia"]:
        sys.exit("talus export: clump of %s: YADE's inertia %.17g, talus's %.17g" % (c["members"], s.inertia[2], c["inertia"]))
    s.inertia = Vector3(s.inertia[0], s.inertia[1], c["inertia"])
    for t, m in zip(c["members"], mem):
        bid[t] = m
    clumps.append([cid, list(zip(mem, c["members"])), c["mass"], c["inertia"]])
radius_of = {bid[t]: info[t][2] for t in info}
mass_inertia = {bid[t]: info[t][:2] for t in info}   # a member's own, as talus counts them

# ---- particles a talus run inserted (its inserted.csv): each comes in at the start
# of its step s, before iteration s, at v(s-1/2) = v_0 - dt/2 g (no contact where it is
# put); those of step 0 before the first iteration, at v_0 (the start adjusts them)
inserted = list(C["inserted"])
born = {}          # body id -> the step it came in at


def insert_batch(s):
    while inserted and inserted[0][0] == s:
        st, t, x, y, z, vx, vy, vz, r, mi, rho = inserted.pop(0)
        m = rho * 4.0 / 3.0 * math.pi * (r * r * r)
        inertia = 0.4 * m * r * r
        b = utils.sphere((x, y, z), r, material=mats[mi])
        b.state.mass = m
        b.state.inertia = Vector3(inertia, inertia, inertia)
        v = Vector3(vx, vy, vz)
        b.state.vel = v if s == 0 else v - g * (0.5 * dt)
        i = O.bodies.append(b)
        free.append([i, t, m, inertia])
        bid[t] = i
        info[t] = (m, inertia, r)
        radius_of[i] = r
        mass_inertia[i] = (m, inertia)
        born[i] = s


insert_batch(0)

# ---- walls: the body ids of each, every one moving at the wall's velocity
wall_ids, wall_of = [], {}
for i, w in enumerate(C["walls"]):
    mid, k = mats[w["material"]], w["kind"]
    if k == "wall":
        ids = [O.bodies.append(utils.wall(w["at"], axis=w["axis"], sense=0, material=mid))]
    elif k == "box":
        ids = [O.bodies.append(utils.wall(at, axis=ax, sense=0, material=mid)) for ax, at in w["sides"]]
    elif k == "facet":
        ids = [O.bodies.append(utils.facet([Vector3(*v) for v in w["vertices"]], material=mid))]
    elif k == "stl":
        ids = list(O.bodies.append(ymport.stl(w["file"], fixed=True, material=mid)))
    else:  # ball
        ids = [O.bodies.append(utils.sphere(Vector3(*w["center"]), w["radius"], fixed=True, material=mid))]
        radius_of[ids[0]] = w["radius"]
    for j in ids:
        O.bodies[j].state.vel = Vector3(*w["velocity"])
        wall_of[j] = i
    wall_ids.append(ids)
removed = [False] * len(wall_ids)

# ---- wall motion (Wall::advance): translation, oscillation amplitude sin(2 pi f (t - t0)),
# rotation about an axis through a point carried by the translation. Each step's move
# k -> k+1 is given to Newton as each body's velocity (the chord to its exact next
# position) and spin; a wall at one constant velocity all run keeps the velocity it
# was made with. axis_of: the point and axis of a turning wall's axis torque.
motion_of = [None] * len(wall_ids)
motion_t0 = [0] * len(wall_ids)
axis_of = [None if w["torque_axis"] is None else [Vector3(*w["torque_axis"][0]), Vector3(*w["torque_axis"][1]).normalized()]
           for w in C["walls"]]


def dynamic(m):
    return m is not None and (m["osc"] is not None or (m["rot"] is not None and m["rot"][2] != 0.0))


def set_motion(i, phase, k):
    """Wall i moves from step k on as phase `phase` says (if it says anything)."""
    for m in C["walls"][i]["motions"]:
        if m["phase"] == phase:
            motion_of[i], motion_t0[i] = m, k
            if m["rot"] is not None:
                axis_of[i] = [Vector3(*m["rot"][1]), Vector3(*m["rot"][0]).normalized()]
            if removed[i]:
                return
            for j in wall_ids[i]:
                O.bodies[j].state.vel = Vector3(*m["velocity"])
                O.bodies[j].state.angVel = Vector3(0, 0, 0)
            if k == 0 and dynamic(m):
                # the laws' first look (iteration 0) sees Wall::velocity_at at t = 0
                for j in wall_ids[i]:
                    s = O.bodies[j].state
                    if m["osc"] is not None:
                        s.vel += Vector3(*m["osc"][0]) * m["osc"][1]
                    if m["rot"] is not None and m["rot"][2] != 0.0:
                        s.vel += (axis_of[i][1] * m["rot"][2]).cross(s.pos - axis_of[i][0])
                        s.angVel = axis_of[i][1] * m["rot"][2]


def gone(i, k):
    """Whether wall i is out of the run after step k (talus: inactive, neither servo nor load)."""
    return removed[i] or i in removed_soon or removal.get(i) == k


def move_walls(k):
    """The velocities that move each wall from its pose at step k to that at step k+1."""
    for i, m in enumerate(motion_of):
        if gone(i, k) or m is None:
            continue
        d = Vector3(*m["velocity"]) * dt
        if m["osc"] is not None:
            amp, om = Vector3(*m["osc"][0]), m["osc"][1]
            d += amp * (math.sin(om * (k + 1 - motion_t0[i]) * dt) - math.sin(om * (k - motion_t0[i]) * dt))
        rate = m["rot"][2] if m["rot"] is not None else 0.0
        if dynamic(m):
            q = Quaternion(axis_of[i][1], rate * dt) if rate != 0.0 else None
            for j in wall_ids[i]:
                s = O.bodies[j].state
                x = s.pos + d if q is None else axis_of[i][0] + d + q * (s.pos - axis_of[i][0])
                s.vel = (x - s.pos) / dt
                s.angVel = axis_of[i][1] * rate if q is not None else Vector3(0, 0, 0)
        if axis_of[i] is not None:
            axis_of[i][0] = axis_of[i][0] + d


for i in range(len(wall_ids)):
    set_motion(i, 0, 0)

# servo walls (Wall::servo_update): at iteration k the load of step k sets the velocity
# along the direction for the move k -> k+1: gain (target - R) within +-max_speed,
# R = -F . direction the particles' push; travel: how far it has moved
servo_of = [w["servo"] for w in C["walls"]]
travel = [0.0] * len(wall_ids)


def servo_walls(k):
    for i, sv in enumerate(servo_of):
        if sv is None or gone(i, k):
            continue
        d = Vector3(*sv["direction"])
        F = Vector3(0, 0, 0)
        for j in wall_ids[i]:
            F += O.forces.f(j, True)
        v = min(max(sv["gain"] * (sv["target"] + F.dot(d)), -sv["max_speed"]), sv["max_speed"])
        for j in wall_ids[i]:
            O.bodies[j].state.vel = d * v
        travel[i] += v * dt
# (the exporter wrote wall_arm: 1 puts the torque's contact point on the wall's surface, 0.5 mid-overlap)
arm = C["wall_arm"]

# ---- probes
tracked = [(t, bid[t]) for t in C["track"]]
out = open("probes.csv", "w")
out.write(C["header"] + "\n")
stats = {"force_check": 0.0, "rows": 0}
v0 = {}


def clump_loads(cid, mem):
    """Force and torque (about the clump's centre) summed from its members, as Newton does."""
    xc = O.bodies[cid].state.pos
    F, T = Vector3(0, 0, 0), Vector3(0, 0, 0)
    for m, _ in mem:
        f = O.forces.f(m, True)
        F += f
        T += O.forces.t(m, True) + (O.bodies[m].state.pos - xc).cross(f)
    return F, T


def step_velocities(k):
    """{body id: (v_k, w_k)} of every sphere (members included): talus's end-of-step velocities."""
    V = {}
    for b, t, m, inertia in free:
        if k > 0 and born.get(b) == k:
            continue           # inserted at the start of step k: not in talus's row of step k
        s = O.bodies[b].state
        if k == 0:
            V[b] = (proj(s.vel), proj_w(s.angVel))
        else:
            V[b] = (proj(s.vel + (O.forces.f(b, True) / m + g) * (0.5 * dt)),
                    proj_w(s.angVel + O.forces.t(b, True) * (0.5 * dt / inertia)))
    for cid, mem, M, Ic in clumps:
        s = O.bodies[cid].state
        if k == 0:
            vc, wc = proj(s.vel), proj_w(s.angVel)
        else:
            F, T = clump_loads(cid, mem)
            vc = proj(s.vel + (F / M + g) * (0.5 * dt))
            wc = proj_w(s.angVel + T * (0.5 * dt / Ic))
        for m, _ in mem:
            V[m] = (vc + wc.cross(O.bodies[m].state.pos - s.pos), wc)
    return V


def energies(V):
    ke, pe = [], []
    for b, (v, w) in V.items():
        m, inertia = mass_inertia[b]
        ke.append(0.5 * m * v.squaredNorm() + 0.5 * inertia * w.squaredNorm())
        pe.append(-m * g.dot(O.bodies[b].state.pos))
    return math.fsum(ke), math.fsum(pe)


def fmt(x):
    return "%.17g" % float(x)


def write_row(k, V, ke):
    n_contacts = 0
    nw = len(wall_ids)
    tq = [Vector3(0, 0, 0) for _ in range(nw)]
    fw = [Vector3(0, 0, 0) for _ in range(nw)]
    for I in O.interactions.all(True):
        geo, ph = I.geom, I.phys
        if geo is None or ph is None:
            continue
        pen = geo.penetrationDepth
        if not pen > 0.0:
            continue
        n_contacts += 1
        w1, w2 = wall_of.get(I.id1), wall_of.get(I.id2)
        if w1 is None and w2 is None:
            continue
        nrm = geo.normal                       # from id1 to id2
        if hertz:
            f12 = ph.normalForce + ph.shearForce   # the force on id2
        else:
            f12 = viscel_force(I, geo, ph)
        if w1 is not None:
            w, s, fwall, n_ws = w1, I.id2, -f12, nrm
        else:
            w, s, fwall, n_ws = w2, I.id1, f12, -nrm
        p = O.bodies[s].state.pos - n_ws * (radius_of[s] - arm * pen)
        fw[w] += fwall
        tq[w] += p.cross(fwall)
    cols = [fmt(k * dt), str(k), ctl["name"], fmt(ke), str(n_contacts)]
    if C["particles_column"]:
        cols.append(str(len(V)))
    for i in range(nw):
        if removed[i]:
            cols += ["0"] * (6 + (axis_of[i] is not None))
            if servo_of[i] is not None:
                cols.append(fmt(travel[i]))
            continue
        F = Vector3(0, 0, 0)
        for j in wall_ids[i]:
            F += O.forces.f(j, True)
        stats["force_check"] = max(stats["force_check"], (F - fw[i]).norm())
        cols += [fmt(F[0]), fmt(F[1]), fmt(F[2]), fmt(tq[i][0]), fmt(tq[i][1]), fmt(tq[i][2])]
        if axis_of[i] is not None:
            p, a = axis_of[i]
            cols.append(fmt((tq[i] - p.cross(F)).dot(a)))
        if servo_of[i] is not None:
            cols.append(fmt(travel[i]))
    if C["mass_below_z"] is not None:
        z = C["mass_below_z"]
        cols.append(fmt(math.fsum(info[t][0] for t, b in bid.items() if O.bodies[b].state.pos[2] < z)))
    if C["momentum"]:
        cols += [fmt(math.fsum(info[t][0] * V[b][0][c] for t, b in bid.items())) for c in range(3)]
    for t, b in tracked:
        x = wrap(O.bodies[b].state.pos)
        v, w = V[b]
        f = O.forces.f(b, True) + g * info[t][0]
        cols += [fmt(q) for q in (x[0], x[1], x[2], v[0], v[1], v[2], w[0], w[1], w[2], f[0], f[1], f[2])]
    out.write(",".join(cols) + "\n")
    out.flush()
    stats["rows"] += 1


def viscel_force(I, geo, ph):
    """ViscEl's force on id2 (Law2_ScGeom_ViscElPhys_Basic): the stored shear force is the
    elastic part; while it sticks the law adds cs times the shear velocity of id1 against id2."""
    n = geo.normal
    fn = ph.normalForce
    fs = Vector3(ph.shearForce)
    b1, b2 = O.bodies[I.id1].state, O.bodies[I.id2].state
    c = geo.contactPoint
    vr = (b1.vel + b1.angVel.cross(c - b1.pos)) - (b2.vel + b2.angVel.cross(c - b2.pos))
    vs = vr - n * vr.dot(n)
    cap2 = fn.squaredNorm() * ph.tangensOfFrictionAngle ** 2
    if fs.squaredNorm() < cap2 * (1 - 1e-12):
        fs = fs + vs * ph.cs
    return fn + fs


# ---- phases: talus's step rules in the same arithmetic
phases = C["phases"]
ctl = {"phase": 0, "start": 0, "settle_end": None, "pe0": None, "E": {},
       "name": phases[0]["name"] if phases else "end"}


def crossed(k, interval=iv):
    return math.floor((k * dt + 0.5 * dt) / interval) > math.floor(((k - 1) * dt + 0.5 * dt) / interval)


def phase_end(s0, d):
    start = s0 * dt
    n = max(0, math.ceil(d / dt - 0.5))
    while n > 0 and ((s0 + n - 1) * dt - start) >= d - 0.5 * dt:
        n -= 1
    while ((s0 + n) * dt - start) < d - 0.5 * dt:
        n += 1
    return s0 + n


def first_step(t, lo):
    """The least step k >= lo with k dt >= t - dt/2."""
    k = max(lo, math.ceil(t / dt - 0.5))
    while k > lo and (k - 1) * dt >= t - 0.5 * dt:
        k -= 1
    while k * dt < t - 0.5 * dt:
        k += 1
    return k


def ke_phase_open():
    if ctl["phase"] >= len(phases):
        return False
    return phases[ctl["phase"]]["frac"] is not None and ctl["settle_end"] is None


snap_iv = C["snapshot_interval"]


def snap_due(k):
    return snap_iv is not None and (k == 0 or crossed(k, snap_iv))


def write_snapshot(k, V):
    """What continuum fields need at step k (`output.snapshot_interval` with
    `output.contacts`), in snapshot.<k>.txt: a line `t TIME`; per sphere `p id x y z vx vy vz
    radius mass`; per contact `c a partner wall fx fy fz px py pz cx cy cz bx by bz`: the
    force on particle a (the lower id of a pair), the contact point, a's centre and the
    branch to it from the partner's centre (or from the wall's contact point; partner is
    then the wall's index)."""
    tid = {b: t for t, b in bid.items()}
    with open("snapshot.%d.txt" % k, "w") as fh:
        fh.write("t %s\n" % fmt(k * dt))
        for t in sorted(bid):
            b = bid[t]
            if b not in V:
                continue
            x, v = wrap(O.bodies[b].state.pos), V[b][0]
            fh.write("p %d %s %s %s %s %s %s %s %s\n" % (t, fmt(x[0]), fmt(x[1]), fmt(x[2]), fmt(v[0]), fmt(v[1]), fmt(v[2]), fmt(info[t][2]), fmt(info[t][0])))
        for I in O.interactions.all(True):
            geo, ph = I.geom, I.phys
            if geo is None or ph is None or not geo.penetrationDepth > 0.0:
                continue
            f12 = ph.normalForce + ph.shearForce if hertz else viscel_force(I, geo, ph)   # on id2
            w1, w2 = wall_of.get(I.id1), wall_of.get(I.id2)
            cp = geo.contactPoint
            if w1 is None and w2 is None:
                t1, t2 = tid.get(I.id1), tid.get(I.id2)
                if t1 is None or t2 is None:
                    continue
                x1 = O.bodies[I.id1].state.pos
                x2 = O.bodies[I.id2].state.pos + (O.cell.hSize * Vector3(I.cellDist) if O.periodic else ZERO)
                a, partner, fa, ca, br = (t1, t2, -f12, x1, x1 - x2) if t1 < t2 else (t2, t1, f12, x2, x2 - x1)
                wall = 0
            else:
                wall = 1
                partner = w1 if w1 is not None else w2
                body = I.id2 if w1 is not None else I.id1
                a = tid.get(body)
                if a is None:
                    continue
                fa = f12 if w1 is not None else -f12
                ca = O.bodies[body].state.pos
                br = ca - cp
            shift = wrap(ca) - ca
            c = cp + shift
            fh.write("c %d %d %d %s\n" % (a, partner, wall, " ".join(fmt(q) for q in (*fa, *c, *(ca + shift), *br))))


def hook():
    k = O.iter
    if snap_due(k):
        write_snapshot(k, step_velocities(k))
    row_due = k == 0 or crossed(k)
    ke_due = k == 0 or (ke_phase_open() and k % 20 == 0)
    if row_due or ke_due:
        V = step_velocities(k)
        ke, pe = energies(V)
        if ke_due:
            ctl["E"][k] = (ke, pe)
        if k == 0:
            ctl["pe0"] = pe
        if row_due:
            write_row(k, V, ke)
    if k == 0:
        # v(-1/2) = v_0 - dt/2 a_0: leapfrog from here is velocity Verlet from v_0
        for b, t, m, inertia in free:
            s = O.bodies[b].state
            s.vel = proj(s.vel - (O.forces.f(b, True) / m + g) * (0.5 * dt))
            s.angVel = proj_w(s.angVel - O.forces.t(b, True) * (0.5 * dt / inertia))
        for cid, mem, M, Ic in clumps:
            s = O.bodies[cid].state
            F, T = clump_loads(cid, mem)
            s.vel = proj(s.vel - (F / M + g) * (0.5 * dt))
            s.angVel = proj_w(s.angVel - T * (0.5 * dt / Ic))
    else:
        # the end of talus's step k (its walls then move on as the phase now says)
        advance_phase(k)
    move_walls(k)
    servo_walls(k)


__main__._talus_hook = hook


def erase(i):
    if not removed[i]:
        for j in wall_ids[i]:
            O.bodies.erase(j)
        removed[i] = True


removed_soon = set()
to_erase = []  # walls a phase's end removes, erased after the iteration (between O.run chunks)


def advance_phase(K):
    """Simulation::advance_phase at the end of step K."""
    if ctl["phase"] >= len(phases):
        return
    p = phases[ctl["phase"]]
    done = (K * dt - ctl["start"] * dt) >= p["duration"] - 0.5 * dt
    if p["frac"] is not None:
        if ctl["settle_end"] is None and K % 20 == 0:
            ke, pe = ctl["E"][K]
            drop = ctl["pe0"] - pe
            if drop > 0.0 and ke < p["frac"] * drop:
                ctl["settle_end"] = K * dt + p["settle"]
                print("talus export: phase %s settled at step %d" % (p["name"], K))
        if ctl["settle_end"] is not None:
            done = done or K * dt >= ctl["settle_end"] - 0.5 * dt
    if done:
        for i in p["remove"]:
            to_erase.append(i)
            removed_soon.add(i)
        ctl["phase"] += 1
        ctl["start"] = K
        ctl["settle_end"] = None
        ctl["name"] = phases[ctl["phase"]]["name"] if ctl["phase"] < len(phases) else "end"
        for i in range(len(wall_ids)):
            if i not in removed_soon:
                set_motion(i, ctl["phase"], K)
        print("talus export: phase %s ended at step %d" % (p["name"], K))


def next_event(K):
    """The least step > K at which a phase can end, a KE test falls or a wall goes."""
    p = phases[ctl["phase"]]
    cand = [phase_end(ctl["start"], p["duration"])]
    if p["frac"] is not None:
        if ctl["settle_end"] is None:
            lo = K + 1
            cand.append(lo + (-lo) % 20)
        else:
            cand.append(first_step(ctl["settle_end"], K + 1))
    cand += [s for s in removal.values() if s > K]
    # a chunk ends before the iteration at whose start particles come in
    cand += [inserted[0][0] - 1] if inserted and inserted[0][0] - 1 > K else []
    return max(K + 1, min(cand))


removal = {i: first_step(w["remove_at"], 1) for i, w in enumerate(C["walls"]) if w["remove_at"] is not None}

O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb(), Bo1_Facet_Aabb()], verletDist=0.5 * C["skin"]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom(hertzian=True),
                     Ig2_Facet_Sphere_ScGeom(hertzian=True)], [ip2], [law2]),
    PyRunner(command="_talus_hook()", iterPeriod=1, initRun=True),
    NewtonIntegrator(damping=0.0, gravity=g),
]

K = -1
if not phases:
    O.run(1, True)
    K = 0
while ctl["phase"] < len(phases):
    n = next_event(K)
    O.run(n - K, True)       # iterations K+1 .. n
    K = n
    for t, b in bid.items():
        x = wrap(O.bodies[b].state.pos)
        if any(not (lo[c] <= x[c] <= hi[c]) for c in range(3)):
            out.close()
            sys.exit("talus export: particle %d left the domain at step %d: (%g, %g, %g)" % (t, K, x[0], x[1], x[2]))
    for i, s in removal.items():
        if s == K:
            erase(i)
    while to_erase:
        erase(to_erase.pop())
    insert_batch(K + 1)
out.close()
if C["final_state"]:
    # the state of step K: Newton has already moved every body to x(K+1) = x(K) + dt v(K+1/2)
    with open("final.csv", "w") as fh:
        fh.write("id,x,y,z,vx,vy,vz,radius\n")
        for t in sorted(bid):
            s = O.bodies[bid[t]].state
            x = wrap(s.pos - s.vel * dt)
            fh.write("%d,%s,%s,%s,%s,%s,%s,%s\n" % (t, fmt(x[0]), fmt(x[1]), fmt(x[2]), fmt(s.vel[0]), fmt(s.vel[1]), fmt(s.vel[2]), fmt(info[t][2])))
print("TALUS-EXPORT-DONE step=%d rows=%d force_check=%.3g" % (K, stats["rows"], stats["force_check"]))
