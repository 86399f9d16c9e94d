"""talus export --to liggghts|yade: the exported decks and scripts against the
hand-written ones of liggghts_cases/ and yade_cases/ (an independent check), against
talus, and the refusals."""

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from compare import engines, setups

ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "cases"


def probes(path):
    rows = list(csv.DictReader(open(path)))
    return {c: np.array([float(r[c]) for r in rows]) for c in rows[0] if c != "phase"}


def export_and_run(case, out):
    subprocess.run([str(engines.TALUS), "export", str(case), "--to", "liggghts", "--out", str(out)], check=True, capture_output=True)
    subprocess.run(["liggghts", "-in", "in.talus", "-log", "log.liggghts"], cwd=out, check=True, capture_output=True)
    return probes(out / "probes.csv")


@pytest.mark.parametrize("setup", ["SC-wall", "SC-pair"])
def test_the_exported_deck_runs_what_the_hand_written_deck_runs(tmp_path, setup):
    exported = export_and_run(CASES / f"{setup}.toml", tmp_path / "exported")
    run = setups.Run(setup, "hertz", 0.5)
    hand = probes(engines.run_liggghts_sc(run, tmp_path / "hand", setups.DT_SC))
    # the same equations in the same code: equal to LIGGGHTS's printed digits
    assert_tracked_columns_equal(exported, hand, 1e-13)


def assert_tracked_columns_equal(exported, hand, rel):
    """Every tracked-particle column of the export equals the hand-written run's at the
    export's rows (the hand-written runs record every step) to `rel` of its scale."""
    idx = np.searchsorted(hand["time_s"], exported["time_s"] - 1e-12)
    assert np.allclose(hand["time_s"][idx], exported["time_s"], rtol=0, atol=1e-12)
    cols = [c for c in hand if c.startswith("p")]
    assert len(cols) >= 12
    for c in cols:
        a, b = exported[c], hand[c][idx]
        scale = max(np.abs(b).max(), 1e-300)
        assert np.abs(a - b).max() <= rel * scale, (c, np.abs(a - b).max(), scale)


def export_and_run_yade(case, out):
    subprocess.run([str(engines.TALUS), "export", str(case), "--to", "yade", "--out", str(out)], check=True, capture_output=True)
    subprocess.run(["yade", "-n", "-j", "1", "-x", "talus.py"], cwd=out, check=True, capture_output=True)
    return probes(out / "probes.csv")


@pytest.mark.parametrize("setup", ["SC-wall", "SC-pair"])
def test_the_exported_yade_script_runs_what_the_hand_written_script_runs(tmp_path, setup):
    exported = export_and_run_yade(CASES / f"{setup}.toml", tmp_path / "exported")
    run = setups.Run(setup, "hertz", 0.5)
    out = tmp_path / "hand" / "yade.csv"
    (tmp_path / "hand").mkdir()
    cmd = ["yade", "-n", "-j", "1", "-x", str(ROOT / "yade_cases" / "SC.py"), "--setup", setup.split("-")[1], "--model", "hertz",
           "--e", "0.5", "--dt", repr(setups.DT_SC), "--vel-at", "step", "--out", str(out)]
    subprocess.run(cmd, check=True, capture_output=True)
    # the same equations in the same code; the export sets talus's mass and inertia
    # (SC.py lets YADE compute them from the density), a last-bit difference
    assert_tracked_columns_equal(exported, probes(out), 1e-9)


def test_what_yade_cannot_run_is_refused_naming_the_key(tmp_path):
    for case, edit, key in [
        ("SC-wall.toml", lambda t: t.replace('integrator = "verlet"', 'integrator = "gear"'), "simulation.integrator"),
        ("SC-wall.toml", lambda t: t.replace('convention = "talus"', 'convention = "talus"\ntangential = "total"'), "contact.tangential"),
        ("SC-wall.toml", lambda t: t.replace('convention = "talus"', 'convention = "talus"\ndamping = "liggghts"'), "contact.damping"),
        ("SC-wall-hooke.toml", lambda t: t.replace('convention = "talus"', 'convention = "talus"\nshear_kinematics = "full_radii"'), "contact.shear_kinematics"),
        ("SC-cohesive-sjkr.toml", lambda t: t.replace('convention = "liggghts"', 'convention = "yade"'), "contact.cohesion.model"),
    ]:
        p = tmp_path / case
        p.write_text(edit((CASES / case).read_text()))
        r = subprocess.run([str(engines.TALUS), "export", str(p), "--to", "yade", "--out", str(tmp_path / "o")], capture_output=True, text=True)
        assert r.returncode != 0 and key in r.stderr and str(p) in r.stderr, r.stderr


