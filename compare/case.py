"""python -m compare CASE.toml [--engines talus,liggghts|yade|lammps] [--out DIR] [--set KEY=VALUE] [--replicas K] [--perturb KEY=VALUE] [--reuse]

Any case against the reference codes: the case is exported (`talus export --to ENGINE`)
and run there, talus runs it in that engine's convention, and one piece of code
measures both from their probes.csv.

By default each engine runs K replicas of the case (the case's `[compare] replicas`,
else 4) that differ at round-off, and the two ensembles are compared: step by step until
the replicas part, by window statistics and figures after (compare/ensemble.py, which
says how). With one replica (`--replicas 1`, or `replicas = 1` as the deterministic SC
set-ups have) single runs are compared as follows:

- the case's analysis figures where it has them (`collision`: restitution, contact
  duration, peak overlap and normal force, tangential rebound, spin; `hopper`: discharge
  rate (20-80% fit) and the walls' load over the weight at the end of the fill);
- for every probe column, the largest deviation over the run, talus's series against the
  reference's interpolated to talus's times, as a fraction of the reference column's range;
  and the difference of the column's means over each window of `[compare] windows`.

Tolerances come from the case's `[compare]` section (defaults: figures 0.02 relative,
series 0.05 of the range, window means 0.02 of the range). Writes report.md (a plot per
probe column), figures.json and the runs into DIR (default out/compare/<case name>);
exits 1 when anything is outside tolerance, 2 when an engine cannot run the case.
With both references, LIGGGHTS is also checked against YADE, and where they disagree talus
runs once per convention option (`--set contact.damping=yade`, ...) to name the option
that explains it (`--no-explain` skips this).
"""

import argparse
import csv
import json
import math
import subprocess
import sys
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from . import ensemble, fields
from .engines import TALUS, EngineError, check_versions
from .regress import DEFAULTS

SKIP = {"time_s", "step", "phase"}
CONVENTION = {"liggghts": "liggghts", "yade": "yade", "lammps": "lammps"}


