//! Malformed input gets a clear error naming the file, the key or line, and the
//! value, and a non-zero exit; a run that goes wrong stops with a checkpoint and
//! names the particle.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

fn talus(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_talus")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).to_string())
}

/// Write a case (SC-wall with edits) into dir and run it; returns (success, stderr).
fn run_edited(dir: &Path, base: &str, edits: &[(&str, &str)]) -> (bool, String) {
    let case = dir.join("bad.toml");
    std::fs::write(&case, case_text(base, edits)).unwrap();
    let out = dir.join("out");
    talus(&["run", case.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"])
}

fn expect_error(base: &str, edits: &[(&str, &str)], needles: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    let (ok, err) = run_edited(d.path(), base, edits);
    assert!(!ok, "{edits:?} should fail");
    assert!(err.contains("bad.toml") || needles.iter().any(|n| n.ends_with(".stl") || n.ends_with(".csv")), "no file name in: {err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` missing from: {err}");
    }
}

#[test]
fn bad_toml_names_the_line() {
    expect_error("SC-wall.toml", &[("[contact]", "[contact\n")], &["line 11"]);
}

#[test]
fn unknown_key_is_refused() {
    expect_error("SC-wall.toml", &[("friction = 0.4", "friction = 0.4\nfrictoin = 0.5")], &["unknown field `frictoin`", "line"]);
}

#[test]
fn negative_radius_is_refused() {
    expect_error("SC-wall.toml", &[("radius = 0.002", "radius = -0.002")], &["particles.list[0].radius = -0.002"]);
}

#[test]
fn bad_material_value_names_key_and_value() {
    expect_error("SC-wall.toml", &[("poisson_ratio = 0.3", "poisson_ratio = 0.7")], &["poisson_ratio = 0.7", "[0, 0.5)"]);
}

#[test]
fn negative_radius_in_csv_names_file_line_and_value() {
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("cloud.csv");
    std::fs::write(&csv, "id,x,y,z,radius\n1,0,0,0.005,0.002\n2,0,0,0.001,-0.001\n").unwrap();
    let edits = [(
        "list = [ { id = 1, position = [0.0, 0.0, 0.0021], velocity = [0.0, 0.0, -0.5], radius = 0.002 } ]",
        &*format!("csv = \"{}\"", csv.display()),
    )];
    let (ok, err) = run_edited(d.path(), "SC-wall.toml", &edits);
    assert!(!ok);
    assert!(err.contains("cloud.csv, line 3") && err.contains("radius = -0.001"), "{err}");
}

#[test]
fn initial_overlap_is_refused() {
    expect_error(
        "SC-pair.toml",
        &[("position = [0.00205, 0.0, 0.0]", "position = [0.0019, 0.0, 0.0]")],
        &["particles 1 and 2 overlap", "overlap_tolerance"],
    );
}

#[test]
fn timestep_over_the_rayleigh_limit_is_refused_unless_forced() {
    expect_error("SC-wall.toml", &[("timestep = 5e-6", "timestep = 2e-4")], &["simulation.timestep = 2.0000e-4", "Rayleigh time", "30%"]);
    let d = tempfile::tempdir().unwrap();
    let (ok, err) = run_edited(
        d.path(),
        "SC-wall.toml",
        &[("timestep = 5e-6", "timestep = 2e-4\nforce_timestep = true")],
    );
    assert!(ok, "{err}");
}

#[test]
fn unreadable_and_degenerate_stl_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let garbage = d.path().join("garbage.stl");
    std::fs::write(&garbage, "solid x\nfacet nonsense\n").unwrap();
    let stl_edit = |p: &Path| {
        format!("stl = \"{}\"", p.display())
    };
    let e1 = stl_edit(&garbage);
    let (ok, err) = run_edited(d.path(), "SC-wall.toml", &[("plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }", &e1), ("[analysis]\nkind = \"collision\"\nparticle = 1\nwall = \"plate\"\n", "")]);
    assert!(!ok && err.contains("garbage.stl") && err.contains("not a readable STL"), "{err}");
    let degenerate = d.path().join("flat.stl");
    std::fs::write(
        &degenerate,
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n\
         facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 2 0 0\nendloop\nendfacet\nendsolid t\n",
    )
    .unwrap();
    let e2 = stl_edit(&degenerate);
    let (ok, err) = run_edited(d.path(), "SC-wall.toml", &[("plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }", &e2), ("[analysis]\nkind = \"collision\"\nparticle = 1\nwall = \"plate\"\n", "")]);
    // the facet's line and its number in the file (the second facet, at line 9)
    assert!(!ok && err.contains("flat.stl, line 9 (facet 2 of 2): the facet is degenerate (zero area)"), "{err}");
    let missing = d.path().join("missing.stl");
    let e3 = stl_edit(&missing);
    let (ok, err) = run_edited(d.path(), "SC-wall.toml", &[("plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }", &e3), ("[analysis]\nkind = \"collision\"\nparticle = 1\nwall = \"plate\"\n", "")]);
    assert!(!ok && err.contains("missing.stl"), "{err}");
}

#[test]
fn non_finite_input_is_refused() {
    expect_error("SC-wall.toml", &[("velocity = [0.0, 0.0, -0.5]", "velocity = [0.0, nan, -0.5]")], &["particles.list[0].velocity"]);
}

#[test]
fn particle_leaving_the_domain_stops_the_run_with_a_checkpoint() {
    let d = tempfile::tempdir().unwrap();
    // the wall moved below the domain: the sphere flies out through the bottom of the domain
    let (ok, err) = run_edited(
        d.path(),
        "SC-wall.toml",
        &[("velocity = [0.0, 0.0, -0.5]", "velocity = [0.0, 0.0, -5.0]"), ("point = [0.0, 0.0, 0.0]", "point = [0.0, 0.0, -1.0]")],
    );
    assert!(!ok);
    assert!(err.contains("particle id 1") && err.contains("left the domain") && err.contains("written to") && err.contains("failure_checkpoint.bin"), "{err}");
    assert!(d.path().join("out").join("failure_checkpoint.bin").exists());
}

#[test]
fn a_nan_during_a_run_stops_it_and_names_the_particle() {
    let mut sim = sim("SC-pair.toml", |_| {});
    sim.step().unwrap();
    let v = sim.particles().vel[1];
    sim.set_velocity(1, talus::dim::Vec3::new(f64::NAN, v.y, v.z));
    let err = sim.step().unwrap_err().to_string();
    assert!(err.contains("particle id 2") && err.contains("non-finite"), "{err}");
}
