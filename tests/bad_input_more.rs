//! More malformed input (issue 10, B4): each refused with a message that names
//! the file, the key, line or particle, and the value, and a non-zero exit.
//! Messages are asserted word for word (the temporary folder shown as DIR), and
//! every shipped case and drag bed is checked to pass the same checks.

mod common;
use common::*;
use std::process::Command;

/// Run `talus run DIR/bad.toml` with `files` written into DIR beside it, plus
/// `extra` arguments; returns (success, stderr with the folder shown as DIR).
fn run_text(text: &str, files: &[(&str, &[u8])], extra: &[&str]) -> (bool, String) {
    let d = tempfile::tempdir().unwrap();
    let case = d.path().join("bad.toml");
    std::fs::write(&case, text).unwrap();
    for (name, bytes) in files {
        std::fs::write(d.path().join(name), bytes).unwrap();
    }
    let out = d.path().join("out");
    let mut args = vec!["run", case.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"];
    args.extend_from_slice(extra);
    let o = Command::new(env!("CARGO_BIN_EXE_talus")).args(&args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).replace(&d.path().display().to_string(), "DIR");
    (o.status.success(), err)
}

/// The whole of stderr for a case text that must be refused.
fn refused(text: &str, files: &[(&str, &[u8])]) -> String {
    let (ok, err) = run_text(text, files, &[]);
    assert!(!ok, "accepted:\n{text}");
    err
}

/// A shipped case with edits must be refused with exactly `msg` about DIR/bad.toml.
fn expect(base: &str, edits: &[(&str, &str)], msg: &str) {
    assert_eq!(refused(&case_text(base, edits), &[]), format!("talus: error: DIR/bad.toml: {msg}\n"), "{edits:?}");
}

fn accepted(text: &str, files: &[(&str, &[u8])], extra: &[&str]) {
    let (ok, err) = run_text(text, files, extra);
    assert!(ok, "refused: {err}");
}

const SPHERE: &str = "list = [ { id = 1, position = [0.0, 0.0, 0.0021], velocity = [0.0, 0.0, -0.5], radius = 0.002 } ]";
const PLATE: &str = "plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }";
const COLLISION: &str = "[analysis]\nkind = \"collision\"\nparticle = 1\nwall = \"plate\"\n";

/// An ASCII STL square in z = `z`, +-1 cm in x and y, with `bad` replacing the first vertex line.
fn square_stl(z: f64, first_vertex: Option<&str>) -> String {
    let v = |x: f64, y: f64| format!("vertex {x} {y} {z}");
    let first = first_vertex.map(str::to_string).unwrap_or_else(|| v(-0.01, -0.01));
    format!(
        "solid square\nfacet normal 0 0 1\nouter loop\n{first}\n{}\n{}\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\n{}\n{}\n{}\nendloop\nendfacet\nendsolid square\n",
        v(0.01, -0.01),
        v(0.01, 0.01),
        v(-0.01, -0.01),
        v(0.01, 0.01),
        v(-0.01, 0.01)
    )
}

#[test]
fn duplicate_material_and_phase_names_are_refused() {
    let second = "[[material]]\nname = \"seed-soft\"\nyoungs_modulus = 2.0e6\npoisson_ratio = 0.3\ndensity = 2500.0\nrestitution = 0.5\nfriction = 0.4\n\n[particles]";
    expect("SC-wall.toml", &[("[particles]", second)], "material[1].name = \"seed-soft\": material names must be unique");
    expect(
        "SC-wall.toml",
        &[("[output]", "[[phase]]\nname = \"collide\"\nduration = 0.001\n\n[output]")],
        "phase[1].name = \"collide\": phase names must be unique",
    );
    expect(
        "shear-bed.toml",
        &[("name = \"lid\"", "name = \"floor\"")],
        "wall[1].name = \"floor\": wall names must be unique",
    );
}

#[test]
fn wall_and_phase_names_unsafe_in_a_file_name_or_csv_header_are_refused() {
    let why = "a name must be non-empty and hold only letters A-Z a-z, digits 0-9, `_` and `-` (it names files and CSV columns)";
    expect("SC-wall.toml", &[("name = \"plate\"", "name = \"my plate\"")], &format!("wall[0].name = \"my plate\": {why}"));
    expect("SC-wall.toml", &[("name = \"plate\"", "name = \"a,b\"")], &format!("wall[0].name = \"a,b\": {why}"));
    expect("SC-wall.toml", &[("name = \"collide\"", "name = \"../x\"")], &format!("phase[0].name = \"../x\": {why}"));
    expect("SC-wall.toml", &[("name = \"collide\"", "name = \"\"")], &format!("phase[0].name = \"\": {why}"));
}

const CASE_2D: &str = r#"
[simulation]
dimension = "2"
timestep = 5e-6
gravity = [0.0, -9.81, 0.0]
domain = { lo = [-0.02, -0.02, -0.001], hi = [0.02, 0.02, 0.001] }

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
list = [ { id = 1, position = [0.0, 0.0021, 0.0], radius = 0.002 } ]

[[wall]]
name = "floor"
material = "m"
plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0] }