def test_python_m_compare_case_passes_on_an_sc_case(tmp_path):
    r = subprocess.run([sys.executable, "-m", "compare", str(CASES / "SC-oblique-hooke.toml"), "--out", str(tmp_path)],
                       cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "report.md").exists() and (tmp_path / "figures.json").exists()
    assert (tmp_path / "plots" / "p1_vz_m_s.png").exists()
    assert "within tolerance" in r.stdout


def test_what_liggghts_cannot_run_is_refused_naming_the_key(tmp_path):
    for case, edit, key in [
        ("SC-wall.toml", lambda t: t.replace('integrator = "verlet"', 'integrator = "gear"'), "simulation.integrator"),
        ("SC-wall.toml", lambda t: t.replace('convention = "talus"', 'convention = "talus"\ntangential = "incremental"'), "contact.tangential"),
        # one of two mesh walls removed: LIGGGHTS 3.8 cannot define its wall/gran/local compute again
        ("H1-small.toml", lambda t: t.replace('remove_walls_at_end = ["gate"]', 'remove_walls_at_end = ["gate", "hopper"]')
         .replace('stl = "meshes/', f'stl = "{CASES}/meshes/'), "phase[0].remove_walls_at_end"),
    ]:
        p = tmp_path / case
        p.write_text(edit((CASES / case).read_text()))
        r = subprocess.run([str(engines.TALUS), "export", str(p), "--to", "liggghts", "--out", str(tmp_path / "o")], capture_output=True, text=True)
        assert r.returncode != 0 and key in r.stderr and str(p) in r.stderr, r.stderr
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "drag" / "c1.toml"), "--to", "liggghts", "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode != 0
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "SC-wall.toml"), "--to", "abaqus", "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode != 0 and "liggghts, yade or lammps" in r.stderr


