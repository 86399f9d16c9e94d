"""The Python module against the command line, closed forms and its own contracts.

Run from the repository root: `python3 -m pytest python/tests` (scripts/test.sh does).
"""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import talus

ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "cases"
TALUS = ROOT / "target" / "release" / "talus"
G = 9.81


def cli(case: Path, out: Path, *args: str) -> dict:
    """`talus run` of a case; its summary."""
    subprocess.run([str(TALUS), "run", str(case), "--out", str(out), "--quiet", *args], check=True, capture_output=True)
    return json.loads((out / "summary.json").read_text())


def free_sphere(x0, v0, gravity=(0.0, 0.0, -G), domain=((-1, -1, -5), (1, 1, 1)), duration=0.5):
    """One sphere and no walls (a dict case)."""
    return {
        "simulation": {"timestep": 1e-4, "gravity": list(gravity), "domain": {"lo": list(domain[0]), "hi": list(domain[1])}},
        "contact": {"model": "hooke", "stiffness": {"kn": 1e3, "kt": 1e3, "gamma_n": 0.0, "gamma_t": 0.0}},
        "material": [{"name": "m", "youngs_modulus": 1e6, "poisson_ratio": 0.3, "density": 2500.0, "restitution": 0.5, "friction": 0.4}],
        "particles": {"material": "m", "list": [{"id": 7, "position": list(x0), "velocity": list(v0), "radius": 0.01}]},
        "phase": [{"name": "fall", "duration": duration}],
        "output": {"interval": 0.01},
    }


# ---------------------------------------------------------------- same as the CLI


@pytest.mark.parametrize("case,steps", [("SC-oblique.toml", None), ("SC-pair-hooke.toml", None), ("H1-small.toml", 2000)])
def test_same_state_hash_as_the_command_line(tmp_path, case, steps):
    args = ["--steps", str(steps)] if steps else []
    ref = cli(CASES / case, tmp_path / "cli", *args)
    sim = talus.Simulation.from_file(CASES / case)
    if steps:
        sim.step(steps)
        assert sim.state_hash() == ref["state_hash"]
    else:
        s = sim.run()
        assert s["state_hash"] == ref["state_hash"]
        assert sim.state_hash() == ref["state_hash"]
        # the analysis figures too, to the last bit
        for k in ("restitution", "max_overlap_m", "contact_duration_s"):
            if k in ref:
                assert s[k] == ref[k], k


def test_run_with_out_writes_the_command_lines_files(tmp_path):
    ref = cli(CASES / "SC-wall.toml", tmp_path / "cli")
    sim = talus.Simulation.from_file(CASES / "SC-wall.toml")
    s = sim.run(out=tmp_path / "py")
    for f in ("probes.csv", "checkpoint.bin", "summary.json", "checkpoint_after_collide.bin"):
        assert (tmp_path / "py" / f).exists(), f
    assert (tmp_path / "py" / "probes.csv").read_bytes() == (tmp_path / "cli" / "probes.csv").read_bytes()
    on_disk = json.loads((tmp_path / "py" / "summary.json").read_text())
    assert on_disk["state_hash"] == s["state_hash"] == ref["state_hash"]
    assert sim.summary()["state_hash"] == ref["state_hash"]


def test_from_toml_and_from_dict_are_the_file(tmp_path):
    text = (CASES / "SC-pair.toml").read_text()
    a = talus.Simulation.from_toml(text, base_dir=CASES, name="SC-pair")
    a.run()
    b = talus.Simulation.from_file(CASES / "SC-pair.toml")
    b.run()
    assert a.state_hash() == b.state_hash()
    d = free_sphere([0, 0, 0], [0.1, 0, 0])
    c = talus.Simulation.from_dict(d)
    c.step(10)
    assert c.step_count == 10


# ---------------------------------------------------------------- physics


def test_free_fall_matches_the_closed_form_to_round_off():
    x0, v0 = np.array([0.1, -0.2, 0.3]), np.array([0.5, 0.25, 2.0])
    sim = talus.Simulation.from_dict(free_sphere(x0, v0))
    g = np.array([0.0, 0.0, -G])
    for n in (1, 99, 900, 4000):
        sim.step(n)
        t = sim.time
        x = x0 + v0 * t + 0.5 * g * t * t
        v = v0 + g * t
        assert np.allclose(sim.positions[0], x, rtol=0, atol=1e-12 * (1 + abs(x).max())), (t, sim.positions[0] - x)
        assert np.allclose(sim.velocities[0], v, rtol=0, atol=1e-12 * (1 + abs(v).max()))
    assert sim.ids.tolist() == [7]
    assert np.allclose(sim.forces[0], sim.masses[0] * g, rtol=1e-15)