[[phase]]
name = "fall"
duration = 0.001
"#;

fn expect_2d(a: &str, b: &str, msg: &str) {
    assert!(CASE_2D.contains(a));
    assert_eq!(refused(&CASE_2D.replacen(a, b, 1), &[]), format!("talus: error: DIR/bad.toml: {msg}\n"));
}

#[test]
fn in_2d_gravity_wall_normals_and_wall_velocities_along_z_are_refused() {
    accepted(CASE_2D, &[], &[]);
    expect_2d(
        "gravity = [0.0, -9.81, 0.0]",
        "gravity = [0.0, -9.81, -1.0]",
        "simulation.gravity = [0.0, -9.81, -1.0]: in 2D (simulation.dimension = \"2\") gravity lies in the x-y plane (z component 0)",
    );
    expect_2d(
        "normal = [0.0, 1.0, 0.0]",
        "normal = [0.0, 1.0, 0.5]",
        "wall.floor.plane.normal = [0.0, 1.0, 0.5]: in 2D a wall's normal lies in the x-y plane (z component 0)",
    );
    expect_2d(
        "normal = [0.0, 1.0, 0.0] }",
        "normal = [0.0, 1.0, 0.0] }\nvelocity = [0.0, 0.0, 0.1]",
        "wall.floor.velocity = [0.0, 0.0, 0.1]: in 2D a wall moves in the x-y plane (z component 0)",
    );
}

fn with_csv(csv: &str) -> String {
    let case = case_text("SC-wall.toml", &[(SPHERE, "csv = \"cloud.csv\"")]);
    refused(&case, &[("cloud.csv", csv.as_bytes())])
}

#[test]
fn particle_csv_with_part_of_a_vector_or_a_repeated_column_is_refused() {
    assert_eq!(
        with_csv("id,x,y,z,radius,vx,vy\n1,0,0,0.0021,0.002,0,0\n"),
        "talus: error: DIR/cloud.csv, line 1: the header has `vx`, `vy` but not `vz`: give all of vx,vy,vz or none\n"
    );
    assert_eq!(
        with_csv("id,x,y,z,radius,wz\n1,0,0,0.0021,0.002,5\n"),
        "talus: error: DIR/cloud.csv, line 1: the header has `wz` but not `wx`, `wy`: give all of wx,wy,wz or none\n"
    );
    assert_eq!(
        with_csv("id,x,y,z,radius,x\n1,0,0,0.0021,0.002,0\n"),
        "talus: error: DIR/cloud.csv, line 1: column `x` appears twice (column 6)\n"
    );
    // all three, or none, are fine
    let case = case_text("SC-wall.toml", &[(SPHERE, "csv = \"cloud.csv\"")]);
    accepted(&case, &[("cloud.csv", b"id,x,y,z,radius,vx,vy,vz\n1,0,0,0.0021,0.002,0,0,-0.5\n")], &["--steps", "1"]);
}

#[test]
fn empty_particle_sets_are_refused() {
    expect("SC-wall.toml", &[(SPHERE, "list = []")], "particles.list = []: no particles; give at least one (or insert them in a phase)");
    expect("H1-small.toml", &[("count = 5000", "count = 0")], "particles.lattice.count = 0: no particles; give at least one");
    assert_eq!(with_csv("id,x,y,z,radius\n"), "talus: error: DIR/cloud.csv: no particles in the file\n");
}

