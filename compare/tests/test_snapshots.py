"""Snapshots read by a reader that is not talus's: the XDMF index parsed as XML and its
HDF5 datasets opened with h5py. Each snapshot holds the particles (with their ids) and
the walls in the run at that time: a mesh as its triangles, a plane as the polygon where
it cuts the domain, a ball as a sphere of triangles, each where it is then; a removed
wall is gone from the snapshots after its removal."""

import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

from compare import engines

ROOT = Path(__file__).resolve().parents[2]

CASE = """
[simulation]
timestep = 2e-5
gravity = [0.0, 0.0, -9.81]
domain = { lo = [-0.11, -0.11, -0.11], hi = [0.11, 0.11, 0.2] }

[contact]
model = "hertz"

[[material]]
name = "m"
youngs_modulus = 1.0e6
poisson_ratio = 0.3
density = 2500.0
restitution = 0.5
friction = 0.4

[particles]
material = "m"
lattice = { count = 60, radius_min = 0.004, radius_max = 0.005, lo = [-0.03, -0.03, 0.02], hi_xy = [0.03, 0.03], spacing = 2.2, seed = 1 }

[[wall]]
name = "box"
material = "m"
stl = "META/box.stl"

[[wall]]
name = "gate"
material = "m"
plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }
remove_at = 0.01

[[wall]]
name = "ball"
material = "m"
disc = { center = [0.08, 0.08, 0.15], radius = 0.01 }
velocity = [0.0, 0.0, -0.5]

[[phase]]
name = "fall"
duration = 0.02

[output]
interval = 0.005
snapshot_interval = 0.005
"""


def test_snapshots_carry_ids_and_walls_where_they_are(tmp_path):
    subprocess.run([str(engines.TALUS), "meshes", str(tmp_path)], check=True, capture_output=True)
    case = tmp_path / "snap.toml"
    case.write_text(CASE.replace("META", str(tmp_path)))
    subprocess.run([str(engines.TALUS), "run", str(case), "--out", str(tmp_path / "o"), "--quiet"], check=True, capture_output=True)
    root = ET.parse(tmp_path / "o" / "snapshots.xdmf").getroot()
    h5 = h5py.File(tmp_path / "o" / "snapshots.h5", "r")
    temporal = root.find("Domain/Grid")
    assert temporal.get("CollectionType") == "Temporal"
    steps = temporal.findall("Grid")
    assert len(steps) == 5  # t = 0, 0.005, ..., 0.02

    def data(item):
        f, path = item.text.strip().split(":")
        assert f == "snapshots.h5"
        d = h5[path][()]
        assert list(d.shape) == [int(x) for x in item.get("Dimensions").split()], (path, d.shape)
        return d

    seen_gate = []
    for g in steps:
        t = float(g.find("Time").get("Value"))
        grids = {x.get("Name"): x for x in g.findall("Grid")}
        p = grids["particles"]
        ids = data(p.find("Attribute[@Name='id']/DataItem"))
        assert sorted(ids.tolist()) == list(range(1, 61)) or sorted(ids.tolist()) == list(range(60))
        data(p.find("Geometry/DataItem"))
        seen_gate.append(("wall:gate" in grids, t))
        for name, w in grids.items():
            if not name.startswith("wall:"):
                continue
            v = data(w.find("Geometry/DataItem"))
            cells = data(w.find("Topology/DataItem"))
            assert w.find("Topology").get("TopologyType") == "Triangle"
            assert cells.max() < len(v) and cells.shape[1] == 3
            if name == "wall:gate":
                # the plane z = 0 cut by the domain: the square [-0.11, 0.11]^2 at z = 0
                assert np.allclose(v[:, 2], 0.0) and np.isclose(np.abs(v[:, :2]).max(), 0.11) and len(v) == 4
            if name == "wall:ball":
                # a sphere of radius 0.01 about the centre at this time (moving down at 0.5 m/s)
                c = np.array([0.08, 0.08, 0.15 - 0.5 * t])
                r = np.linalg.norm(v - c, axis=1)
                assert np.allclose(r, 0.01, rtol=1e-9, atol=1e-6), (t, r.min(), r.max())
            if name == "wall:box":
                assert len(cells) == 10
    # the gate is there until its removal at 0.01 s, and gone after
    assert [s for s, t in seen_gate] == [t < 0.01 - 1e-9 for s, t in seen_gate], seen_gate