def test_the_shipped_drag_bed_is_what_talus_drag_bed_case_writes(tmp_path):
    """cases/beds/c1-bed1.csv is bed 1 of cases/drag/c1.toml as `talus drag --bed-case 1`
    prepares it (grown and settled), bit for bit, and the case written beside it runs."""
    r = subprocess.run([str(engines.TALUS), "drag", str(CASES / "drag" / "c1.toml"), "--bed-case", "1", "--out", str(tmp_path)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "c1-bed1.csv").read_bytes() == (CASES / "beds" / "c1-bed1.csv").read_bytes()
    written = (tmp_path / "c1-bed1.toml").read_text()
    shipped = (CASES / "drag-c1-bed1.toml").read_text()
    assert written.replace('csv = "c1-bed1.csv"', 'csv = "beds/c1-bed1.csv"').split("[simulation]")[1] == shipped.split("[simulation]")[1]


def test_moving_meshes_are_written_with_fix_move_mesh_and_refused_where_a_code_cannot(tmp_path):
    """A translating mesh: `fix move/mesh linear`; the drum's rotation from the start of its
    second phase: a `rotate` fix created then, the mesh's reference point on the axis, the axis
    torque column (also in the YADE script); a turning plane is refused by both, naming the key."""
    p = tmp_path / "H1-moving.toml"
    text = (CASES / "H1-small.toml").read_text().replace('stl = "meshes/hopper.stl"', 'stl = "meshes/hopper.stl"\nvelocity = [0.0, 0.0, 0.1]')
    text = text.replace('"meshes/', f'"{CASES}/meshes/')
    p.write_text(text)
    r = subprocess.run([str(engines.TALUS), "export", str(p), "--to", "liggghts", "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    deck = (tmp_path / "o" / "in.talus").read_text()
    assert "move/mesh mesh hopper linear 0.0000000000000000e0 0.0000000000000000e0 1.0000000000000001e-1" in deck
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "drum.toml"), "--to", "liggghts", "--out", str(tmp_path / "d")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    deck = (tmp_path / "d" / "in.talus").read_text()
    turn = deck.index("variable phase string turn")
    assert deck.index("move/mesh mesh drum rotate origin") > turn and "reference_point 0.0" in deck
    assert "drum_axis_torque_n_m" in deck
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "drum.toml"), "--to", "yade", "--out", str(tmp_path / "y")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "drum_axis_torque_n_m" in (tmp_path / "y" / "talus.py").read_text()
    for code in ("liggghts", "yade"):
        r = subprocess.run([str(engines.TALUS), "export", str(CASES / "SC-wall.toml"), "--to", code, "--out", str(tmp_path / "p"),
                            "--set", "wall[0].rotation={axis=[1.0,0.0,0.0],point=[0.0,0.0,0.0],angular_velocity=1.0}"], capture_output=True, text=True)
        assert r.returncode != 0 and "wall.plate.rotation" in r.stderr, (code, r.stderr)


def test_a_plate_moving_along_its_normal_agrees_with_liggghts_and_yade_to_1e_6(tmp_path):
    """SC-wall with its plate moving up at 0.05 m/s (LIGGGHTS: a mesh moved by `fix move/mesh
    linear`; YADE: its Wall at that velocity): every figure and column of talus in each
    reference's convention within SC's 1e-6 of the reference's."""
    r = subprocess.run([sys.executable, "-m", "compare", str(CASES / "SC-wall.toml"), "--engines", "talus,liggghts,yade", "--no-explain",
                        "--set", "wall[0].velocity=[0.0,0.0,0.05]", "--out", str(tmp_path)], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr


def test_an_oscillating_plate_differs_from_the_references_by_order_w_dt(tmp_path):
    """SC-wall with its plate oscillating (20 um at 500 Hz, w dt = 0.016): talus moves it by the
    exact displacement with the exact velocity; LIGGGHTS's wiggle by dt times the step-end
    velocity, YADE by the chord velocity. The peak force and overlap agree within 0.5% (and
    differ: the test would see an oscillation that is not exported)."""
    r = subprocess.run([sys.executable, "-m", "compare", str(CASES / "SC-wall.toml"), "--engines", "talus,liggghts,yade", "--no-explain",
                        "--set", "wall[0].oscillation={amplitude=[0.0,0.0,2e-5],frequency=500.0}", "--out", str(tmp_path)],
                       capture_output=True, text=True, cwd=ROOT)
    import json
    f = json.loads((tmp_path / "figures.json").read_text())
    still = json.loads((ROOT / "cases" / "golden" / "SC-wall.json").read_text())["figures"]
    for ref in ("liggghts", "yade"):
        for k in ("max_normal_force_n", "max_overlap_m"):
            t, x = f["engines"][f"talus[{ref}]"][k], f["engines"][ref][k]
            assert abs(t - x) < 5e-3 * abs(x), (ref, k, t, x)
    # the plate's motion shows: the peak force is not the still plate's
    assert abs(f["engines"]["liggghts"]["max_normal_force_n"] - still["max_normal_force_n"]) > 1e-3 * still["max_normal_force_n"]


def test_a_servo_wall_is_written_for_yade_and_refused_for_liggghts(tmp_path):
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "shear-servo.toml"), "--to", "liggghts", "--out", str(tmp_path / "l")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "wall.lid.servo" in r.stderr and "shear-servo.toml" in r.stderr, r.stderr
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "shear-servo.toml"), "--to", "yade", "--out", str(tmp_path / "y")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    script = (tmp_path / "y" / "talus.py").read_text()
    assert "lid_travel_m" in script and '"target": 10.0' in script


