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
