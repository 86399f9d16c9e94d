# H1: hopper fill and discharge (CASES.md "H1"), the YADE 2023.02a side of cases/H1-small.toml
# and of liggghts_cases/H1.in (same probe CSV and fill-end CSV).
#
# Run headless, one thread (YADE with several threads is not deterministic), from the
# repository root (the default mesh paths are relative to it):
#
#   ./target/release/talus cloud cases/H1-small.toml --out /tmp/h1cloud.csv
#   yade -n -j 1 -x yade_cases/H1.py --cloud /tmp/h1cloud.csv --out /tmp/h1_yade.csv \
#        --out-fill-end /tmp/h1_yade_fill_end.csv --fill-time 0.66 --discharge-time 1.5
#
# Add --checkpoint-every 600 for a run that can be killed and resumed: the same command again
# continues from the last checkpoint and ends with the same files, byte for byte (README,
# "Checkpoints and resume").
#
# See yade_cases/README.md ("H1.py") for every option, the columns, the timing convention
# and the YADE quirks met here.
#
# Set-up (SI units): material seed-soft (E = 1e6 Pa, nu = 0.3, rho = 2500 kg/m3,
# mu = 0.4, en = es = 0.5) for particles and walls; Hertz-Mindlin
# (Ip2_FrictMat_FrictMat_MindlinPhys(en, es) + Law2_ScGeom_MindlinPhys_Mindlin);
# hopper and lower box: the STL meshes as fixed facets, flat (Ig2_Facet_Sphere_ScGeom
# hertzian=True: R* = r); gate: the plane z = gate_z (utils.wall, hertzian=True), erased
# after the fill; gravity (0, 0, -9.81); fixed dt; NewtonIntegrator(damping=0).

import argparse
import csv
import hashlib
import json
import math
import os
import sys
import time

from yade import ymport

# The other names YADE puts in the script's namespace (O, utils, Vector3, engines,
# functors) are used unqualified below, as in every YADE script.

HEADER = ("time_s,step,phase,kinetic_energy_j,contacts,"
          "hopper_force_x_n,hopper_force_y_n,hopper_force_z_n,"
          "hopper_torque_x_n_m,hopper_torque_y_n_m,hopper_torque_z_n_m,"
          "gate_force_x_n,gate_force_y_n,gate_force_z_n,"
          "gate_torque_x_n_m,gate_torque_y_n_m,gate_torque_z_n_m,"
          "box_force_x_n,box_force_y_n,box_force_z_n,"
          "box_torque_x_n_m,box_torque_y_n_m,box_torque_z_n_m,mass_below_kg")
FILL_END_HEADER = ("fill_end_time_s,window_steps,"
                   "hopper_force_x_n,hopper_force_y_n,hopper_force_z_n,"
                   "gate_force_x_n,gate_force_y_n,gate_force_z_n,"
                   "box_force_x_n,box_force_y_n,box_force_z_n")
WALLS = ("hopper", "gate", "box")  # the case file's order, as in the CSV