#[test]
fn a_particle_overlapping_a_wall_or_behind_a_plane_at_the_start_is_refused() {
    let msg = "particle id 1 overlaps wall \"plate\" by 1.0000e-4 m initially, more than particles.overlap_tolerance = 0.001 of its radius 2.0000e-3 m";
    expect("SC-wall.toml", &[("position = [0.0, 0.0, 0.0021]", "position = [0.0, 0.0, 0.0019]")], msg);
    expect(
        "SC-wall.toml",
        &[("position = [0.0, 0.0, 0.0021]", "position = [0.0, 0.0, -0.0005]")],
        "particle id 1 at [0.0, 0.0, -0.0005] is behind the plane wall \"plate\" (signed distance -5.0000e-4 m; planes are one-sided: particles live on the side the normal [0.0, 0.0, 1.0] points to)",
    );
    // a mesh wall likewise
    let stl = square_stl(0.0, None);
    let mesh = case_text("SC-wall.toml", &[(PLATE, "stl = \"square.stl\""), (COLLISION, ""), ("0.0021]", "0.0019]")]);
    assert_eq!(refused(&mesh, &[("square.stl", stl.as_bytes())]), format!("talus: error: DIR/bad.toml: {msg}\n"));
    // within a larger tolerance the same start is accepted
    let tolerant = case_text(
        "SC-wall.toml",
        &[("position = [0.0, 0.0, 0.0021]", "position = [0.0, 0.0, 0.0019]"), ("material = \"seed-soft\"\nlist", "material = \"seed-soft\"\noverlap_tolerance = 0.1\nlist")],
    );
    accepted(&tolerant, &[], &["--steps", "1"]);
}

#[test]
fn non_finite_wall_velocity_and_gravity_are_refused() {
    expect(
        "SC-wall.toml",
        &[(PLATE, &format!("{PLATE}\nvelocity = [nan, 0.0, 0.0]"))],
        "wall.plate.velocity = [NaN, 0.0, 0.0]: every component must be a finite number (m/s)",
    );
    expect(
        "SC-wall.toml",
        &[("gravity = [0.0, 0.0, 0.0]", "gravity = [0.0, 0.0, -inf]")],
        "simulation.gravity = [0.0, 0.0, -inf]: every component must be a finite number (m/s^2)",
    );
}

#[test]
fn bad_fractions_intervals_and_tolerances_are_refused() {
    expect(
        "H1-small.toml",
        &[("kinetic_energy_fraction = 1e-6", "kinetic_energy_fraction = -1e-6")],
        "phase.fill.kinetic_energy_fraction = -0.000001: must be a fraction >= 0",
    );
    for (v, shown) in [("0.0", "0"), ("-1e-5", "-0.00001"), ("inf", "inf"), ("nan", "NaN")] {
        expect("SC-wall.toml", &[("interval = 1e-5", &format!("interval = {v}"))], &format!("output.interval = {shown}: must be a positive time (s)"));
    }
    expect(
        "H1-small.toml",
        &[("snapshot_interval = 0.1", "snapshot_interval = -0.1")],
        "output.snapshot_interval = -0.1: must be a positive time (s)",
    );
    expect(
        "SC-wall.toml",
        &[("interval = 1e-5", "interval = 1e-5\ncheckpoint_interval = 0.0")],
        "output.checkpoint_interval = 0: must be a positive time (s)",
    );
    for (v, shown) in [("nan", "NaN"), ("-0.1", "-0.1")] {
        expect(
            "SC-wall.toml",
            &[("material = \"seed-soft\"\nlist", &format!("material = \"seed-soft\"\noverlap_tolerance = {v}\nlist"))],
            &format!("particles.overlap_tolerance = {shown}: must be a fraction >= 0 of the radius"),
        );
    }
}

#[test]
fn a_lattice_upside_down_and_a_grid_whose_product_overflows_are_refused() {
    expect(
        "H1-small.toml",
        &[("hi_xy = [0.046, 0.046]", "hi_xy = [0.046, -0.05]")],
        "particles.lattice.hi_xy = [0.046, -0.05]: must lie above lo = [-0.046, -0.046, 0.06] in x and in y",
    );
    expect(
        "shear-bed.toml",
        &[("balance = \"time\"", "grid = [4294967296, 4294967296, 2]\nbalance = \"time\"")],
        "parallel.grid = [4294967296, 4294967296, 2]: the product of the counts overflows; it must equal the number of MPI ranks",
    );
}

