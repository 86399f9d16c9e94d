"""Continuum fields compared between engines (`python3 -m compare CASE.toml --fields AXIS`).

Each engine's run is turned into a snapshot file in talus's layout (snapshots.h5: per
snapshot the particles' positions, velocities, masses, radii, and every contact's force,
point, particle centre and branch vector; the domain as attributes), then `talus fields`
makes the same coarse-grained profile of every engine's file: the same kernel, width,
points and snapshots, so the engines differ only by their particles and contacts.
talus writes that file itself (`output.snapshot_interval` with `output.contacts`); a LAMMPS
deck exported from the same case writes dumps that `lammps_snapshots` converts, a YADE
script snapshot files that `yade_snapshots` converts (docs/contacts-in-the-reference-codes.md
says what each engine can write).

A profile's column is compared as its largest difference from talus's over the points,
relative to the scale of its kind in talus's profile (`field_checks`)."""

import csv
import re
import subprocess
from pathlib import Path

import h5py
import numpy as np

from .engines import TALUS, EngineError

# the profile's columns compared (the coordinate column is the same points in every engine)
COLUMNS = ["density_kg_m3", "velocity_x_m_s", "velocity_y_m_s", "velocity_z_m_s",
           "stress_xx_pa", "stress_yy_pa", "stress_zz_pa", "stress_xz_pa"]


def _read_dump(path):
    """A LAMMPS dump (custom or local) file of one step: (step, box bounds, boundary flags, columns, rows)."""
    lines = Path(path).read_text().splitlines()
    step = int(lines[lines.index("ITEM: TIMESTEP") + 1])
    k = next(i for i, line in enumerate(lines) if line.startswith("ITEM: BOX BOUNDS"))
    flags = lines[k].split()[3:]
    box = [[float(x) for x in lines[k + 1 + j].split()[:2]] for j in range(3)]
    h = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS") or line.startswith("ITEM: ENTRIES"))
    cols = lines[h].split()[2:]
    rows = np.array([[float(x) for x in line.split()] for line in lines[h + 1:] if line.strip()]).reshape(-1, len(cols))
    return step, box, flags, cols, rows


def _timestep(deck):
    m = re.search(r"^timestep\s+(\S+)", Path(deck).read_text(), re.M)
    if not m:
        raise EngineError(f"{deck}: no timestep line")
    return float(m.group(1))