def parse_args(argv):
    p = argparse.ArgumentParser(prog="H1.py", description="YADE H1 hopper fill and discharge (talus cases/H1-small.toml).")
    p.add_argument("--cloud", required=True, help="talus cloud CSV: id,x,y,z,radius,vx,vy,vz")
    p.add_argument("--out", default="h1_yade.csv", help="probe time series (CSV)")
    p.add_argument("--out-fill-end", default="fill_end.csv", help="wall forces averaged over the fill's last --fill-window")
    p.add_argument("--fill-time", type=float, default=0.66, help="fill phase, s (rounded to whole steps)")
    p.add_argument("--discharge-time", type=float, default=1.5, help="discharge after the gate removal, s (rounded)")
    p.add_argument("--dt", type=float, default=1.0673161788874508e-4, help="time step, s (O.dt, no time stepper)")
    p.add_argument("--interval", type=float, default=0.01, help="probe interval, s (rounded to whole steps, >= 1)")
    p.add_argument("--fill-window", type=float, default=0.1, help="fill-end averaging window, s (rounded, >= 1 step)")
    p.add_argument("--thermo-time", type=float, default=0.1, help="progress line on stdout every this many s")
    p.add_argument("--hopper-stl", default="cases/meshes/hopper.stl", help="bin + converging section (m, STL)")
    p.add_argument("--box-stl", default="cases/meshes/box.stl", help="lower box (m, STL)")
    p.add_argument("--gate-z", type=float, default=0.0, help="gate: the plane z = gate-z; mass below counts z < gate-z")
    p.add_argument("--skin", type=float, default=0.001,
                   help="LIGGGHTS-style neighbour skin, m; the collider gets verletDist = skin/2 (see README)")
    p.add_argument("--youngs", type=float, default=1.0e6)
    p.add_argument("--poisson", type=float, default=0.3)
    p.add_argument("--density", type=float, default=2500.0)
    p.add_argument("--restitution", type=float, default=0.5, help="Mindlin en = es")
    p.add_argument("--friction", type=float, default=0.4, help="mu; frictionAngle = atan(mu)")
    p.add_argument("--gravity", type=float, default=9.81, help="|g|, along -z")
    p.add_argument("--start", choices=["verlet", "leapfrog"], default="verlet",
                   help="verlet (default): start YADE's leapfrog from v(-dt/2) = v0 - dt/2 g, which reproduces "
                        "velocity Verlet from v0 (talus, LIGGGHTS); leapfrog: v(-dt/2) = v0")
    p.add_argument("--ke-velocity", choices=["step", "half"], default="step",
                   help="step (default): KE from v_k = v(k-1/2) + dt/2 (F_k/m + g), w_k likewise; half: YADE's v(k-1/2)")
    p.add_argument("--torque-point", choices=["surface", "yade"], default="surface",
                   help="surface (default): torque about the origin with the contact point on the wall surface "
                        "(as talus and LIGGGHTS); yade: O.forces.t + pos x f (YADE's contact point, mid-overlap)")
    p.add_argument("--summary", default=None, help="also write the JSON summary to this file")
    p.add_argument("--checkpoint-every", type=float, default=0.0, metavar="SECONDS",
                   help="resumable run: save the whole state (O.save) at the first checkpoint step after every "
                        "SECONDS of wall time, next to --out (OUT.ckpt.json and OUT.ckpt.ITER.bin.gz); a later run "
                        "with the same arguments continues from it. 0 (default): no checkpoints, no resume")
    p.add_argument("--checkpoint-steps", type=int, default=None, metavar="N",
                   help="checkpoint steps: every N steps (default: 10 probe intervals). At each one the state makes "
                        "a save/load round trip (in memory, or through the checkpoint file), so that a run resumed "
                        "from any checkpoint is bit-identical to a run that was never stopped")
    p.add_argument("--restart", action="store_true",
                   help="with --checkpoint-every: ignore (and replace) an existing checkpoint of --out and start afresh")
    return p.parse_args(argv)


# arguments that do not change the run (they may differ between the pieces of a resumed run)
NOT_CHECKED = ("checkpoint_every", "restart", "thermo_time", "summary")