#[test]
fn a_negative_step_count_names_steps_and_the_value() {
    let text = case_text("SC-wall.toml", &[]);
    for v in ["-5", "ten"] {
        let (ok, err) = run_text(&text, &[], &["--steps", v]);
        assert!(!ok);
        assert_eq!(err, format!("talus: error: --steps {v}: must be a whole number of steps, 0 or more\n"));
    }
    accepted(&text, &[], &["--steps", "0"]);
}

#[test]
fn explicit_hooke_stiffness_whose_contact_spans_fewer_than_20_steps_is_refused_unless_forced() {
    let stiff = |kn: &str| format!("stiffness = {{ kn = {kn}, kt = {kn}, gamma_n = 0.0, gamma_t = 0.0 }}");
    let wall = [("characteristic_velocity = 0.5   # LIGGGHTS model hooke: kn, kt, gamma_n, gamma_t derived at V", stiff("1e9"))];
    let wall: Vec<(&str, &str)> = wall.iter().map(|(a, b)| (*a, b.as_str())).collect();
    // a sphere on a wall: m* = m = 8.3776e-5 kg, pi sqrt(m*/kn) = 9.0930e-7 s
    expect(
        "SC-wall-hooke.toml",
        &wall,
        "contact.stiffness.kn = 1000000000: the shortest contact lasts pi sqrt(m*/kn) = 9.0930e-7 s (m* = 8.3776e-5 kg, the lightest particle on a wall), 0.18 time steps of 5.0000e-6 s; at least 20 are needed (lower simulation.timestep or kn, or set simulation.force_timestep = true to run anyway)",
    );
    // two equal spheres: m* = m/2
    let pair = stiff("1e9");
    expect(
        "SC-pair-hooke.toml",
        &[("characteristic_velocity = 1.0   # relative impact speed; LIGGGHTS model hooke", &pair)],
        "contact.stiffness.kn = 1000000000: the shortest contact lasts pi sqrt(m*/kn) = 6.4298e-7 s (m* = 4.1888e-5 kg, the two lightest particles, m1 m2 / (m1 + m2)), 0.13 time steps of 5.0000e-6 s; at least 20 are needed (lower simulation.timestep or kn, or set simulation.force_timestep = true to run anyway)",
    );
    // forced, it runs; a stiffness whose contact spans 20 steps or more runs unforced
    let mut forced = wall.clone();
    forced.push(("timestep = 5e-6", "timestep = 5e-6\nforce_timestep = true"));
    accepted(&case_text("SC-wall-hooke.toml", &forced), &[], &["--steps", "1"]);
    let soft = stiff("400.0");
    accepted(&case_text("SC-wall-hooke.toml", &[(wall[0].0, soft.as_str())]), &[], &["--steps", "1"]);
}

#[test]
fn a_lattice_that_does_not_fit_its_region_or_the_memory_is_refused_before_it_is_made() {
    expect(
        "H1-small.toml",
        &[("count = 5000", "count = 20000")],
        "particles.lattice.count = 20000: 17 x 17 particles per layer at spacing 5.1700e-3 m need 70 layers, up to z = 4.2190e-1 m, above the top of the domain (simulation.domain.hi z = 0.32); at most 14450 fit",
    );
    // a domain tall enough for 1e12 particles: refused on memory, at once (nothing allocated)
    let t = std::time::Instant::now();
    let err = refused(
        &case_text("H1-small.toml", &[("count = 5000", "count = 1000000000000"), ("hi = [0.11, 0.11, 0.32]", "hi = [0.11, 0.11, 1.0e8]")]),
        &[],
    );
    let head = "talus: error: DIR/bad.toml: particles.lattice.count = 1000000000000: 1000000000000 particles need about 2.048e15 bytes of memory (2048 bytes per particle, a generous estimate), more than the ";
    assert!(err.starts_with(head) && err.ends_with(" in /proc/meminfo)\n") && err.contains(" bytes available (Mem"), "{err}");
    assert!(t.elapsed().as_secs_f64() < 10.0);
}