def read_probes(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise EngineError(f"{path}: no rows")
    s = {c: np.array([float(r[c]) for r in rows]) for c in rows[0] if c != "phase"}
    s["phase"] = np.array([r["phase"] for r in rows])
    return s


def run(cmd, log, cwd=None):
    with open(log, "w") as f:
        p = subprocess.run([str(c) for c in cmd], cwd=cwd, stdout=f, stderr=subprocess.STDOUT)
    if p.returncode != 0:
        raise EngineError(f"{' '.join(map(str, cmd))} failed (exit {p.returncode}); log {log}:\n{Path(log).read_text()[-1500:]}")


# `--set KEY=VALUE` of the command line, applied to talus's runs and to the exports alike
SETS = []
# `--reuse`: a run already finished in the output folder (same case, same settings) is read, not run again
REUSE = False


def finished(out, what):
    """With --reuse: whether `out` holds a finished run of `what` (the command, as recorded)."""
    mark = out / "finished"
    return REUSE and mark.exists() and mark.read_text() == what


def run_talus(case, convention, out, extra=()):
    out.mkdir(parents=True, exist_ok=True)
    sets = [a for kv in [*SETS, *extra] for a in ("--set", kv)]
    cmd = [TALUS, "run", case, "--out", out, "--quiet", "--set", f"contact.convention={convention}", *sets]
    what = " ".join(map(str, cmd))
    if not finished(out, what):
        (out / "finished").unlink(missing_ok=True)
        run(cmd, out / "talus.log")
        (out / "finished").write_text(what)
    return read_probes(out / "probes.csv"), json.loads((out / "summary.json").read_text())


# The line each exported deck prints as its last act. LIGGGHTS ends a run early and exits
# with status 0 on SIGINT or SIGTERM ("Forced restart written"), so the exit status alone
# does not say that the deck ran to its end.
END_MARKS = {"liggghts": "talus export: done", "yade": "TALUS-EXPORT-DONE", "lammps": "talus export: done"}


def check_reached_end(engine, log):
    text = Path(log).read_text(errors="replace")
    if END_MARKS[engine] not in text:
        raise EngineError(f"{engine} stopped before the end of the deck (exit 0, but no '{END_MARKS[engine]}' in {log}; "
                          f"was it interrupted?):\n{text[-800:]}")


def run_reference(case, engine, out, inserted=None, extra=()):
    """The reference engine on the exported case; a case that inserts particles brings in
    those of `inserted` (the inserted.csv of talus's run in that engine's convention).
    `extra`: more `--set KEY=VALUE` for the export (a replica's particles)."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [TALUS, "export", case, "--to", engine, "--out", out, *[a for kv in [*SETS, *extra] for a in ("--set", kv)]]
    if inserted is not None and Path(inserted).exists():
        cmd += ["--inserted", inserted]
    what = " ".join(map(str, cmd))
    if not finished(out, what):
        (out / "finished").unlink(missing_ok=True)
        run(cmd, out / "export.log")
        if engine == "liggghts":
            run(["liggghts", "-in", "in.talus", "-log", "log.liggghts"], out / "run.log", cwd=out)
        elif engine == "lammps":
            run(["lmp", "-in", "in.talus", "-log", "log.lammps"], out / "run.log", cwd=out)
        else:
            run(["yade", "-n", "-j", "1", "-x", "talus.py"], out / "run.log", cwd=out)
        check_reached_end(engine, out / "run.log")
        (out / "finished").write_text(what)
    return read_probes(out / "probes.csv")


# Where LIGGGHTS's and YADE's conventions differ: each option, its YADE value for
# `talus run --set`, and the models it matters for (contact/conventions.rs `resolve`).
# (Friction mixing, mean against min, differs only between different materials.)
CONVENTION_OPTIONS = [
    ("contact.damping=yade", "Hertz damping: YADE's Thornton fit of restitution against LIGGGHTS's ratio", {"hertz"}),
    ("contact.end_of_contact=clip", "end of contact: normal force clipped at 0 (YADE) against tensile (LIGGGHTS)", {"hertz", "hooke"}),
    ("contact.tangential=incremental", "tangential history: incremented shear force (YADE) against total displacement (LIGGGHTS)", {"hertz", "hooke"}),
    ("contact.shear_kinematics=full_radii", "shear kinematics: full radii (YADE's Mindlin) against the contact point (LIGGGHTS)", {"hertz"}),
    ("contact.wall_contact_point=surface", "wall contact point: on the surface (YADE) against mid-overlap (LIGGGHTS)", {"hertz", "hooke"}),
]


def explain(case_path, case, checks, ts_l, ft_l, rs_y, fr_y, summary, tol, out):
    """For each check where LIGGGHTS and YADE disagree: run talus in LIGGGHTS's convention
    with one YADE option at a time (and, where no single option explains a check, two at a
    time), and name the option or pair that closes most of the gap between talus[liggghts]
    and YADE (the fraction closed is in the report)."""
    from itertools import combinations

    bad = [c for c in checks if not c["ok"] and c["kind"] in ("figure", "series")]
    if not bad:
        return []
    model = case.get("contact", {}).get("model", "hertz")
    opts = [(o, what) for o, what, models in CONVENTION_OPTIONS if model in models]
    runs = {}

    def switched(combo):
        if combo not in runs:
            tag = "+".join(o.split("=")[0].split(".")[1] for o in combo)
            o = out / f"talus-liggghts+{tag}"
            s, summ = run_talus(case_path, "liggghts", o, list(combo))
            runs[combo] = (s, figures_of(s, case, summ, o))
        return runs[combo]

    def dev(c, s, f):
        name = c["name"]
        if c["kind"] == "figure":
            return abs(f.get(name, math.nan) - fr_y[name])
        if name not in s:
            return math.nan
        one = {"time_s": s["time_s"], name: s[name]}
        return series_checks(one, rs_y, dict(tol, ignore=[], windows=[], series={}))[0]["deviation"]

    def closed(c, base, combo):
        s, f = switched(combo)
        d = dev(c, s, f)
        return (base - d) / base if base > 0 and d == d else 0.0

    what_of = dict(opts)
    rows = []
    for c in bad:
        base = dev(c, ts_l, ft_l)
        tried = [((o,), closed(c, base, (o,))) for o, _ in opts]
        best = max(tried, key=lambda x: x[1]) if tried else None
        if best is None or best[1] <= 0.5:
            pairs = [(combo, closed(c, base, combo)) for combo in combinations([o for o, _ in opts], 2)]
            if pairs:
                bp = max(pairs, key=lambda x: x[1])
                if best is None or bp[1] > best[1]:
                    best = bp
        if best is not None and best[1] > 0.5:
            names = " and ".join(what_of[o] for o in best[0])
            sets = " ".join(f"`{o}`" for o in best[0])
            verdict = f"{names} ({sets} closes {100 * best[1]:.0f}% of talus[liggghts]'s gap to YADE)"
            by = list(best[0])
        else:
            verdict = "no convention option, alone or in pairs, explains it" + (f" (best: {' '.join(best[0])}, {100 * best[1]:.0f}%)" if best else "")
            by = None
        rows.append({"kind": c["kind"], "name": c["name"], "deviation": c["deviation"], "explained_by": by, "verdict": verdict})
    return rows


def collision_figures(s, case):
    """SC figures of the case's `collision` analysis from tracked particles' columns."""
    a = case["analysis"]
    pid = a["particle"]
    parts = {p["id"]: p for p in case["particles"].get("list", [])}
    r1 = parts[pid]["radius"]

    def v3(k, q):
        return np.stack([s[f"p{k}_{c}{q}"] for c in ("x", "y", "z")], axis=1) if q == "_m" else \
            np.stack([s[f"p{k}_{c}"] for c in q], axis=1)

    x1 = v3(pid, "_m")
    v1 = v3(pid, ["vx_m_s", "vy_m_s", "vz_m_s"])
    w1 = v3(pid, ["wx_rad_s", "wy_rad_s", "wz_rad_s"])
    f1 = v3(pid, ["fx_n", "fy_n", "fz_n"])
    if a.get("partner") is not None:
        k = a["partner"]
        r2 = parts[k]["radius"]
        x2, v2, w2 = v3(k, "_m"), v3(k, ["vx_m_s", "vy_m_s", "vz_m_s"]), v3(k, ["wx_rad_s", "wy_rad_s", "wz_rad_s"])
        n = (x1[0] - x2[0]) / np.linalg.norm(x1[0] - x2[0])
        overlap = r1 + r2 - np.linalg.norm(x1 - x2, axis=1)
        vrel = v1 - v2
    else:
        wall = next(w for w in case["wall"] if w["name"] == a["wall"])
        n = np.array(wall["plane"]["normal"], float)
        n = n / np.linalg.norm(n)
        overlap = r1 - (x1 - np.array(wall["plane"]["point"], float)) @ n
        vrel, w2 = v1, None
    t = s["time_s"]
    inside = overlap > 0
    if not inside.any():
        raise EngineError("the collision never happened in the series")
    k0 = int(np.argmax(inside))
    k1 = k0 + int(np.argmax(~inside[k0:]))
    ts = t[k0 - 1] + (t[k0] - t[k0 - 1]) * (-overlap[k0 - 1]) / (overlap[k0] - overlap[k0 - 1])
    te = t[k1 - 1] + (t[k1] - t[k1 - 1]) * overlap[k1 - 1] / (overlap[k1 - 1] - overlap[k1])
    vin, vout = vrel[0], vrel[-1]
    vt = vin - n * vin.dot(n)
    slip = np.cross(w1[0], -r1 * n)
    if w2 is not None:
        slip = slip - np.cross(w2[0], r2 * n)
    slip = slip - n * slip.dot(n)
    tdir = vt / np.linalg.norm(vt) if np.linalg.norm(vt) > 0 else (slip / np.linalg.norm(slip) if np.linalg.norm(slip) > 0 else np.zeros(3))
    return {
        "restitution": float(-vout.dot(n) / vin.dot(n)),
        "contact_duration_s": float(te - ts),
        "max_overlap_m": float(overlap[inside].max()),
        "max_normal_force_n": float(np.abs(f1[inside] @ n).max()),
        "tangential_rebound_m_s": float(vout.dot(tdir)),
        "spin_rad_s": float(w1[-1].dot(np.cross(n, tdir))),
    }


def hopper_figures(s, case, total_mass):
    a = case["analysis"]
    g = np.linalg.norm(case["simulation"].get("gravity", [0, 0, -9.81]))
    m = s["mass_below_kg"]
    sel = (m >= 0.2 * total_mass) & (m <= 0.8 * total_mass)
    fig = {"discharged_mass_kg": float(m[-1])}
    if sel.sum() >= 3:
        fig["discharge_rate_kg_s"] = float(np.polyfit(s["time_s"][sel], m[sel], 1)[0])
    fill = s["phase"] == a["fill_phase"]
    if fill.any():
        t_end = s["time_s"][fill].max()
        win = fill & (s["time_s"] >= t_end - a.get("fill_window", 0.1))
        walls = [w["name"] for w in case.get("wall", [])]
        fz = sum(s[f"{w}_force_z_n"][win].mean() for w in walls)
        fig["fill_end_force_balance"] = float(-fz / (total_mass * g))
        fig["fill_end_time_s"] = float(t_end)
    return fig


def read_final(folder):
    """The final particle state an engine wrote: final.csv (talus, YADE) or final.dump (LIGGGHTS)."""
    folder = Path(folder)
    if (folder / "final.csv").exists():
        d = np.genfromtxt(folder / "final.csv", delimiter=",", names=True)
        return np.stack([d["x"], d["y"], d["z"]], axis=1), d["radius"]
    if (folder / "final.dump").exists():
        lines = (folder / "final.dump").read_text().splitlines()
        k = max(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
        cols = lines[k].split()[2:]
        a = np.array([[float(x) for x in l.split()] for l in lines[k + 1:] if l.strip()])
        c = {n: a[:, i] for i, n in enumerate(cols)}
        return np.stack([c["x"], c["y"], c["z"]], axis=1), c["radius"]
    raise EngineError(f"{folder}: no final.csv or final.dump (the case needs output.final_state = true)")


def pile_figures(x, r, case):
    """A pile's figures from the final positions: its height (the highest sphere top above
    the floor) and its angle of repose. The free surface is the highest sphere top in rings
    about the pile's axis, one mean diameter wide; the angle is that of the least-squares
    line through the rings whose surface lies between 20% and 80% of the height (so neither
    the flat top nor the loose toe counts)."""
    a = case["analysis"]
    cx, cy = a["center"]
    z0 = a.get("floor_z", 0.0)
    rho = np.hypot(x[:, 0] - cx, x[:, 1] - cy) if a.get("profile", "radial") == "radial" else x[:, 0] - cx
    top = x[:, 2] + r - z0
    w = 2.0 * r.mean()
    ring = np.floor(rho / w).astype(int)
    rings = np.arange(ring.max() + 1)
    surf = np.array([top[ring == k].max() if (ring == k).sum() >= 3 else np.nan for k in rings])
    height = float(np.nanmax(surf))
    sel = (surf >= 0.2 * height) & (surf <= 0.8 * height)
    fig = {"pile_height_m": height}
    if sel.sum() >= 3:
        slope = np.polyfit((rings[sel] + 0.5) * w, surf[sel], 1)[0]
        fig["angle_of_repose_deg"] = float(np.degrees(np.arctan(-slope)))
    # how far the spheres ran: the distance holding 95% of them
    fig["runout_95_m"] = float(np.quantile(rho, 0.95))
    return fig


def drag_figures(s, case):
    """The drag on a moving wall: the granules' force against its motion, averaged over the
    rows whose displacement |v| (t - t0) lies in the case's window (the drag paper's 1-5 mm).
    The wall moves from the start (its `velocity`, t0 = 0) or from the start of the first
    phase whose `move` gives it a velocity (t0: that phase's first probe row). Where a servo
    wall holds a pressure and the moving wall is a disc of diameter D_c, also the pressure
    and the drag / (P D_c) of the drag paper's scaling (in 2D P is a line load, N/m: the
    servo's `area` is the lid's length)."""
    a = case["analysis"]
    wall = next(w for w in case["wall"] if w["name"] == a["wall"])
    v = np.array(wall.get("velocity", [0.0, 0.0, 0.0]), float)
    t0 = 0.0
    if not v.any():
        for p in case["phase"]:
            m = next((m for m in p.get("move", []) if m["wall"] == a["wall"] and any(m.get("velocity", [0.0]))), None)
            if m is not None:
                v = np.array(m["velocity"], float)
                rows = np.nonzero(np.asarray(s["phase"]) == p["name"])[0]
                if rows.size == 0:
                    raise EngineError(f"drag: no probe row in phase \"{p['name']}\", where {a['wall']} starts to move")
                # the last row of the phase before (its end), or the first of this one
                t0 = float(s["time_s"][rows[0] - 1] if rows[0] > 0 else s["time_s"][rows[0]])
                break
    speed = np.linalg.norm(v)
    f = np.stack([s[f"{a['wall']}_force_{c}_n"] for c in "xyz"], axis=1)
    drag = -(f @ v) / speed
    disp = speed * (s["time_s"] - t0)
    sel = (disp >= a["window"][0]) & (disp <= a["window"][1])
    if not sel.any():
        raise EngineError(f"drag: no probe row within displacements {a['window']} m")
    fig = {"mean_drag_n": float(drag[sel].mean()), "peak_drag_n": float(drag[disp >= 0].max())}
    servo = next((w["servo"] for w in case["wall"] if "pressure" in w.get("servo", {})), None)
    if servo is not None and "disc" in wall:
        p = float(servo["pressure"])
        fig["confining_pressure"] = p
        fig["drag_per_p_dc"] = fig["mean_drag_n"] / (p * 2.0 * float(wall["disc"]["radius"]))
    return fig


def drum_figures(s, case, folder):
    """A rotating drum: the dynamic angle of repose, the angle to the horizontal of the bed's
    long axis (principal axis of the spheres' volume) in the plane normal to the drum's axis,
    from the final positions; and the mean torque of the spheres on the drum about its axis
    (`<wall>_axis_torque_n_m`) over the case's window."""
    a = case["analysis"]
    wall = next(w for w in case["wall"] if w["name"] == a["wall"])
    rot = wall.get("rotation") or next(m["rotation"] for p in case["phase"] for m in p.get("move", [])
                                       if m["wall"] == a["wall"] and "rotation" in m)
    axis = np.array(rot["axis"], float)
    axis /= np.linalg.norm(axis)
    g = np.array(case["simulation"].get("gravity", [0.0, 0.0, -9.81]), float)
    g /= np.linalg.norm(g)
    e1 = np.cross(axis, g)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e1, axis)  # upward (against gravity) in the plane
    if e2 @ g > 0:
        e2 = -e2
    x, r = read_final(folder)
    w = r ** 3
    q = np.stack([x @ e1, x @ e2], axis=1)
    q -= (w[:, None] * q).sum(0) / w.sum()
    cov = (w[:, None, None] * q[:, :, None] * q[:, None, :]).sum(0) / w.sum()
    vals, vecs = np.linalg.eigh(cov)
    major = vecs[:, np.argmax(vals)]
    angle = abs(np.degrees(np.arctan2(major[1], major[0])))
    angle = min(angle, 180.0 - angle)
    t = s["time_s"]
    sel = (t >= a["window"][0]) & (t <= a["window"][1])
    col = f"{a['wall']}_axis_torque_n_m"
    if not sel.any() or col not in s:
        raise EngineError(f"drum: no {col} rows within {a['window']} s")
    return {"dynamic_angle_of_repose_deg": float(angle), "mean_axis_torque_n_m": float(s[col][sel].mean())}