def sha256_of(path):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_json_atomic(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(obj, fh)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def read_cloud(path):
    rows = []
    with open(path, newline="") as fh:
        rd = csv.DictReader(fh)
        for r in rd:
            rows.append((int(r["id"]), float(r["x"]), float(r["y"]), float(r["z"]), float(r["radius"]),
                         float(r["vx"]), float(r["vy"]), float(r["vz"])))
    if not rows:
        raise SystemExit("empty cloud: " + path)
    return rows


def steps_of(seconds, dt):
    # nearest whole step, as liggghts_cases/H1.in (floor(x/dt + 0.5))
    return int(math.floor(seconds / dt + 0.5))


def fmt(x):
    return "%.17g" % float(x)


def discharge_rate(times, masses, total):
    """Least-squares slope of mass against time between 20% and 80% of the total mass."""
    pts = [(t, m) for t, m in zip(times, masses) if 0.2 * total <= m <= 0.8 * total]
    if len(pts) < 2:
        return None, len(pts)
    n = float(len(pts))
    mt = sum(t for t, _ in pts) / n
    mm = sum(m for _, m in pts) / n
    sxx = sum((t - mt) ** 2 for t, _ in pts)
    sxy = sum((t - mt) * (m - mm) for t, m in pts)
    return (sxy / sxx if sxx > 0 else None), len(pts)


def main(argv):
    a = parse_args(argv)
    dt = a.dt
    if not dt > 0:
        raise SystemExit("--dt must be > 0")
    fill_steps = steps_of(a.fill_time, dt)
    discharge_steps = steps_of(a.discharge_time, dt)
    out_every = steps_of(a.interval, dt)
    win_steps = steps_of(a.fill_window, dt)
    thermo_every = max(1, steps_of(a.thermo_time, dt))
    if fill_steps < 0 or discharge_steps < 0:
        raise SystemExit("--fill-time and --discharge-time must be >= 0")
    if out_every < 1:
        raise SystemExit("--interval must be at least one step")
    if win_steps < 1:
        raise SystemExit("--fill-window must be at least one step")
    ck_steps = a.checkpoint_steps if a.checkpoint_steps is not None else 10 * out_every
    if ck_steps < 1:
        raise SystemExit("--checkpoint-steps must be at least 1")
    total_steps = fill_steps + discharge_steps
    # steps averaged: fill_steps-win_steps+1 .. fill_steps (step 0 included if the fill is shorter)
    win_first = max(0, fill_steps - win_steps + 1)
    win_used = fill_steps - win_first + 1
    gz = a.gate_z
    g_vec = Vector3(0.0, 0.0, -a.gravity)

    # ---- checkpoint (--checkpoint-every): OUT.ckpt.json (arguments, O.iter, the state file's
    # name, the probe CSV's length, the driver's own state) and OUT.ckpt.ITER.bin.gz (O.save)
    ckpt = a.checkpoint_every > 0
    ck_json = a.out + ".ckpt.json"
    ck_dir = os.path.dirname(os.path.abspath(ck_json))
    ck_prefix = os.path.basename(a.out) + ".ckpt."
    run_args = {k: v for k, v in sorted(vars(a).items()) if k not in NOT_CHECKED}
    run_args["checkpoint_steps"] = ck_steps
    run_args["cloud_sha256"] = sha256_of(a.cloud)

    def state_files():
        return sorted(os.path.join(ck_dir, f) for f in os.listdir(ck_dir)
                      if f.startswith(ck_prefix) and f.endswith(".bin.gz"))

    def remove_checkpoint(keep=None):
        for f in state_files():
            if f != keep:
                os.remove(f)

    meta = None
    if os.path.exists(ck_json):
        if ckpt and not a.restart:
            with open(ck_json) as fh:
                meta = json.load(fh)
            old_args = meta.get("args", {})
            for k in sorted(set(old_args) | set(run_args)):
                if old_args.get(k) != run_args.get(k):
                    name = "the cloud's content (sha256)" if k == "cloud_sha256" else "--" + k.replace("_", "-")
                    raise SystemExit("H1.py: the checkpoint %s was made with %s = %r, this run has %r: pass the same "
                                     "arguments to resume it, or --restart to start afresh"
                                     % (ck_json, name, old_args.get(k), run_args.get(k)))
            if meta.get("finished"):
                if a.summary and meta.get("summary") is not None:
                    with open(a.summary, "w") as fh:
                        fh.write(json.dumps(meta["summary"], sort_keys=True, indent=1) + "\n")
                print("H1: this run finished already (%s: step %d); nothing to do (--restart runs it again)"
                      % (ck_json, meta["iter"]))
                sys.stdout.flush()
                return
        else:
            # a fresh run writes --out anew: the old checkpoint no longer matches it
            print("H1: removing the checkpoint of an earlier run (%s)" % ck_json)
            os.remove(ck_json)
            remove_checkpoint()

    cloud = read_cloud(a.cloud)

    O.reset()
    O.dt = dt
    mat = FrictMat(young=a.youngs, poisson=a.poisson, density=a.density,
                   frictionAngle=math.atan(a.friction), label="seed-soft")
    mat_id = O.materials.append(mat)

    # ---- bodies: the gate first (id 0), so that the sphere with talus id k gets YADE id k
    # when the cloud's ids are 1..N in file order (talus writes them so)
    gate_id = O.bodies.append(utils.wall(gz, axis=2, sense=0, material=mat_id))
    sphere_ids = []
    talus_ids = []
    for (tid, x, y, z, r, vx, vy, vz) in cloud:
        b = utils.sphere((x, y, z), r, material=mat_id)
        v0 = Vector3(vx, vy, vz)
        if a.start == "verlet":
            # leapfrog v(1/2) = v(-1/2) + dt a0 equals velocity Verlet's v0 + dt/2 a0 when
            # v(-1/2) = v0 - dt/2 a0; a0 = g (the cloud has no overlaps: checked below)
            v0 = v0 - g_vec * (0.5 * dt)
        b.state.vel = v0
        b.state.angVel = Vector3(0.0, 0.0, 0.0)
        sphere_ids.append(O.bodies.append(b))
        talus_ids.append(tid)
    ids_match = all(s == t for s, t in zip(sphere_ids, talus_ids))
    hopper_ids = O.bodies.append(ymport.stl(a.hopper_stl, fixed=True, material=mat_id))
    box_ids = O.bodies.append(ymport.stl(a.box_stl, fixed=True, material=mat_id))
    if not hopper_ids or not box_ids:
        raise SystemExit("empty mesh")

    wall_of = {gate_id: 1}
    for i in hopper_ids:
        wall_of[i] = 0
    for i in box_ids:
        wall_of[i] = 2
    # coplanar facet groups (same plane, either orientation), to detect the double-counted
    # contact of a sphere on the shared edge of two coplanar triangles
    plane_of = {}
    planes = []
    for i in list(hopper_ids) + list(box_ids):
        b = O.bodies[i]
        n = Vector3(b.shape.normal)
        # orient the normal canonically (first non-zero component positive)
        for c in range(3):
            if abs(n[c]) > 1e-9:
                if n[c] < 0:
                    n = -n
                break
        d = n.dot(b.state.pos)
        key = None
        for k, (pn, pd) in enumerate(planes):
            if (pn - n).norm() < 1e-6 and abs(pd - d) < 1e-7:
                key = k
                break
        if key is None:
            planes.append((n, d))
            key = len(planes) - 1
        plane_of[i] = key

    masses = {i: O.bodies[i].state.mass for i in sphere_ids}
    total_mass = sum(masses.values())
    radius_of = {i: O.bodies[i].shape.radius for i in sphere_ids}

    # ---- engines: the probe hook sits between the force loop and the integrator ----
    ig_facet = Ig2_Facet_Sphere_ScGeom(hertzian=True)
    ig_wall = Ig2_Wall_Sphere_ScGeom(hertzian=True)
    collider = InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb(), Bo1_Facet_Aabb()],
                                     verletDist=0.5 * a.skin, label="collider")

    st = {
        "gate": True,
        "acc": [0.0] * 9, "acc_n": 0,
        "fill_end": None,
        "rows": [],  # (time, phase, mass_below) for the summary
        "t0": time.time(), "t_last": time.time(), "it_last": 0,
        "double_max": 0, "double_rows": 0, "double_at_fill_end": None, "initial_contacts": None,
        "force_check": 0.0,
        "pieces": [0],  # O.iter at the start of each piece of a resumed run
    }
    # the driver's own state saved with a checkpoint (the rest of st is timing)
    SAVED = ("gate", "acc", "acc_n", "fill_end", "rows", "double_max", "double_rows", "double_at_fill_end",
             "initial_contacts", "force_check", "pieces")
    elapsed_before = 0.0
    if meta is None:
        out = open(a.out, "w")
        out.write(HEADER + "\n")
        out.flush()
    else:
        # ---- resume: the scene as saved (bodies, interactions, engines, O.iter, O.time) ----
        state = os.path.join(ck_dir, meta["state"])
        if not os.path.exists(state):
            raise SystemExit("H1.py: %s names %s, which is missing: cannot resume; --restart starts afresh"
                             % (ck_json, state))
        O.load(state)
        if O.iter != meta["iter"]:
            raise SystemExit("H1.py: %s holds step %d, the checkpoint says %d" % (state, O.iter, meta["iter"]))
        for k in SAVED:
            st[k] = meta["st"][k]
        st["rows"] = [tuple(r) for r in st["rows"]]
        st["pieces"].append(O.iter)
        elapsed_before = meta["elapsed_s"]
        # the probe CSV back to the rows written before the checkpoint (a killed piece
        # may have written more)
        if not os.path.exists(a.out) or os.path.getsize(a.out) < meta["csv_bytes"]:
            raise SystemExit("H1.py: %s is shorter than at the checkpoint (%d bytes): cannot resume; --restart "
                             "starts afresh" % (a.out, meta["csv_bytes"]))
        with open(a.out, "r+b") as fh:
            fh.truncate(meta["csv_bytes"])
            fh.seek(0)
            n_lines = fh.read().count(b"\n")
        if n_lines != len(st["rows"]) + 1:
            raise SystemExit("H1.py: %s has %d rows at the checkpoint's length, the checkpoint %d"
                             % (a.out, n_lines - 1, len(st["rows"])))
        out = open(a.out, "a")
        collider = [e for e in O.engines if isinstance(e, InsertionSortCollider)][0]
        print("H1: resuming from %s at step %d (t = %.6g s, %d probe rows kept)"
              % (state, O.iter, O.time, len(st["rows"])))
    st["t0"] = time.time() - elapsed_before
    st["t_last"], st["it_last"] = time.time(), O.iter

    def wall_forces():
        """Force of the particles ON each wall: sums of O.forces.f over the wall's bodies."""
        fs = []
        for ids in (hopper_ids, None, box_ids):
            if ids is None:
                fs.append(O.forces.f(gate_id, True) if st["gate"] else Vector3(0, 0, 0))
                continue
            s = Vector3(0.0, 0.0, 0.0)
            for i in ids:
                s += O.forces.f(i, True)
            fs.append(s)
        return fs

    def scan_interactions():
        """Contacts, wall torques about the origin with the contact point on the wall surface,
        per-wall forces rebuilt from the interactions (a check on O.forces), double contacts."""
        n_contacts = 0
        tq = [Vector3(0, 0, 0), Vector3(0, 0, 0), Vector3(0, 0, 0)]
        fw = [Vector3(0, 0, 0), Vector3(0, 0, 0), Vector3(0, 0, 0)]
        seen = {}
        double = 0
        for I in O.interactions.all(True):
            g = I.geom
            ph = I.phys
            if g is None or ph is None:
                continue
            pen = g.penetrationDepth
            if not pen > 0.0:
                continue
            n_contacts += 1
            id1, id2 = I.id1, I.id2
            w1 = wall_of.get(id1)
            w2 = wall_of.get(id2)
            if w1 is None and w2 is None:
                continue
            f12 = ph.normalForce + ph.shearForce  # force on id2 (Law2 applies -(Fn+Fs) to id1)
            nrm = g.normal  # from id1 to id2
            if w1 is not None:
                w, s, fwall = w1, id2, -f12
                p = O.bodies[s].state.pos - nrm * (radius_of[s] - pen)
            else:
                w, s, fwall = w2, id1, f12
                p = O.bodies[s].state.pos + nrm * (radius_of[s] - pen)
            fw[w] += fwall
            tq[w] += p.cross(fwall)
            wid = id1 if w1 is not None else id2
            if wid in plane_of:
                key = (s, plane_of[wid])
                if key in seen:
                    double += 1
                else:
                    seen[key] = 1
        return n_contacts, tq, fw, double

    def yade_torques():
        tq = []
        for ids in (hopper_ids, [gate_id] if st["gate"] else [], box_ids):
            s = Vector3(0.0, 0.0, 0.0)
            for i in ids:
                s += O.forces.t(i, True) + O.bodies[i].state.pos.cross(O.forces.f(i, True))
            tq.append(s)
        return tq

    def particles():
        ke = 0.0
        mb = 0.0
        half = a.ke_velocity == "half"
        for i in sphere_ids:
            s = O.bodies[i].state
            m = s.mass
            v = s.vel
            w = s.angVel
            inert = s.inertia[0]
            if not half:
                v = v + (O.forces.f(i, True) / m + g_vec) * (0.5 * dt)
                w = w + O.forces.t(i, True) * (0.5 * dt / inert)
            ke += 0.5 * m * v.squaredNorm() + 0.5 * inert * w.squaredNorm()
            if s.pos[2] < gz:
                mb += m
        return ke, mb

    def probe_row(k, phase):
        fs = wall_forces()
        ke, mb = particles()
        n_contacts, tq_s, fw, double = scan_interactions()
        tq = tq_s if a.torque_point == "surface" else yade_torques()
        for w in range(3):
            st["force_check"] = max(st["force_check"], (fw[w] - fs[w]).norm())
        if double:
            st["double_rows"] += 1
            st["double_max"] = max(st["double_max"], double)
        if k == 0:
            st["initial_contacts"] = n_contacts
        cols = [fmt(k * dt), str(k), phase, fmt(ke), str(n_contacts)]
        for w in range(3):
            if w == 1 and not st["gate"]:
                cols += ["0"] * 6
                continue
            cols += [fmt(fs[w][0]), fmt(fs[w][1]), fmt(fs[w][2]), fmt(tq[w][0]), fmt(tq[w][1]), fmt(tq[w][2])]
        cols.append(fmt(mb))
        out.write(",".join(cols) + "\n")
        out.flush()
        st["rows"].append((k * dt, phase, mb))
        return ke, mb, n_contacts, fs, double

    def hook():
        k = O.iter
        phase = "fill" if k <= fill_steps else "discharge"
        if st["gate"] and k >= win_first:
            fs = wall_forces()
            acc = st["acc"]
            for w in range(3):
                for c in range(3):
                    acc[3 * w + c] += fs[w][c]
            st["acc_n"] += 1
            if k == fill_steps:
                st["fill_end"] = [x / st["acc_n"] for x in acc]
                with open(a.out_fill_end, "w") as fh:
                    fh.write(FILL_END_HEADER + "\n")
                    fh.write(",".join([fmt(k * dt), str(st["acc_n"])] + [fmt(x) for x in st["fill_end"]]) + "\n")
        info = None
        if k % out_every == 0:
            info = probe_row(k, phase)
        if k == fill_steps and st["gate"]:
            st["double_at_fill_end"] = scan_interactions()[3]
        if k % thermo_every == 0 or k == fill_steps or k == total_steps:
            if info is None:
                fs = wall_forces()
                ke, mb = particles()
                nc, _, _, double = scan_interactions()
            else:
                ke, mb, nc, fs, double = info
            now = time.time()
            rate = (k - st["it_last"]) * len(sphere_ids) / max(now - st["t_last"], 1e-9)
            st["t_last"], st["it_last"] = now, k
            print("H1 step %d t %.4f %s KE %.4e contacts %d double %d mass_below %.5f Fz hopper %.4f gate %.4f box %.4f"
                  " | %.0f s, %.3g particle-steps/s" % (k, k * dt, phase, ke, nc, double, mb, fs[0][2], fs[1][2],
                                                       fs[2][2], now - st["t0"], rate))
            sys.stdout.flush()

    import __main__
    __main__._h1_hook = hook

    if meta is None:
        O.engines = [
            ForceResetter(),
            collider,
            InteractionLoop(
                [Ig2_Sphere_Sphere_ScGeom(), ig_wall, ig_facet],
                [Ip2_FrictMat_FrictMat_MindlinPhys(en=a.restitution, es=a.restitution)],
                [Law2_ScGeom_MindlinPhys_Mindlin()],
            ),
            PyRunner(command="_h1_hook()", iterPeriod=1, initRun=True, label="h1_hook"),
            NewtonIntegrator(damping=0.0, gravity=g_vec),
        ]

    print("H1: %d spheres (ids match talus: %s), total mass %.6g kg, fill %d steps, discharge %d steps, "
          "probe every %d steps, fill-end window %d steps, dt %r, verletDist %g m"
          % (len(sphere_ids), ids_match, total_mass, fill_steps, discharge_steps, out_every, win_used, dt,
             collider.verletDist))
    sys.stdout.flush()

    ck_last = [time.time()]

    def save_checkpoint():
        """O.save to a temporary name, then os.replace; then the JSON (os.replace), which
        names the state file; then the older state files go."""
        out.flush()
        os.fsync(out.fileno())
        state = os.path.join(ck_dir, "%s%d.bin.gz" % (ck_prefix, O.iter))
        tmp = os.path.join(ck_dir, ck_prefix + "tmp.bin.gz")  # YADE picks the format by the suffix
        O.save(tmp)
        os.replace(tmp, state)
        saved = {k: st[k] for k in SAVED}
        write_json_atomic(ck_json, {
            "args": run_args, "finished": False, "iter": O.iter, "time": O.time, "state": os.path.basename(state),
            "csv_bytes": out.tell(), "elapsed_s": time.time() - st["t0"], "st": saved})
        remove_checkpoint(keep=state)
        return state

    def at_checkpoint_step():
        """Every ck_steps steps (between two O.run calls, a clean step boundary): the state
        makes a save/load round trip, through the checkpoint file when one is due, else in
        memory. O.load does not give back every detail of the running scene (the collider
        re-sorts its bounds, only real interactions are saved), so the run that was never
        stopped takes the same round trips as a resumed one and both continue from the same
        loaded state: bit-identical rows."""
        if time.time() - ck_last[0] >= a.checkpoint_every:
            t = time.time()
            state = save_checkpoint()
            O.load(state)
            ck_last[0] = time.time()
            print("H1: checkpoint at step %d: %s (%.1f s)" % (O.iter, state, ck_last[0] - t))
            sys.stdout.flush()
        else:
            O.saveTmp("h1")
            O.loadTmp("h1")

    def advance(end):
        """Run until O.iter == end, stopping at every checkpoint step on the way."""
        while O.iter < end:
            stop = min(end, (O.iter // ck_steps + 1) * ck_steps) if ckpt else end
            O.run(stop - O.iter, True)
            if ckpt and O.iter % ck_steps == 0:
                at_checkpoint_step()

    # fill: force evaluations at steps 0 .. fill_steps, all with the gate (the row and the
    # fill-end window at step fill_steps include the gate, as in LIGGGHTS); the leapfrog
    # update after the evaluation at fill_steps still carries the gate force
    advance(fill_steps + 1)
    if st["initial_contacts"] and st["pieces"][-1] == 0:
        print("H1 warning: %d contacts at step 0 (the verlet start assumes none)" % st["initial_contacts"])
    # gate removal: evaluations at steps fill_steps+1 .. total_steps have no gate
    if st["gate"]:
        O.bodies.erase(gate_id)
        st["gate"] = False
    advance(total_steps + 1)
    out.close()
    elapsed = time.time() - st["t0"]

    # ---- summary ----
    t_gate = fill_steps * dt
    dis = [(t - t_gate, m) for (t, ph, m) in st["rows"] if ph == "discharge"]
    rate, n_pts = discharge_rate([t for t, _ in dis], [m for _, m in dis], total_mass)
    fe = st["fill_end"]
    summary = {
        "spheres": len(sphere_ids), "ids_match_talus": ids_match, "total_mass_kg": total_mass,
        "weight_n": total_mass * a.gravity, "dt": dt, "fill_steps": fill_steps,
        "discharge_steps": discharge_steps, "out_every": out_every, "window_steps": win_used,
        "steps_run": O.iter, "elapsed_s": elapsed,
        "particle_steps_per_s": len(sphere_ids) * (O.iter) / max(elapsed, 1e-9),
        "discharge_rate_kg_s": rate, "discharge_rate_points": n_pts,
        "mass_below_end_kg": st["rows"][-1][2] if st["rows"] else None,
        "double_contacts_max": st["double_max"], "rows_with_double_contacts": st["double_rows"],
        "double_contacts_at_fill_end": st["double_at_fill_end"],
        "max_interaction_vs_oforces_force_diff_n": st["force_check"],
        "verlet_dist_m": collider.verletDist,
        "command": " ".join(["H1.py"] + list(argv)),
    }
    if ckpt:
        summary["checkpoint_steps"] = ck_steps
        summary["resumed_at_steps"] = st["pieces"][1:]
    if fe is not None:
        down_h, down_g = -fe[2], -fe[5]
        summary.update({"fill_end_time_s": t_gate, "fill_end_hopper_down_n": down_h, "fill_end_gate_down_n": down_g,
                        "fill_end_box_down_n": -fe[8],
                        "fill_end_force_balance": (down_h + down_g) / (total_mass * a.gravity)})
    print("H1-SUMMARY " + json.dumps(summary, sort_keys=True))
    if a.summary:
        with open(a.summary, "w") as fh:
            fh.write(json.dumps(summary, sort_keys=True, indent=1) + "\n")
    if ckpt:
        # finished: a later run with the same arguments does nothing (--restart runs again)
        write_json_atomic(ck_json, {"args": run_args, "finished": True, "iter": O.iter, "time": O.time,
                                    "summary": summary})
        remove_checkpoint()


main(sys.argv[1:])