#[test]
fn an_ascii_stl_with_a_bad_number_names_the_line_and_a_short_binary_stl_names_both_sizes() {
    let case = case_text("SC-wall.toml", &[(PLATE, "stl = \"bad.stl\""), (COLLISION, "")]);
    for (vertex, tok) in [("vertex -0.01 -0.0x1 0", "-0.0x1"), ("vertex -0.01 nan 0", "nan"), ("vertex -0.01 -0.01 1e99", "1e99")] {
        let stl = square_stl(0.0, Some(vertex));
        assert_eq!(
            refused(&case, &[("bad.stl", stl.as_bytes())]),
            format!("talus: error: DIR/bad.stl, line 4: `{tok}` is not a finite number (in `vertex x y z`)\n")
        );
    }
    let stl = square_stl(0.0, None).replace("endloop\nendfacet\nfacet", "endloop\nfacet");
    assert_eq!(
        refused(&case, &[("bad.stl", stl.as_bytes())]),
        "talus: error: DIR/bad.stl: not a readable STL file (ASCII or binary): expected [\"endfacet\"], got [\"facet\", \"normal\", \"0\", \"0\", \"1\"]\n"
    );
    // binary: 84-byte header with 3 facets, but only 2 facets of 50 bytes follow
    let mut bin = vec![0u8; 80];
    bin.extend(3u32.to_le_bytes());
    bin.extend(vec![0u8; 100]);
    assert_eq!(
        refused(&case, &[("bad.stl", &bin)]),
        "talus: error: DIR/bad.stl: binary STL: the header says 3 facets, which take 84 + 50 x 3 = 234 bytes, but the file has 184 bytes\n"
    );
}

#[test]
fn every_shipped_case_and_drag_bed_passes_the_input_checks() {
    let mut n = 0;
    for e in std::fs::read_dir(cases_dir()).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            let c = talus::case::Case::load(&p).unwrap_or_else(|e| panic!("{e}"));
            talus::sim::Simulation::new(c).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 9);
    for e in std::fs::read_dir(cases_dir().join("drag")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "toml") {
            continue; // golden/: the regression's golden files
        }
        let dc = talus::drag::DragCase::load(&p).unwrap_or_else(|e| panic!("{e}"));
        for &seed in &dc.drag.seeds {
            let (case, _) = dc.bed_case(seed).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            talus::sim::Simulation::new(case).unwrap_or_else(|e| panic!("{} seed {seed}: {e}", p.display()));
        }
    }
}

#[test]
fn a_case_giving_two_or_none_of_a_choice_names_the_line_and_what_it_gave() {
    for (edit, msg) in [
        (
            ("timestep = 5e-6", "timestep = 5e-6\ntimestep_rayleigh_fraction = 0.1"),
            "simulation: timestep = 0.000005 and timestep_rayleigh_fraction = 0.1: give exactly one of simulation.timestep and simulation.timestep_rayleigh_fraction",
        ),
        (
            (SPHERE, "csv = \"x.csv\"\nlist = []"),
            "particles: 2 particle sources: give exactly one of particles.csv, particles.lattice, particles.list",
        ),
        (
            (PLATE, "stl = \"a.stl\"\nplane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }"),
            "wall.plate: shapes given: [plane, stl]: give exactly one of plane, stl, disc, segment and box",
        ),
    ] {
        let err = refused(&case_text("SC-wall.toml", &[edit]), &[]);
        assert!(err.starts_with("talus: error: DIR/bad.toml, line ") && err.ends_with(&format!(": {msg}\n")), "{err}");
    }
}