def figures_of(s, case, summary, folder=None):
    kind = case.get("analysis", {}).get("kind")
    if kind == "collision":
        return collision_figures(s, case)
    if kind == "hopper":
        return hopper_figures(s, case, summary["total_mass_kg"])
    if kind == "drag":
        return drag_figures(s, case)
    if kind == "drum" and folder is not None:
        return drum_figures(s, case, folder)
    if kind == "pile" and folder is not None:
        return pile_figures(*read_final(folder), case)
    return {}


def series_checks(talus, ref, tol):
    out = []
    t_t, t_r = talus["time_s"], ref["time_s"]
    end = min(t_t[-1], t_r[-1])
    # from the first row after step 0: LIGGGHTS's mesh walls report no load at step 0
    # (fix mesh/surface/stress sums the loads during steps), whatever the start
    keep = (t_t <= end + 1e-12) & (t_t > 0)
    def unit(c):
        return c.rsplit("_", 2)[-2:] if c.endswith("_n_m") or c.endswith("_m_s") else c.rsplit("_", 1)[-1:]

    # round-off floor per unit: 1e-12 of the largest value of any column in that unit
    # (a 2D case's z forces and x, y torques are 0 in one code and 1e-17 in another)
    big = {}
    for c in ref:
        if c not in SKIP:
            big[tuple(unit(c))] = max(big.get(tuple(unit(c)), 0.0), float(np.abs(ref[c]).max()))
    for col in talus:
        if col in SKIP or col in tol["ignore"] or col not in ref:
            continue
        a = talus[col][keep]
        b = np.interp(t_t[keep], t_r, ref[col])
        floor = 1e-12 * big.get(tuple(unit(col)), 0.0)
        if np.abs(talus[col]).max() <= floor and np.abs(ref[col]).max() <= floor:
            continue  # zero in both, to round-off
        rng = ref[col].max() - ref[col].min()
        # a column that barely changes (a resting load) is measured against 1e-9 of its size
        scale = max(rng, 1e-9 * np.abs(ref[col]).max(), 1e-300)
        dev = float(np.abs(a - b).max() / scale) if len(a) else 0.0
        t = tol["series"].get(col, tol["series_range"])
        out.append({"kind": "series", "name": col, "deviation": dev, "tolerance": t, "ok": dev <= t})
        for w0, w1 in tol["windows"]:
            ia = (t_t >= w0) & (t_t <= w1)
            ib = (t_r >= w0) & (t_r <= w1)
            if not ia.any() or not ib.any():
                out.append({"kind": "window", "name": f"{col}@[{w0},{w1}]", "deviation": math.nan, "tolerance": 0, "ok": False})
                continue
            d = float(abs(talus[col][ia].mean() - ref[col][ib].mean()) / scale)
            tw = tol["window_means"].get(col, tol["window_mean"])
            out.append({"kind": "window", "name": f"{col}@[{w0},{w1}]", "deviation": d, "tolerance": tw, "ok": d <= tw})
    return out