def test_settled_bed_floor_carries_its_weight():
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import dict_pile
    finally:
        sys.path.pop(0)
    r = dict_pile.settle(300)
    # the side walls carry a little of it by friction; the floor carries the rest
    assert abs(r["floor_load_over_weight"] - 1.0) < 0.01, r
    walls_z = sum(f[2] for f in r["walls_n"].values())
    assert abs(-walls_z / r["weight_n"] - 1.0) < 0.005, r


# ---------------------------------------------------------------- errors


def test_input_errors_carry_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text((CASES / "SC-wall.toml").read_text().replace("restitution = 0.5", "restitution = 1.5"))
    r = subprocess.run([str(TALUS), "run", str(bad), "--out", str(tmp_path / "o"), "--quiet"], capture_output=True, text=True)
    assert r.returncode != 0
    with pytest.raises(talus.InputError) as e:
        talus.Simulation.from_file(bad)
    assert str(e.value) in r.stderr
    assert "restitution" in str(e.value) and "1.5" in str(e.value)
    assert isinstance(e.value, ValueError)
    with pytest.raises(talus.InputError, match="line 2.*unknown field `foo`"):
        talus.Simulation.from_toml("[simulation]\nfoo = 1\n")
    d = free_sphere([0, 0, 0], [0, 0, 0])
    d["material"][0]["density"] = -1.0
    with pytest.raises(talus.InputError, match="density"):
        talus.Simulation.from_dict(d)
    d["material"][0]["density"] = None
    with pytest.raises(talus.InputError):
        talus.Simulation.from_dict(d)
    with pytest.raises(FileNotFoundError, match="cannot read case file .*missing.toml"):
        talus.Simulation.from_file(tmp_path / "missing.toml")
    with pytest.raises(talus.InputError, match="--set"):
        talus.Simulation.from_file(CASES / "SC-wall.toml", overrides=["nonsense"])