#[test]
fn bad_cohesion_is_refused_naming_the_key_and_the_value() {
    let coh = |v: &str| case_text("SC-cohesive-sjkr.toml", &[("cohesion = { model = \"sjkr\", energy_density = 3.0e4 }", v)]);
    let bad = |v: &str, msg: &str| {
        assert_eq!(refused(&coh(v), &[]), format!("talus: error: DIR/bad.toml: {msg}\n"), "{v}");
    };
    bad(
        "cohesion = { model = \"sjkr\", energy_density = -1.0 }",
        "contact.cohesion.energy_density = -1: the cohesion energy density must be a finite number of J/m^3, 0 or more",
    );
    // a key the cohesion model does not read, and a model it does not know
    let err = refused(&coh("cohesion = { model = \"sjkr\", energy_density = 3.0e4, surface_energy = 0.1 }"), &[]);
    assert!(err.contains("DIR/bad.toml") && err.contains("surface_energy"), "{err}");
    let err = refused(&coh("cohesion = { model = \"jkr2\", energy_density = 3.0e4 }"), &[]);
    assert!(err.contains("DIR/bad.toml") && err.contains("jkr2") && err.contains("sjkr2"), "{err}");
    // in 2D: the area is that of two overlapping spheres
    let two_d = CASE_2D.replacen("[contact]\n", "[contact]\ncohesion = { model = \"sjkr2\", energy_density = 1.0e4 }\n", 1);
    assert!(two_d != CASE_2D);
    assert_eq!(
        refused(&two_d, &[]),
        "talus: error: DIR/bad.toml: contact.cohesion.model = \"sjkr2\": cohesion acts between spheres (3D, no clumps, no ellipses): its contact area is that of two overlapping spheres\n"
    );
}

#[test]
fn a_comparison_of_no_replicas_is_refused() {
    expect("SC-pair.toml", &[("replicas = 1 ", "replicas = 0 ")], "compare.replicas = 0: must be 1 or more (1: single runs compared step by step)");
}

#[test]
fn a_collision_with_itself_and_a_dimension_of_4_name_the_value() {
    expect(
        "SC-pair.toml",
        &[("partner = 2", "partner = 1")],
        "analysis.partner = 1: the partner is the particle itself (analysis.particle = 1); name another particle, or a wall",
    );
    for (given, shown) in [("4", "4"), ("\"4\"", "\"4\"")] {
        let text = case_text("SC-wall.toml", &[("[simulation]\n", &format!("[simulation]\ndimension = {given}\n"))]);
        let err = refused(&text, &[]);
        assert!(err.starts_with("talus: error: DIR/bad.toml, line ") && err.contains(&format!("dimension = {shown}: must be 2 (a run in the x-y plane) or 3")), "{err}");
    }
    // 2 and 3 as numbers, as in the strings the files have written so far
    accepted(&case_text("SC-wall.toml", &[("[simulation]\n", "[simulation]\ndimension = 3\n")]), &[], &["--steps", "1"]);
}

#[test]
fn a_run_that_makes_energy_from_nothing_stops_with_a_checkpoint_naming_the_step_and_the_energy() {
    // SC-wall with a step of 3 Rayleigh times, forced: the sphere is kicked out of the plate
    // with 600 times its kinetic energy, and nothing (no gravity, no moving wall) gave it that
    let text = case_text("SC-wall.toml", &[("timestep = 5e-6", "timestep = 1.6e-3\nforce_timestep = true"), ("duration = 0.004", "duration = 0.5"),
        ("domain = { lo = [-0.01, -0.01, -0.001], hi = [0.01, 0.01, 0.01] }", "domain = { lo = [-1.0, -1.0, -1.0], hi = [1.0, 1.0, 1.0] }")]);
    let (ok, err) = run_text(&text, &[], &[]);
    assert!(!ok, "{err}");
    assert!(err.contains("run stopped at step 20 ") && err.contains("the kinetic energy grew to 6.3665e-3 J, more than 100 times what the case can give"), "{err}");
    assert!(err.contains("checkpoint of all ranks written to DIR/out/failure_checkpoint.bin"), "{err}");
}

#[test]
fn a_drag_study_too_large_for_the_memory_is_refused_before_it_is_made() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(cases_dir().join("drag/c1.toml")).unwrap().replace("[drag]\n", "[drag]\ncount = 1000000000\n");
    let case = d.path().join("huge.toml");
    std::fs::write(&case, text).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_talus")).args(["drag", case.to_str().unwrap(), "--out", d.path().join("o").to_str().unwrap()]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).replace(&d.path().display().to_string(), "DIR");
    assert!(!o.status.success());
    assert!(err.starts_with("talus: error: DIR/huge.toml: drag.count = 1000000000: ") && err.contains("granules need about") && err.contains("bytes of memory"), "{err}");
}
