"""Write cases/beds/cooling-gas.csv: the start of cases/cooling.toml (issue 14).

1000 equal spheres (radius 1 mm) on a 10 x 10 x 10 simple cubic lattice of
spacing 3.5 mm (the 35 mm periodic box, solid fraction 0.098), each jittered by
up to 0.5 mm along each axis (no two overlap: centres stay at least 2.5 mm
apart), velocities drawn from a Maxwellian of 0.5 m/s per component, the mean
taken off (zero total momentum), no spin. Seeded: the same file every time.

    python3 scripts/make_cooling_gas.py
"""
import pathlib
import numpy as np

rng = np.random.default_rng(20261129)
n_side, spacing, r, jitter, sigma = 10, 0.0035, 0.001, 0.0005, 0.5
rows = []
k = 0
idx = np.arange(n_side)
grid = np.array(np.meshgrid(idx, idx, idx, indexing="ij")).reshape(3, -1).T
pos = (grid + 0.5) * spacing + rng.uniform(-jitter, jitter, size=grid.shape)
vel = rng.normal(0.0, sigma, size=grid.shape)
vel -= vel.mean(axis=0)
out = pathlib.Path(__file__).resolve().parent.parent / "cases" / "beds" / "cooling-gas.csv"
with open(out, "w") as fh:
    fh.write("id,x,y,z,radius,vx,vy,vz\n")
    for i, (x, v) in enumerate(zip(pos, vel)):
        fh.write("%d,%r,%r,%r,%r,%r,%r,%r\n" % (i + 1, *map(float, x), r, *map(float, v)))
print("wrote", out)
