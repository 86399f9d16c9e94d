#!/usr/bin/env python3
"""Turn a talus particle cloud (CSV from `talus cloud`) into a LIGGGHTS data file.

Input CSV columns: id,x,y,z,radius,vx,vy,vz (SI units, header line required).
Output: a LAMMPS/LIGGGHTS data file for `atom_style granular`
(Atoms lines: id type diameter density x y z; Velocities lines: id vx vy vz wx wy wz).

Every particle gets atom type 1 and the same density (seed-soft: 2500 kg/m3).
Numbers are written with 17 significant digits, so positions and radii reach
LIGGGHTS bit for bit (diameter = 2 * radius is exact in binary).

Box bounds default to talus's H1 domain (cases/H1-small.toml [simulation].domain):
x, y in [-0.11, 0.11], z in [-0.11, 0.32].

Usage:
  python3 csv_to_data.py cloud.csv out.data [--density 2500] [--type 1]
                         [--box XLO XHI YLO YHI ZLO ZHI]
Standard library only.
"""

import argparse
import csv
import math
import sys

DEFAULT_BOX = (-0.11, 0.11, -0.11, 0.11, -0.11, 0.32)


def g17(v):
    return "%.17g" % v


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", help="talus cloud CSV: id,x,y,z,radius,vx,vy,vz")
    ap.add_argument("data", help="LIGGGHTS data file to write")
    ap.add_argument("--density", type=float, default=2500.0,
                    help="particle density, kg/m3 (default 2500, seed-soft)")
    ap.add_argument("--type", type=int, default=1, help="atom type (default 1)")
    ap.add_argument("--box", type=float, nargs=6, default=list(DEFAULT_BOX),
                    metavar=("XLO", "XHI", "YLO", "YHI", "ZLO", "ZHI"),
                    help="box bounds (default: talus H1 domain %s)" % (DEFAULT_BOX,))
    a = ap.parse_args(argv)

    rows = []
    with open(a.csv, newline="") as f:
        rd = csv.DictReader(f)
        need = ["id", "x", "y", "z", "radius", "vx", "vy", "vz"]
        missing = [c for c in need if c not in (rd.fieldnames or [])]
        if missing:
            sys.exit("%s: missing column(s) %s (have %s)" % (a.csv, missing, rd.fieldnames))
        for r in rd:
            rows.append((int(r["id"]), float(r["x"]), float(r["y"]), float(r["z"]),
                         float(r["radius"]), float(r["vx"]), float(r["vy"]), float(r["vz"])))
    if not rows:
        sys.exit("%s: no particles" % a.csv)
    rows.sort(key=lambda r: r[0])
    ids = [r[0] for r in rows]
    if len(set(ids)) != len(ids) or min(ids) < 1:
        sys.exit("%s: particle ids must be unique and >= 1" % a.csv)

    xlo, xhi, ylo, yhi, zlo, zhi = a.box
    for r in rows:
        pid, x, y, z, rad = r[:5]
        if not (xlo <= x - rad and x + rad <= xhi and ylo <= y - rad and y + rad <= yhi
                and zlo <= z - rad and z + rad <= zhi):
            sys.exit("particle %d at (%g, %g, %g), r = %g is not inside the box %s"
                     % (pid, x, y, z, rad, a.box))
        if not rad > 0.0:
            sys.exit("particle %d: radius %g must be > 0" % (pid, rad))

    moving = any(r[5] != 0.0 or r[6] != 0.0 or r[7] != 0.0 for r in rows)
    mass = sum(a.density * 4.0 / 3.0 * math.pi * r[4] ** 3 for r in rows)
    with open(a.data, "w") as f:
        f.write("LIGGGHTS data file from %s (talus cloud), %d spheres, total mass %.9e kg\n\n"
                % (a.csv, len(rows), mass))
        f.write("%d atoms\n" % len(rows))
        f.write("%d atom types\n\n" % a.type)
        f.write("%s %s xlo xhi\n" % (g17(xlo), g17(xhi)))
        f.write("%s %s ylo yhi\n" % (g17(ylo), g17(yhi)))
        f.write("%s %s zlo zhi\n\n" % (g17(zlo), g17(zhi)))
        f.write("Atoms\n\n")
        for pid, x, y, z, rad, *_ in rows:
            f.write("%d %d %s %s %s %s %s\n"
                    % (pid, a.type, g17(2.0 * rad), g17(a.density), g17(x), g17(y), g17(z)))
        if moving:
            f.write("\nVelocities\n\n")
            for pid, _x, _y, _z, _r, vx, vy, vz in rows:
                f.write("%d %s %s %s 0 0 0\n" % (pid, g17(vx), g17(vy), g17(vz)))
    print("wrote %d particles (total mass %.6e kg) to %s" % (len(rows), mass, a.data))


if __name__ == "__main__":
    main()
