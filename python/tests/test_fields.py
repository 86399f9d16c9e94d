"""Continuum fields from Python against what holds by construction and against
`talus fields` on the same state.

Run from the repository root: `python3 -m pytest python/tests`.
"""

import csv
import subprocess
from pathlib import Path

import numpy as np
import pytest

import talus

ROOT = Path(__file__).resolve().parents[2]
TALUS = ROOT / "target" / "release" / "talus"

COLUMN = (ROOT / "cases" / "static-column.toml").read_text()


def test_a_column_at_rest_from_python_matches_the_command_line(tmp_path: Path) -> None:
    sim = talus.Simulation.from_toml(COLUMN, base_dir=tmp_path, name="column")
    sim.run(out=str(tmp_path / "run"))
    f = sim.fields(width=0.2, profile="z", points=60)
    assert f["at"].shape == (60, 3) and f["stress"].shape == (60, 3, 3)
    h = 6.0 / 60
    # the density integrates to the mass per area (3 kg over 16 m^2)
    assert abs(f["density"].sum() * h - 3.0 / 16.0) < 1e-3 * 3.0 / 16.0  # (the midpoint rule on 60 points)
    # sigma_zz at the middle of the lowest free sphere carries the two above it
    # and half its own weight... within the kernel's smoothing: between 1 and 3 weights per area
    z = f["at"][:, 2]
    szz = f["stress"][:, 2, 2]
    assert szz.max() > 2.0 / 16.0 and szz.max() < 3.0 / 16.0 * 1.01
    # the same state through the command line: the same numbers (the snapshot at t = 30 s)
    subprocess.run([str(TALUS), "fields", str(tmp_path / "run"), "--width", "0.2", "--profile", "z", "--points", "60", "--from", "39.9"], check=True, capture_output=True)
    with open(tmp_path / "run" / "profile_z.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 60
    np.testing.assert_allclose([float(r["z_m"]) for r in rows], z, rtol=0, atol=1e-12)
    np.testing.assert_allclose([float(r["density_kg_m3"]) for r in rows], f["density"], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose([float(r["stress_zz_pa"]) for r in rows], szz, rtol=1e-8, atol=1e-12)


def test_fields_refuses_a_bad_request() -> None:
    sim = talus.Simulation.from_toml(COLUMN, name="column")
    with pytest.raises(talus.InputError, match="profile"):
        sim.fields(width=0.2, profile="w")
    with pytest.raises(talus.InputError, match="width"):
        sim.fields(width=-1.0, profile="z")
    with pytest.raises(talus.InputError, match="not both"):
        sim.fields(width=0.2, profile="z", grid=(2, 2, 2))


def test_a_grid_is_an_xdmf_structured_grid_of_every_field(tmp_path: Path) -> None:
    """`talus fields --grid` writes fields.h5 and an XDMF index a reader other
    than talus opens: every attribute's dataset exists with the grid's shape."""
    import xml.etree.ElementTree as ET

    import h5py

    sim = talus.Simulation.from_toml(COLUMN, base_dir=tmp_path, name="column")
    sim.run(out=str(tmp_path / "run"))
    subprocess.run([str(TALUS), "fields", str(tmp_path / "run"), "--width", "1.0", "--kernel", "lucy", "--grid", "8,10,12"], check=True, capture_output=True)
    root = ET.parse(tmp_path / "run" / "fields.xdmf").getroot()
    topo = root.find(".//Topology")
    assert topo.get("TopologyType") == "3DCoRectMesh" and topo.get("Dimensions") == "12 10 8"
    names = []
    with h5py.File(tmp_path / "run" / "fields.h5") as h5:
        for a in root.iter("Attribute"):
            item = a.find("DataItem")
            path = item.text.split(":", 1)[1]
            shape = tuple(int(x) for x in item.get("Dimensions").split())
            assert h5[path].shape == shape, (path, h5[path].shape, shape)
            names.append(a.get("Name"))
        # the grid's density sums to the column's mass (3 kg; cells of 0.5 x 0.4 x 0.5 m, a kernel of radius 1 m)
        assert abs(h5["density"][()].sum() * 0.5 * 0.4 * 0.5 - 3.0) < 0.03 * 3.0
    assert {"density", "velocity", "stress_zz", "contact_stress_zz", "kinetic_stress_zz", "stress_xz"} <= set(names)