def lammps_snapshots(folder, out_h5):
    """The dumps of an exported LAMMPS deck (particles.<step>.dump, contacts.<step>.dump) as
    a snapshot file in talus's layout. Pair forces: normal (fx fy fz) plus tangential (p1 p2
    p3) on the first particle; branch p10-p12 (x_first - x_second, the image in contact);
    contact point at mid-overlap. Wall contacts: each wall fix's columns in the particle dump
    (in contact, force on the particle, point on the wall)."""
    folder = Path(folder)
    dt = _timestep(folder / "in.talus")
    parts = {int(p.name.split(".")[1]): p for p in folder.glob("particles.*.dump")}
    if not parts:
        raise EngineError(f"{folder}: no particles.*.dump (export the case with output.contacts = true and output.snapshot_interval)")
    with h5py.File(out_h5, "w") as h5:
        for step in sorted(parts):
            _, box, flags, cols, p = _read_dump(parts[step])
            if "domain_lo" not in h5.attrs:
                h5.attrs["domain_lo"] = np.array([b[0] for b in box])
                h5.attrs["domain_hi"] = np.array([b[1] for b in box])
                h5.attrs["periodic"] = np.array([1.0 if f == "pp" else 0.0 for f in flags])
            c = {name: j for j, name in enumerate(cols)}
            pos = p[:, [c["x"], c["y"], c["z"]]]
            ids = p[:, c["id"]].astype(np.int64)
            radius = p[:, c["radius"]]
            at = {int(i): k for k, i in enumerate(ids)}
            rec = {"ids": [], "wall": [], "force": [], "point": [], "centre": [], "branch": []}
            # pairs
            cfile = folder / f"contacts.{step}.dump"
            if cfile.exists():
                _, _, _, ccols, q = _read_dump(cfile)
                for row in q:
                    a, b = int(row[0]), int(row[1])
                    f = row[2:5] + row[5:8]
                    d = row[8:11]
                    if not np.any(f):
                        continue  # a neighbour that does not touch (a reaching law's type cutoff)
                    ia = at[a]
                    dist = np.linalg.norm(d)
                    n = d / dist
                    overlap = radius[ia] + radius[at[b]] - dist
                    rec["ids"].append([a, b]); rec["wall"].append(0); rec["force"].append(f)
                    rec["point"].append(pos[ia] - n * (radius[ia] - overlap / 2)); rec["centre"].append(pos[ia]); rec["branch"].append(d)
            # walls: f_<fix>[1..7] per wall fix
            fixes = sorted({m.group(1) for name in cols for m in [re.match(r"f_(.+)\[1\]$", name)] if m})
            for w, fx in enumerate(fixes):
                j = [c[f"f_{fx}[{k}]"] for k in range(1, 8)]
                for k in np.nonzero(p[:, j[0]] != 0)[0]:
                    point = p[k, j[4:7]]
                    rec["ids"].append([int(ids[k]), w]); rec["wall"].append(1); rec["force"].append(p[k, j[1:4]])
                    rec["point"].append(point); rec["centre"].append(pos[k]); rec["branch"].append(pos[k] - point)
            n = len(rec["wall"])
            _write_snapshot(h5, step, step * dt, ids, pos, p[:, [c["vx"], c["vy"], c["vz"]]], radius, p[:, c["mass"]],
                            {"ids": np.array(rec["ids"]).reshape(n, 2), "wall": np.array(rec["wall"]),
                             **{k: np.array(rec[k], dtype=float).reshape(n, 3) for k in ("force", "point", "centre", "branch")}})
    return out_h5


def _write_snapshot(h5, step, t, ids, pos, vel, radius, mass, contacts):
    """One snapshot group in talus's layout (src/output.rs, src/fields/snapshots.rs): the
    particles, and the contacts' ids (n x 2), wall flags and force, point, centre and
    branch (n x 3 each)."""
    g = h5.create_group(f"step_{step:09d}")
    g.attrs["time_s"] = t
    g["id"] = np.asarray(ids).astype(np.uint64)
    g["position"], g["velocity"], g["radius"], g["mass"] = pos, vel, radius, mass
    cg = g.create_group("contacts")
    cg["ids"] = np.asarray(contacts["ids"]).astype(np.uint64)
    cg["wall"] = np.asarray(contacts["wall"]).astype(np.uint8)
    for key in ("force", "point", "centre", "branch"):
        cg[key] = contacts[key]


def yade_snapshots(folder, out_h5, case):
    """The snapshot files of an exported YADE script (snapshot.<step>.txt, written by its
    driver between the force loop and the integrator: talus's end-of-step state) as a
    snapshot file in talus's layout; the domain from the case (a dict of the TOML)."""
    folder = Path(folder)
    files = {int(p.name.split(".")[1]): p for p in folder.glob("snapshot.*.txt")}
    if not files:
        raise EngineError(f"{folder}: no snapshot.*.txt (export the case with output.contacts = true and output.snapshot_interval)")
    d = case["simulation"]["domain"]
    per = d.get("periodic", [])
    with h5py.File(out_h5, "w") as h5:
        h5.attrs["domain_lo"] = np.array(d["lo"], dtype=float)
        h5.attrs["domain_hi"] = np.array(d["hi"], dtype=float)
        h5.attrs["periodic"] = np.array([1.0 if a in per else 0.0 for a in "xyz"])
        for step in sorted(files):
            t, parts, cons = None, [], []
            for line in files[step].read_text().splitlines():
                w = line.split()
                if not w:
                    continue
                if w[0] == "t":
                    t = float(w[1])
                elif w[0] == "p":
                    parts.append([float(x) for x in w[1:]])
                elif w[0] == "c":
                    cons.append([float(x) for x in w[1:]])
            p = np.array(parts, dtype=float).reshape(-1, 9)
            c = np.array(cons, dtype=float).reshape(-1, 15)
            _write_snapshot(h5, step, t, p[:, 0], p[:, 1:4], p[:, 4:7], p[:, 7], p[:, 8],
                            {"ids": c[:, 0:2], "wall": c[:, 2], "force": c[:, 3:6], "point": c[:, 6:9], "centre": c[:, 9:12], "branch": c[:, 12:15]})
    return out_h5