def test_run_error_after_the_failure_checkpoint(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # no floor: the sphere leaves the domain through z = -0.05 m
    sim = talus.Simulation.from_dict(free_sphere([0, 0, 0], [0, 0, -1], domain=((-1, -1, -0.05), (1, 1, 1))), name="falls")
    with pytest.raises(talus.RunError) as e:
        sim.run()
    msg = str(e.value)
    assert "particle id 7" in msg and "failure_checkpoint.bin" in msg, msg
    assert isinstance(e.value, RuntimeError)
    ck = tmp_path / "out" / "falls" / "failure_checkpoint.bin"
    assert ck.exists()
    # the same with an output folder: the checkpoint goes there
    sim = talus.Simulation.from_dict(free_sphere([0, 0, 0], [0, 0, -1], domain=((-1, -1, -0.05), (1, 1, 1))), name="falls")
    with pytest.raises(talus.RunError, match="failure_checkpoint"):
        sim.run(out=tmp_path / "o")
    assert (tmp_path / "o" / "failure_checkpoint.bin").exists()
    assert (tmp_path / "o" / "probes.csv").stat().st_size > 0


def test_setters_refuse_bad_values_and_change_nothing():
    sim = talus.Simulation.from_dict(free_sphere([0, 0, 0], [0, 0, 0]))
    before = sim.state_hash()
    for call, args, match in [
        (sim.set_positions, ([7], [[np.nan, 0, 0]]), "finite"),
        (sim.set_positions, ([7], [[0, 0, 2.0]]), "outside the domain"),
        (sim.set_velocities, ([7], [[0, np.inf, 0]]), "finite"),
        (sim.set_spins, ([8], [[0, 0, 1]]), "no particle 8"),
        (sim.set_positions, ([-1], [[0, 0, 0]]), "no particle -1"),
        (sim.set_positions, ([7, 7], [[0, 0, 0]]), "2 ids but 1 values"),
        (sim.set_velocities, ([7], [[0, 0]]), "N x 3"),
    ]:
        with pytest.raises(talus.InputError, match=match):
            call(*args)
    assert sim.state_hash() == before
    sim.set_positions([7], [[0.2, 0.1, -0.3]])
    sim.set_velocities(np.array([7]), np.array([[1.0, 0, 0]]))
    sim.set_spins([7], [[0, 0, 3.0]])
    assert sim.positions.tolist() == [[0.2, 0.1, -0.3]]
    assert sim.velocities.tolist() == [[1.0, 0, 0]]
    assert sim.spins.tolist() == [[0, 0, 3.0]]
    assert len(sim.walls) == 0  # no walls: a mapping with nothing in it
    with pytest.raises(KeyError, match="no wall named"):
        sim.walls["gate"]
    with pytest.raises(talus.InputError, match="n must be 0 or more"):
        sim.step(-1)
    with pytest.raises(talus.InputError, match="n_steps"):
        sim.every(0, print)


# ---------------------------------------------------------------- stepping control


def test_callbacks_run_the_expected_number_of_times():
    sim = talus.Simulation.from_dict(free_sphere([0, 0, 0], [0, 0, 0], duration=0.1))
    seen = {"a": [], "b": []}
    sim.every(7, lambda s: seen["a"].append(s.step_count))
    sim.every(250, lambda s: seen["b"].append(s.step_count))
    sim.step(20)  # steps 1..20
    sim.run_until(0.05)  # to step 500
    sim.run()  # to the end of the phase, step 1000
    assert sim.step_count == 1000
    assert seen["a"] == list(range(7, 1001, 7))
    assert seen["b"] == [250, 500, 750, 1000]
    sim.clear_callbacks()
    sim.step(7)
    assert len(seen["a"]) == 142


def test_phases_walls_and_run_phase():
    sim = talus.Simulation.from_file(CASES / "H1-small.toml", overrides=["particles.lattice.count=300", "phase.fill.duration=0.3", "phase.discharge.duration=0.2"])
    assert sim.phase == "fill" and sim.walls["gate"].active
    assert list(sim.walls) == ["hopper", "gate", "box"] and "gate" in sim.walls
    assert sim.run_phase() == "fill"
    assert sim.phase == "discharge" and sim.phase_index == 1
    assert not sim.walls["gate"].active
    assert abs(sim.time - 0.3) < sim.dt
    assert sim.run_phase() == "discharge"
    assert sim.phase == "end" and sim.run_phase() is None


def test_wall_velocity_and_remove():
    d = free_sphere([0, 0, 0.0101], [0, 0, 0], gravity=(0, 0, -G))
    d["wall"] = [{"name": "floor", "material": "m", "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]}}]
    d["phase"] = [{"name": "rest", "duration": 1.0}]
    d["contact"] = {"model": "hertz"}  # damped (restitution 0.5): the sphere comes to rest
    sim = talus.Simulation.from_dict(d)
    sim.run_until(0.5)
    floor = sim.walls["floor"]
    # a sphere at rest on the floor: the floor carries its weight
    assert abs(-floor.force[2] / (sim.masses[0] * G) - 1) < 1e-3
    with pytest.raises(talus.InputError, match="3 finite numbers"):
        floor.velocity = [0, 0, np.nan]
    floor.velocity = [0.0, 0.0, 0.01]
    assert floor.velocity.tolist() == [0, 0, 0.01]
    z0 = sim.positions[0, 2]
    sim.step(1000)  # 0.1 s: the floor lifts the sphere by 1 mm
    assert abs(sim.positions[0, 2] - z0 - 1e-3) < 2e-5
    floor.velocity = [0, 0, 0]
    floor.remove()
    assert not floor.active
    sim.step(10)
    assert floor.force.tolist() == [0, 0, 0]
    v1 = sim.velocities[0, 2]
    sim.step(10)  # in free fall
    assert abs(sim.velocities[0, 2] - (v1 - G * 10 * sim.dt)) < 1e-12


def test_a_turning_wall_from_python_axis_torque_and_rate():
    """A sphere resting on a floor whose axis (y, through x = 0.05) turns at rate 0: the axis
    torque is m g (x0 - 0.05); setting the rate turns the floor (its normal tilts by rate t)."""
    x0 = 0.0
    d = free_sphere([x0, 0, 0.0101], [0, 0, 0], gravity=(0, 0, -G))
    d["wall"] = [{"name": "floor", "material": "m", "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]},
                  "rotation": {"axis": [0, 1, 0], "point": [0.05, 0, 0], "angular_velocity": 0.0}}]
    d["phase"] = [{"name": "rest", "duration": 1.0}]
    d["contact"] = {"model": "hertz"}
    sim = talus.Simulation.from_dict(d)
    sim.run_until(0.5)
    floor = sim.walls["floor"]
    m = sim.masses[0]
    assert abs(floor.axis_torque - m * G * (x0 - 0.05)) < 1e-3 * m * G * 0.05
    assert floor.angular_velocity == 0.0
    with pytest.raises(talus.InputError, match="finite"):
        floor.angular_velocity = float("inf")
    floor.angular_velocity = 0.1
    sim.step(100)
    assert floor.angular_velocity == 0.1
    # a wall without an axis has none to turn about
    d["wall"][0].pop("rotation")
    other = talus.Simulation.from_dict(d)
    assert other.walls["floor"].axis_torque is None and other.walls["floor"].angular_velocity is None
    with pytest.raises(talus.InputError, match="no rotation axis"):
        other.walls["floor"].angular_velocity = 1.0


def test_checkpoint_from_python_restarts_to_the_uninterrupted_state(tmp_path):
    case = CASES / "H1-small.toml"
    over = ["particles.lattice.count=400"]
    whole = talus.Simulation.from_file(case, overrides=over)
    whole.step(1200)
    part = talus.Simulation.from_file(case, overrides=over)
    part.step(500)
    part.save_checkpoint(tmp_path / "ck.bin")
    again = talus.Simulation.restart(tmp_path / "ck.bin", part)
    assert again.step_count == 500
    again.step(700)
    assert again.state_hash() == whole.state_hash()
    # from the file of the case too (the overrides make another case: refused)
    with pytest.raises(talus.InputError):
        talus.Simulation.restart(tmp_path / "ck.bin", case)


@pytest.fixture
def python_ctrl_c():
    """Ctrl-C as Python has it by default (KeyboardInterrupt), whatever this
    process inherited: a process started in the background by a shell without
    job control inherits SIGINT ignored, and Python then leaves it ignored."""
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def test_ctrl_c_raises_keyboard_interrupt_between_steps_and_the_run_goes_on(python_ctrl_c):
    over = ["particles.lattice.count=2000"]
    ref = talus.Simulation.from_file(CASES / "H1-small.toml", overrides=over)
    ref.step(3000)
    sim = talus.Simulation.from_file(CASES / "H1-small.toml", overrides=over)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t = time.time()
    with pytest.raises(KeyboardInterrupt):
        sim.step(3000)
    assert time.time() - t < 10
    stopped = sim.step_count
    assert 0 < stopped < 3000
    sim.step(3000 - stopped)
    assert sim.state_hash() == ref.state_hash()


def test_arrays_are_copies_in_id_order():
    sim = talus.Simulation.from_file(CASES / "H1-small.toml", overrides=["particles.lattice.count=500"])
    sim.step(50)
    ids = sim.ids
    assert ids.dtype == np.uint64 and (np.diff(ids.astype(np.int64)) > 0).all()
    x = sim.positions
    assert x.shape == (500, 3) and x.dtype == np.float64
    x[:] = 0.0
    assert not (sim.positions == 0).all()
    assert sim.radii.shape == (500,) and sim.masses.shape == (500,)
    assert sim.torques.shape == (500, 3) and sim.spins.shape == (500, 3)
    c = talus.cloud(CASES / "H1-small.toml")
    assert len(c["ids"]) == 5000 and c["positions"].shape == (5000, 3)


def test_the_module_says_it_is_serial():
    assert talus.mpi is False
    env = dict(os.environ, OMPI_COMM_WORLD_SIZE="2")
    r = subprocess.run([sys.executable, "-c", "import talus"], env=env, capture_output=True, text=True)
    assert r.returncode == 0 and "serial" in r.stderr


# ---------------------------------------------------------------- examples


def run_example(name: str, tmp_path: Path, *args: str) -> str:
    r = subprocess.run([sys.executable, str(ROOT / "examples" / name), "--out", str(tmp_path), *args], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_example_restitution(tmp_path):
    run_example("restitution.py", tmp_path)
    curves = json.loads((tmp_path / "restitution.json").read_text())
    assert (tmp_path / "restitution.png").stat().st_size > 0
    for model, pts in curves.items():
        assert len(pts) == 5
        for e_in, e_out in pts:
            # LIGGGHTS's damping mapping gives back the material's restitution (SC tolerance)
            assert abs(e_out - e_in) < 2e-3, (model, e_in, e_out)


def test_example_dict_pile(tmp_path):
    out = run_example("dict_pile.py", tmp_path, "--count", "200")
    r = json.loads((tmp_path / "pile.json").read_text())
    assert r["particles"] == 200 and "floor carries" in out
    assert abs(r["floor_load_over_weight"] - 1) < 0.01


def test_example_friction_sweep(tmp_path):
    run_example("friction_sweep.py", tmp_path)
    rows = json.loads((tmp_path / "friction_sweep.json").read_text())
    rates = [r["rate_kg_s"] for r in rows]
    assert [r["friction"] for r in rows] == [0.2, 0.4, 0.6]
    # more friction, slower discharge; everything leaves the hopper
    assert rates[0] > rates[1] > rates[2] > 0, rates
    for r in rows:
        assert abs(r["discharged_kg"] / r["total_kg"] - 1) < 0.01


def test_example_h1_small_hopper(tmp_path):
    out = run_example("h1_small_hopper.py", tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    # the whole run (the same state as the command line's is checked above on
    # its first steps): the fill carried by floor and gate, everything discharged,
    # and the callback's series ends where talus's own figure does
    assert abs(s["fill_end_force_balance"] - 1) < 0.01
    assert abs(s["discharged_mass_kg"] / s["total_mass_kg"] - 1) < 0.01
    assert (tmp_path / "discharge.png").stat().st_size > 0
    d = np.loadtxt(tmp_path / "discharge.csv", delimiter=",", skiprows=1)
    assert abs(d[-1, 1] - s["discharged_mass_kg"]) < 0.01 * s["total_mass_kg"]
    assert "discharge rate" in out


def test_stepping_releases_the_gil():
    sim = talus.Simulation.from_file(CASES / "H1-small.toml", threads=1, overrides=["particles.lattice.count=2000"])
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.002)

    th = threading.Thread(target=tick)
    th.start()
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < 1.5:
        sim.step(500)
    t1 = time.perf_counter()
    stop.set()
    th.join()
    during = [t0] + [t for t in ticks if t0 < t < t1] + [t1]
    # the other thread ran all along (holding the GIL, it could not have)
    assert len(during) > 50, len(during)
    assert max(b - a for a, b in zip(during, during[1:])) < 0.5


def test_drag_from_python_is_talus_drag(tmp_path):
    case = tmp_path / "c1-one-bed.toml"
    case.write_text((CASES / "drag" / "c1.toml").read_text().replace('id = "c1"', 'id = "c1-one-bed"\nseeds = [1]'))
    s = talus.drag(case, out=tmp_path / "py")
    subprocess.run([str(TALUS), "drag", str(case), "--out", str(tmp_path / "cli")], check=True, capture_output=True)
    ref = json.loads((tmp_path / "cli" / "summary.json").read_text())
    assert s["beds"] == 1 and s["mean_drag_n"] == ref["mean_drag_n"] > 0
    bad = tmp_path / "bad.toml"
    bad.write_text(case.read_text().replace("granule_size = 1.092e-3", "granule_size = -1.0"))
    with pytest.raises(talus.InputError, match="granule_size"):
        talus.drag(bad, out=tmp_path / "bad")


def test_ctrl_c_stops_a_drag_study_after_its_bed(tmp_path, python_ctrl_c):
    case = tmp_path / "c1-three-beds.toml"
    case.write_text((CASES / "drag" / "c1.toml").read_text().replace('id = "c1"', 'id = "c1-three-beds"\nseeds = [1, 2, 3]'))
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t = time.time()
    with pytest.raises(KeyboardInterrupt):
        talus.drag(case, out=tmp_path / "o")
    # stopped after the first bed, not after all three
    assert not (tmp_path / "o" / "summary.json").exists()
    assert time.time() - t < 60