def figure_checks(ft, fr, tol):
    out = []
    for k in ft:
        if k in tol["ignore"] or k not in fr:
            continue
        scale = abs(fr[k]) if fr[k] != 0 else 1.0
        d = abs(ft[k] - fr[k]) / scale
        t = tol["figures"].get(k, tol["figure_rel"])
        out.append({"kind": "figure", "name": k, "talus": ft[k], "reference": fr[k], "deviation": d, "tolerance": t, "ok": d <= t})
    return out


def plot(out, name, talus, refs):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = next(iter(talus.values()))
    cols = [c for c in first if c not in SKIP]
    paths = {}
    (out / "plots").mkdir(parents=True, exist_ok=True)
    for c in cols:
        fig, ax = plt.subplots(figsize=(5, 3))
        for label, s in talus_and_refs(talus, refs):
            if c in s:
                ax.plot(s["time_s"], s[c], label=label, lw=1)
        paths[c] = save_plot(fig, ax, out, c, f"{name}: {c}")
    return paths


def save_plot(fig, ax, out, column, title):
    """A column's plot, labelled, into out/plots/COLUMN.png (its path)."""
    import matplotlib.pyplot as plt

    ax.set_xlabel("time_s")
    ax.set_ylabel(column)
    ax.set_title(title, fontsize=8)
    if ax.get_lines():
        ax.legend(fontsize=6)
    fig.tight_layout()
    p = out / "plots" / f"{column}.png"
    fig.savefig(p, dpi=90)
    plt.close(fig)
    return p


