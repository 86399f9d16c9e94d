//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use talus::case::Case;
use talus::run::{run, RunOptions};
use talus::sim::Simulation;

pub fn cases_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("cases")
}

/// A case file's text with string replacements applied (each must match).
pub fn case_text(name: &str, edits: &[(&str, &str)]) -> String {
    let mut t = std::fs::read_to_string(cases_dir().join(name)).unwrap();
    for (a, b) in edits {
        assert!(t.contains(a), "{name} has no `{a}`");
        t = t.replacen(a, b, 1);
    }
    t
}

/// Write an edited copy of a case (and the hopper meshes) into `dir`.
pub fn write_case(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let m = dir.join("meshes");
    std::fs::create_dir_all(&m).unwrap();
    for f in ["hopper.stl", "box.stl"] {
        std::fs::copy(cases_dir().join("meshes").join(f), m.join(f)).unwrap();
    }
    let path = dir.join(name);
    std::fs::write(&path, case_text(name, edits)).unwrap();
    path
}

pub fn parse(name: &str, text: &str) -> Case {
    Case::parse(text, &cases_dir().join(name)).unwrap_or_else(|e| panic!("{e}"))
}

pub fn sim(name: &str, edits: &[(&str, &str)]) -> Simulation {
    Simulation::new(parse(name, &case_text(name, edits))).unwrap_or_else(|e| panic!("{e}"))
}

/// Run a case (with edits) to the end; returns summary.json as a map.
pub fn run_case(name: &str, edits: &[(&str, &str)]) -> serde_json::Map<String, serde_json::Value> {
    let dir = tempfile::tempdir().unwrap();
    let opts = RunOptions { out: dir.path().to_path_buf(), ..Default::default() };
    run(parse(name, &case_text(name, edits)), &opts).unwrap_or_else(|e| panic!("{e}")).summary
}

pub fn num(m: &serde_json::Map<String, serde_json::Value>, k: &str) -> f64 {
    m.get(k).and_then(|v| v.as_f64()).unwrap_or_else(|| panic!("summary has no number {k}: {m:?}"))
}

/// Hertz theory for an elastic impact at relative speed v: (peak overlap, duration, peak force).
/// Duration 2 (delta_max / v) int_0^1 (1 - x^(5/2))^(-1/2) dx = 2.943 delta_max / v.
pub fn hertz_theory(y: f64, r: f64, m: f64, v: f64) -> (f64, f64, f64) {
    let d = (15.0 * m * v * v / (16.0 * y * r.sqrt())).powf(0.4);
    // int_0^1 (1 - x^2.5)^-0.5 dx = B(2/5, 1/2) / (5/2) = Gamma(0.4) Gamma(0.5) / (2.5 Gamma(0.9))
    let integral = 2.218_159_543_757_688 * 1.772_453_850_905_516 / (2.5 * 1.068_628_702_119_319_3);
    (d, 2.0 * integral * d / v, 4.0 / 3.0 * y * r.sqrt() * d.powf(1.5))
}

pub const E: f64 = 1.0e6;
pub const NU: f64 = 0.3;
pub const RHO: f64 = 2500.0;
pub const R: f64 = 0.002;

/// Y* of two seed-soft bodies, and the mass of one 2 mm sphere.
pub fn y_eff() -> f64 {
    E / (2.0 * (1.0 - NU * NU))
}
pub fn mass() -> f64 {
    RHO * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3)
}

/// A 2D case: material (E = 1e9, nu 0.3, rho 3900, restitution `e`, friction
/// `mu`), the given particle list and extra lines, no gravity unless given.
pub fn case2d(e: f64, mu: f64, gravity: f64, particles: &str, extra: &str, dt: f64) -> Result<talus::sim::Simulation, String> {
    let t = format!(
        r#"
[simulation]
dimension = "2"
timestep = {dt:e}
gravity = [0.0, {g:e}, 0.0]
domain = {{ lo = [-0.05, -0.05, -0.001], hi = [0.05, 0.05, 0.001] }}

[contact]
model = "hertz"

[[material]]
name = "m"
youngs_modulus = 1.0e9
poisson_ratio = 0.3
density = 3900.0
restitution = {e}
friction = {mu}

[particles]
material = "m"
{particles}

{extra}

[[phase]]
name = "run"
duration = 1.0
"#,
        g = -gravity
    );
    talus::case::Case::parse(&t, &cases_dir().join("2d.toml"))
        .and_then(talus::sim::Simulation::new)
        .map_err(|e| e.to_string())
}