def snapshots_of(engine, folder, case):
    """A reference engine's run as a snapshot file in talus's layout (snapshots.h5 in its folder)."""
    out = Path(folder) / "snapshots.h5"
    if engine == "lammps":
        return lammps_snapshots(folder, out)
    if engine == "yade":
        return yade_snapshots(folder, out, case)
    raise EngineError(f"--fields: the {engine} export does not write contacts yet (lammps and yade do)")


def profile(snapshots, axis, width, out, t0=None, t1=None, kernel="gauss", points=100):
    """`talus fields` of a snapshot file (or a run's folder) into folder `out`; the profile's rows."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cmd = [str(TALUS), "fields", str(snapshots), "--kernel", kernel, "--width", repr(width), "--profile", axis,
           "--points", str(points), "--out", str(out)]
    if t0 is not None:
        cmd += ["--from", repr(t0)]
    if t1 is not None:
        cmd += ["--to", repr(t1)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise EngineError(f"talus fields failed: {' '.join(cmd)}\n{r.stderr[-1500:]}")
    with open(out / f"profile_{axis}.csv") as f:
        return {k: np.array([float(row[k]) for row in rows]) for rows in [list(csv.DictReader(f))] for k in rows[0]}


def mean_diameter(snapshots):
    """Twice the mean radius of the particles in the last snapshot of a talus run's folder."""
    with h5py.File(Path(snapshots) / "snapshots.h5") as h5:
        last = sorted(k for k in h5 if k.startswith("step_"))[-1]
        return 2.0 * float(np.mean(h5[last]["radius"][()]))


def field_checks(talus, ref, tol, axis, velocity_floor=0.0, columns=None):
    """Each compared column's largest difference over the points, relative to the scale of
    its kind in talus's profile: density, its largest value; a velocity component, the
    largest of any component (at least `velocity_floor`, m/s: a bed at rest has only noise
    to compare); a stress component, the largest of any component."""
    def family(k):
        return [c for c in COLUMNS if c.split("_")[0] == k.split("_")[0] and c in talus]
    unknown = [k for k in columns or [] if k not in COLUMNS]
    if unknown:
        raise EngineError(f"--fields-columns: unknown column {', '.join(unknown)} (of {', '.join(COLUMNS)})")
    checks = []
    for k in columns or COLUMNS:
        if k not in talus or k not in ref:
            continue
        scale = max(float(np.max(np.abs(talus[c]))) for c in family(k))
        if k.startswith("velocity"):
            scale = max(scale, velocity_floor)
        dev = float(np.max(np.abs(talus[k] - ref[k]))) / scale if scale > 0 else 0.0
        checks.append({"kind": "field", "name": f"{k} along {axis}", "deviation": dev, "tolerance": tol, "ok": dev <= tol})
    return checks


def plot(out, name, axis, profiles):
    """Each compared column against the coordinate, one line per engine (fields-<column>.png)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pngs = []
    for k in ("density_kg_m3", "stress_zz_pa", "stress_xz_pa", "velocity_x_m_s"):
        fig, ax = plt.subplots(figsize=(5, 4))
        for engine, p in profiles.items():
            ax.plot(p[k], p[f"{axis}_m"], label=engine)
        ax.set_xlabel(k)
        ax.set_ylabel(f"{axis} (m)")
        ax.set_title(f"{name}: {k}")
        ax.legend(fontsize=8)
        fig.tight_layout()
        png = Path(out) / f"fields-{k}.png"
        fig.savefig(png, dpi=90)
        plt.close(fig)
        pngs.append(png)
    return pngs