def talus_and_refs(talus, refs):
    yield from talus.items()
    yield from refs.items()


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m compare CASE.toml", description=__doc__.splitlines()[0])
    ap.add_argument("case", type=Path)
    ap.add_argument("--engines", default="talus,liggghts")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--no-explain", action="store_true",
                    help="with both references: do not run talus once per convention option to explain where they disagree")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="change one value of the case in every engine (as `talus run --set`); repeatable")
    ap.add_argument("--replicas", type=int, metavar="K",
                    help="replicas per engine, compared as ensembles (compare/ensemble.py): default the case's "
                         "[compare] replicas, else 4; 1 compares single runs step by step")
    ap.add_argument("--perturb", action="append", default=[], metavar="KEY=VALUE",
                    help="change one value of the case in talus's runs only (the power check: a real change must "
                         "be found, a null one not); repeatable")
    ap.add_argument("--reuse", action="store_true",
                    help="read the runs already finished in the output folder with the same command line instead of running them again "
                         "(a long comparison can be finished in parts; an edited case file or a rebuilt talus is not detected)")
    ap.add_argument("--fields", metavar="AXIS", choices=["x", "y", "z"],
                    help="also compare continuum fields: each engine's profile along AXIS (talus fields: density, "
                         "velocity, stress), from snapshots with contacts (the case's output.snapshot_interval; "
                         "output.contacts is set); LAMMPS and YADE single runs (compare/fields.py)")
    ap.add_argument("--fields-width", type=float, metavar="W",
                    help="the fields' Gaussian kernel width (m; default the mean particle diameter)")
    ap.add_argument("--fields-from", type=float, metavar="T0", help="average the snapshots from T0 (s) on (default all)")
    ap.add_argument("--fields-tolerance", type=float, default=0.05, metavar="REL",
                    help="largest difference of a profile column from talus's, relative to its kind's scale (default 0.05)")
    ap.add_argument("--fields-columns", metavar="COL,...",
                    help="the profile columns checked (default all of " + ",".join(fields.COLUMNS) + "); a single run of a "
                         "jammed bed fixes its lateral stress by its history, which only ensembles average")
    a = ap.parse_args(argv)
    global REUSE
    SETS[:] = a.set
    REUSE = a.reuse
    engines = [e.strip() for e in a.engines.split(",") if e.strip()]
    refs = [e for e in engines if e != "talus"]
    try:
        for e in engines:
            if e not in ("talus", "liggghts", "yade", "lammps"):
                raise EngineError(f"--engines: unknown engine `{e}` (talus, liggghts, yade, lammps)")
        if not refs:
            raise EngineError("--engines: name a reference (liggghts, yade or lammps)")
        check_versions(["talus"] + refs)
        with open(a.case, "rb") as f:
            case = tomllib.load(f)
    except (EngineError, OSError, tomllib.TOMLDecodeError) as e:
        print(f"compare: {e}", file=sys.stderr)
        return 2
    tol = dict(DEFAULTS)
    tol.update(case.get("compare", {}))
    for k, v in (("figures", {}), ("series", {}), ("windows", []), ("window_means", {}), ("ignore", [])):
        tol.setdefault(k, v)
    out = a.out or Path("out") / "compare" / a.case.stem
    out.mkdir(parents=True, exist_ok=True)
    k_reps = a.replicas if a.replicas is not None else int(tol.get("replicas", ensemble.DEFAULT_REPLICAS))
    if k_reps < 1:
        print(f"compare: --replicas {k_reps}: at least 1", file=sys.stderr)
        return 2
    if a.fields:
        bad = [r for r in refs if r not in ("lammps", "yade")]
        if bad or k_reps > 1:
            print(f"compare: --fields: only single runs against LAMMPS and YADE write their contacts yet (not {', '.join(bad) or 'ensembles'}); "
                  "use --engines talus,lammps or talus,yade and --replicas 1", file=sys.stderr)
            return 2
        if not case.get("output", {}).get("snapshot_interval") and not any(x.startswith("output.snapshot_interval=") for x in a.set):
            print(f"compare: --fields: {a.case} has no output.snapshot_interval (the fields are made from snapshots)", file=sys.stderr)
            return 2
        SETS.append("output.contacts=true")
    if k_reps > 1:
        try:
            return ensemble.compare(a.case, case, refs, tol, out, k_reps, a.perturb)
        except EngineError as e:
            print(f"compare: {e}", file=sys.stderr)
            return 2
    result = {"case": str(a.case), "tolerances": tol, "engines": {}, "checks": {}}
    talus_series, ref_series, kept = {}, {}, {}
    def runs_for(ref):
        # talus in the reference's convention, then the reference (which takes the
        # particles talus inserted)
        conv = CONVENTION[ref]
        ts, summary = run_talus(a.case, conv, out / f"talus-{conv}", a.perturb)
        return ts, summary, run_reference(a.case, ref, out / ref, out / f"talus-{conv}" / "inserted.csv")

    try:
        # each reference's pair of runs side by side with the other's (LIGGGHTS and
        # YADE each run on one core; H1-small's YADE run is the longest of all)
        with ThreadPoolExecutor(max_workers=len(refs)) as pool:
            done = list(pool.map(runs_for, refs))
        for ref, (ts, summary, rs) in zip(refs, done):
            conv = CONVENTION[ref]
            talus_series[f"talus[{conv}]"], ref_series[ref] = ts, rs
            ft, fr = figures_of(ts, case, summary, out / f"talus-{conv}"), figures_of(rs, case, summary, out / ref)
            kept[ref] = (ts, ft, rs, fr, summary)
            result["engines"][f"talus[{conv}]"] = ft
            result["engines"][ref] = fr
            result["checks"][ref] = figure_checks(ft, fr, tol) + series_checks(ts, rs, tol)
        if "liggghts" in kept and "yade" in kept:
            # the references against each other (LIGGGHTS as the measured side), and
            # where they disagree, which convention explains it
            ts_l, ft_l, rs_l, fr_l, summary = kept["liggghts"]
            _, _, rs_y, fr_y, _ = kept["yade"]
            cross = figure_checks(fr_l, fr_y, tol) + series_checks(rs_l, rs_y, tol)
            why = [] if a.no_explain else explain(a.case, case, cross, ts_l, ft_l, rs_y, fr_y, summary, tol, out)
            result["references"] = {"checks": cross, "explained": why}
        if a.fields:
            field_profiles = {}
            for ref in refs:
                conv = CONVENTION[ref]
                tdir = out / f"talus-{conv}"
                width = a.fields_width or fields.mean_diameter(tdir)
                g = math.sqrt(sum(x * x for x in case.get("simulation", {}).get("gravity", [0.0, 0.0, 0.0])))
                tp = fields.profile(tdir, a.fields, width, out / "fields" / f"talus-{conv}", t0=a.fields_from)
                rp = fields.profile(fields.snapshots_of(ref, out / ref, case), a.fields, width,
                                    out / "fields" / ref, t0=a.fields_from)
                field_profiles[f"talus[{conv}]"], field_profiles[ref] = tp, rp
                cols = a.fields_columns.split(",") if a.fields_columns else None
                result["checks"][ref] += fields.field_checks(tp, rp, a.fields_tolerance, a.fields, math.sqrt(g * width), cols)
            fields.plot(out, a.case.stem, a.fields, field_profiles)
    except EngineError as e:
        print(f"compare: {e}", file=sys.stderr)
        return 2
    plots = plot(out, a.case.stem, talus_series, ref_series)
    failures = [f"talus vs {ref}: {c['name']} deviation {c['deviation']:.3g} > {c['tolerance']:g}"
                for ref, cs in result["checks"].items() for c in cs if not c["ok"]]
    result["failures"] = failures
    (out / "figures.json").write_text(json.dumps(result, indent=1, default=float) + "\n")
    lines = [f"# {a.case.name}: talus against {', '.join(refs)}", ""]
    if any(result["engines"].values()):
        names = list(result["engines"])
        keys = sorted({k for f in result["engines"].values() for k in f})
        lines += ["| figure | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
        for k in keys:
            lines.append(f"| {k} | " + " | ".join(f"{result['engines'][n].get(k, float('nan')):.6g}" for n in names) + " |")
        lines.append("")
    for ref, cs in result["checks"].items():
        lines += [f"## talus[{CONVENTION[ref]}] against {ref}", "", "| check | name | deviation | tolerance | |", "|---|---|---|---|---|"]
        for c in cs:
            lines.append(f"| {c['kind']} | {c['name']} | {c['deviation']:.3g} | {c['tolerance']:g} | {'ok' if c['ok'] else '**OUTSIDE**'} |")
        lines.append("")
    if "references" in result:
        cross = result["references"]["checks"]
        n_bad = sum(not c["ok"] for c in cross)
        lines += ["## LIGGGHTS against YADE: where the references disagree", "",
                  f"{len(cross) - n_bad} of {len(cross)} checks agree within the case's tolerances "
                  "(reported, not failures: the two codes differ by their conventions). For each that does not, "
                  "talus ran in LIGGGHTS's convention with one YADE option at a time (then two); the option "
                  "or pair that closes most of talus[liggghts]'s gap to YADE is named. In a chaotic flow any two runs differ by their "
                  "spread, so an attribution means something only where the gap is larger than that.", ""]
        if result["references"]["explained"]:
            lines += ["| check | name | deviation | which convention explains it |", "|---|---|---|---|"]
            for r in result["references"]["explained"]:
                lines.append(f"| {r['kind']} | {r['name']} | {r['deviation']:.3g} | {r['verdict']} |")
            lines.append("")
    lines += ["## Plots", ""] + [f"![{c}](plots/{p.name})" for c, p in plots.items()]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    for n, f in result["engines"].items():
        if f:
            print(n, json.dumps(f))
    n_checks = sum(len(cs) for cs in result["checks"].values())
    print(f"{n_checks - len(failures)} of {n_checks} checks within tolerance; report: {out / 'report.md'}")
    if failures:
        print("OUTSIDE TOLERANCE:\n  " + "\n  ".join(failures))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