def test_inserted_particles_are_exported_from_a_talus_run_and_refused_without_one(tmp_path):
    case = ROOT / "cases" / "pour.toml"
    short = ["--set", "phase[0].insert[0].count=120", "--set", "phase[0].duration=0.03", "--set", "phase[1].duration=0.001"]
    # without a run's inserted.csv: refused, naming the insertion and what to give
    r = subprocess.run([str(engines.TALUS), "export", str(case), "--to", "liggghts", "--out", str(tmp_path / "x"), *short],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "phase.pour.insert" in r.stderr and "--inserted" in r.stderr, r.stderr
    run = tmp_path / "run"
    # (in LIGGGHTS's convention: a few spheres of two batches meet as they fall)
    subprocess.run([str(engines.TALUS), "run", str(case), "--out", str(run), "--quiet", *short, "--set", "contact.convention=liggghts"],
                   check=True, capture_output=True)
    rows = list(csv.DictReader(open(run / "inserted.csv")))
    assert [int(x["step"]) for x in rows[::50]] == [0, 131, 261] and len(rows) == 120
    # LIGGGHTS: each particle created at the start of its step, where and as talus inserted it
    out = tmp_path / "l"
    subprocess.run([str(engines.TALUS), "export", str(case), "--to", "liggghts", "--out", str(out), "--inserted", str(run / "inserted.csv"), *short],
                   check=True, capture_output=True)
    deck = (out / "in.talus").read_text()
    assert deck.count("create_atoms") == 120 and "create_box" in deck
    x = float(deck.split("create_atoms    1 single ")[1].split()[0])
    assert x == float(rows[0]["x_m"])
    subprocess.run(["liggghts", "-in", "in.talus", "-log", "log.liggghts"], cwd=out, check=True, capture_output=True)
    lig = probes(out / "probes.csv")
    tal = probes(run / "probes.csv")
    # the same count at the same steps; the same fall to 1e-9
    common = np.intersect1d(lig["step"], tal["step"])
    assert len(common) >= 2
    for k in common:
        i, j = np.nonzero(lig["step"] == k)[0][0], np.nonzero(tal["step"] == k)[0][0]
        assert lig["particles"][i] == tal["particles"][j]
        assert abs(lig["kinetic_energy_j"][i] - tal["kinetic_energy_j"][j]) <= 1e-9 * max(tal["kinetic_energy_j"].max(), 1e-30)
    # every particle at the end, in id order (LIGGGHTS's dump holds 6 digits)
    from compare.case import read_final
    (xl, rl), (xt, rt) = read_final(out), read_final(run)
    assert xl.shape == xt.shape == (120, 3)
    assert np.allclose(xl, xt, rtol=2e-6, atol=1e-7) and np.allclose(rl, rt, rtol=1e-5)


def test_inserted_particles_come_into_yade_at_their_steps(tmp_path):
    # the pour without rolling resistance (YADE has no epsd2 law), short: two batches
    text = (ROOT / "cases" / "pour.toml").read_text().replace('rolling = "epsd2"\n', "").replace("rolling_friction = 0.3\n", "")
    case = tmp_path / "pour.toml"
    case.write_text(text)
    short = ["--set", "phase[0].insert[0].count=100", "--set", "phase[0].duration=0.03", "--set", "phase[1].duration=0.001"]
    run = tmp_path / "run"
    subprocess.run([str(engines.TALUS), "run", str(case), "--out", str(run), "--quiet", *short, "--set", "contact.convention=yade"],
                   check=True, capture_output=True)
    out = tmp_path / "y"
    subprocess.run([str(engines.TALUS), "export", str(case), "--to", "yade", "--out", str(out), "--inserted", str(run / "inserted.csv"), *short],
                   check=True, capture_output=True)
    subprocess.run(["yade", "-n", "-j", "1", "-x", "talus.py"], cwd=out, check=True, capture_output=True)
    yad, tal = probes(out / "probes.csv"), probes(run / "probes.csv")
    assert np.array_equal(yad["step"], tal["step"]) and np.array_equal(yad["particles"], tal["particles"])
    assert tal["particles"][0] == 50 and tal["particles"][-1] == 100
    assert np.allclose(yad["kinetic_energy_j"], tal["kinetic_energy_j"], rtol=1e-9, atol=1e-15)
    from compare.case import read_final
    (xy, _), (xt, _) = read_final(out), read_final(run)
    # the spheres that met no other to 1e-11 m; the two that met as they fell, 2e-9 m
    d = np.abs(xy - xt).max(axis=1)
    assert np.sort(d)[-3] < 1e-10 and d.max() < 1e-8, np.sort(d)[-5:]


def test_periodic_cases_are_exported_with_periodic_boundaries_and_walls_refused_for_yade(tmp_path):
    # LIGGGHTS: `boundary p p f` for the chute (periodic along x and y)
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "chute.toml"), "--to", "liggghts", "--out", str(tmp_path / "l")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "boundary        p p f" in (tmp_path / "l" / "in.talus").read_text()
    # YADE's periodic cell takes no wall: refused naming the wall
    r = subprocess.run([str(engines.TALUS), "export", str(CASES / "chute.toml"), "--to", "yade", "--out", str(tmp_path / "y")],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "wall.floor in a periodic domain" in r.stderr and "chute.toml" in r.stderr, r.stderr


def test_the_cooling_gas_collides_across_periodic_faces_as_liggghts_and_yade_do(tmp_path):
    # the first 10 ms of cases/cooling.toml (about 2000 collisions, a third of them
    # across a periodic face, before chaos parts the runs): talus in each code's
    # convention against the code, row by row
    case = tmp_path / "cooling.toml"
    # a time step of 2^-17 s and probes every 32 steps: every engine writes its rows at the same steps
    text = (CASES / "cooling.toml").read_text().replace("duration = 0.25", "duration = 0.01").replace("interval = 0.005", "interval = 2.44140625e-4")
    text = text.replace("timestep_rayleigh_fraction = 0.2", "timestep = 7.62939453125e-06")
    case.write_text(text.replace('csv = "beds/', f'csv = "{CASES}/beds/'))
    lig = export_and_run(case, tmp_path / "l")
    subprocess.run([str(engines.TALUS), "run", str(case), "--out", str(tmp_path / "t"), "--quiet"], check=True, capture_output=True)
    tal = probes(tmp_path / "t" / "probes.csv")

    def same_steps(a, b):
        # the rows both wrote (LIGGGHTS prints every n steps, talus at each step past a multiple of the interval)
        common = np.intersect1d(a["step"], b["step"])
        assert len(common) >= 8, (a["step"], b["step"])
        pick = lambda x: {c: v[np.isin(x["step"], common)] for c, v in x.items()}
        return pick(a), pick(b)

    tal, lig = same_steps(tal, lig)
    # energy was lost: the spheres collided
    assert tal["kinetic_energy_j"][-1] < 0.97 * tal["kinetic_energy_j"][0]
    np.testing.assert_allclose(tal["kinetic_energy_j"], lig["kinetic_energy_j"], rtol=1e-9)
    np.testing.assert_array_equal(tal["contacts"], lig["contacts"])
    yad = export_and_run_yade(case, tmp_path / "y")
    subprocess.run([str(engines.TALUS), "run", str(case), "--out", str(tmp_path / "ty"), "--quiet", "--set", "contact.convention=yade"],
                   check=True, capture_output=True)
    ty, yad = same_steps(probes(tmp_path / "ty" / "probes.csv"), yad)
    np.testing.assert_allclose(ty["kinetic_energy_j"], yad["kinetic_energy_j"], rtol=1e-6)
    np.testing.assert_array_equal(ty["contacts"], yad["contacts"])


def test_cohesion_is_exported_to_liggghts_on_pairs_and_walls_with_its_energy_density(tmp_path):
    # (the cohesive collisions themselves are compared with LIGGGHTS to 1e-6 in scripts/compare_all.sh)
    for model, k in [("sjkr", "3.0000000000000000e4"), ("sjkr2", "1.5000000000000000e4")]:
        out = tmp_path / model
        subprocess.run([str(engines.TALUS), "export", str(CASES / f"SC-cohesive-{model}.toml"), "--to", "liggghts", "--out", str(out)],
                       check=True, capture_output=True)
        deck = (out / "in.talus").read_text()
        assert f"fix m7 all property/global cohesionEnergyDensity peratomtypepair 1 {k}" in deck, deck
        lines = [ln for ln in deck.splitlines() if ln.startswith("pair_style") or " wall/gran " in ln]
        assert len(lines) == 2 and all(f"cohesion {model}" in ln for ln in lines), lines


def test_laws_that_pull_are_refused_by_name_where_a_reference_lacks_them_and_lammps_refuses_what_it_cannot_hold(tmp_path):
    def export(case, to, text=None):
        p = CASES / case
        if text is not None:
            p = tmp_path / case
            p.write_text(text)
        return subprocess.run([str(engines.TALUS), "export", str(p), "--to", to, "--out", str(tmp_path / "o")], capture_output=True, text=True)
    for case in ["SC-cohesive-dmt.toml", "SC-cohesive-jkr.toml"]:
        model = case.split("-")[-1].split(".")[0]
        for to in ["liggghts", "yade"]:
            r = export(case, to)
            assert r.returncode != 0 and f'contact.model = "{model}"' in r.stderr and "lammps" in r.stderr, r.stderr
    # a law per pair of materials: LAMMPS only
    for to in ["liggghts", "yade"]:
        r = export("SC-mixed-laws.toml", to)
        assert r.returncode != 0 and "contact.pair" in r.stderr and "lammps" in r.stderr, r.stderr
    jkr = (CASES / "SC-cohesive-jkr.toml").read_text()
    dmt = (CASES / "SC-cohesive-dmt.toml").read_text()
    for case, text, key in [
        # this LAMMPS's JKR wall gives NaN forces
        ("SC-cohesive-jkr.toml", dmt.replace('model = "dmt"', 'model = "jkr"'), "wall.plate with a jkr law"),
        # the wall moves: the LAMMPS export writes still walls only
        ("SC-wall.toml", (CASES / "SC-wall.toml").read_text().replace("normal = [0.0, 0.0, 1.0] }", "normal = [0.0, 0.0, 1.0] }\nvelocity = [0.0, 0.0, 0.01]"), "wall.plate"),
        # LIGGGHTS's cohesion has no LAMMPS counterpart
        ("SC-cohesive-sjkr.toml", None, "contact.cohesion.model"),
        # LIGGGHTS's derived Hooke stiffness depends on each pair
        ("SC-pair-hooke.toml", None, "contact.characteristic_velocity"),
        ("SC-cohesive-jkr.toml", jkr.replace('convention = "lammps"', 'convention = "lammps"\ntangential = "total"'), "contact.tangential"),
    ]:
        r = export(case, "lammps", text)
        assert r.returncode != 0 and key in r.stderr, (case, r.stderr)


def test_jkr_collisions_agree_with_lammps_to_1e_6(tmp_path):
    # (the other LAMMPS comparisons, DMT among them, are in scripts/compare_all.sh)
    r = subprocess.run([sys.executable, "-m", "compare", str(CASES / "SC-cohesive-jkr.toml"), "--engines", "talus,lammps", "--out", str(tmp_path / "c")],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0 and "30 of 30 checks within tolerance" in r.stdout, r.stdout + r.stderr
    deck = (tmp_path / "c" / "lammps" / "in.talus").read_text()
    assert "pair_coeff      1 1 jkr " in deck and "tangential mindlin NULL 1.0" in deck and "damping tsuji" in deck, deck


def test_liggghts_takes_a_pair_table_of_cohesion_only_and_refuses_any_other_key_of_a_pair(tmp_path):
    """LIGGGHTS holds per pair of atom types only the cohesion's energy density: a table that
    sets only `cohesion` exports (each pair's K, the section's elsewhere); a pair's `model` or a
    second cohesion model is refused by name."""
    def export(text, name):
        p = tmp_path / f"{name}.toml"
        p.write_text(text)
        return subprocess.run([str(engines.TALUS), "export", str(p), "--to", "liggghts", "--out", str(tmp_path / name)],
                              capture_output=True, text=True)
    text = (CASES / "SC-cohesive-pairs.toml").read_text()
    r = export(text, "ok")
    assert r.returncode == 0, r.stderr
    deck = (tmp_path / "ok" / "in.talus").read_text()
    line = next(l for l in deck.splitlines() if "cohesionEnergyDensity" in l)
    # materials grain, glue, steel: grain-glue 1e5, grain-steel 5e3, every other pair the section's 3e4
    k = [float(x) for x in line.split()[7:]]
    assert k == [3e4, 1e5, 5e3, 1e5, 3e4, 3e4, 5e3, 3e4, 3e4]
    assert "cohesion sjkr" in deck.split("pair_style")[1].splitlines()[0]
    r = export(text.replace('materials = ["grain", "steel"]\n', 'materials = ["grain", "steel"]\nmodel = "hertz"\n'), "model")
    assert r.returncode != 0 and 'contact.pair[1].model' in r.stderr and "lammps" in r.stderr, r.stderr
    r = export(text.replace('energy_density = 5.0e3', 'energy_density = 5.0e3').replace(
        'materials = ["grain", "steel"]\ncohesion = { model = "sjkr"', 'materials = ["grain", "steel"]\ncohesion = { model = "sjkr2"'), "two")
    assert r.returncode != 0 and 'contact.pair[1].cohesion.model = "sjkr2"' in r.stderr, r.stderr
