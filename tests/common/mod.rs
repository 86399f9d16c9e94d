//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use talus::builder::CaseBuilder;
use talus::case::{Case, ContactSection, LatticeSection, ModelName, ParticleEntry, ParticleSource, PhaseSection, TimeStep, WallSection};
use talus::dim::Dimension;
use talus::material::Material;
use talus::run::{run, RunOptions};
use talus::sim::Simulation;

pub fn cases_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("cases")
}

/// A case file's text with string replacements applied (each must match): for
/// the tests of how a malformed file is reported. Valid changes go through
/// [`edited`] on the typed values.
pub fn case_text(name: &str, edits: &[(&str, &str)]) -> String {
    let mut t = std::fs::read_to_string(cases_dir().join(name)).unwrap();
    for (a, b) in edits {
        assert!(t.contains(a), "{name} has no `{a}`");
        t = t.replacen(a, b, 1);
    }
    t
}

/// A case of `cases/` with `edit` applied to its typed values, validated again
/// as a case file is.
pub fn edited(name: &str, edit: impl FnOnce(&mut Case)) -> Case {
    let path = cases_dir().join(name);
    let mut case = Case::load(&path).unwrap_or_else(|e| panic!("{e}"));
    edit(&mut case);
    CaseBuilder::from_case(case).build(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Write an edited copy of a case (and the hopper meshes) into `dir`.
pub fn write_case(dir: &Path, name: &str, edit: impl FnOnce(&mut Case)) -> PathBuf {
    let m = dir.join("meshes");
    std::fs::create_dir_all(&m).unwrap();
    for f in ["hopper.stl", "box.stl"] {
        std::fs::copy(cases_dir().join("meshes").join(f), m.join(f)).unwrap();
    }
    let path = dir.join(name);
    std::fs::write(&path, edited(name, edit).to_toml().unwrap()).unwrap();
    path
}

/// A case of `cases/` with `edit` applied, set up.
pub fn sim(name: &str, edit: impl FnOnce(&mut Case)) -> Simulation {
    Simulation::new(edited(name, edit)).unwrap_or_else(|e| panic!("{e}"))
}

/// Run a case (with `edit` applied) to the end; returns summary.json as a map.
pub fn run_case(name: &str, edit: impl FnOnce(&mut Case)) -> serde_json::Map<String, serde_json::Value> {
    let dir = tempfile::tempdir().unwrap();
    let opts = RunOptions { out: dir.path().to_path_buf(), ..Default::default() };
    run(edited(name, edit), &opts).unwrap_or_else(|e| panic!("{e}")).summary
}

/// The particles of a case given one by one (`particles.list`).
pub fn list(c: &mut Case) -> &mut Vec<ParticleEntry> {
    match &mut c.particles.source {
        ParticleSource::List(l) => l,
        s => panic!("particles given by {s:?}, not by a list"),
    }
}

/// The lattice of a case whose particles come from `particles.lattice`.
pub fn lattice(c: &mut Case) -> &mut LatticeSection {
    match &mut c.particles.source {
        ParticleSource::Lattice(l) => l,
        s => panic!("particles given by {s:?}, not by a lattice"),
    }
}

/// The wall of that name.
pub fn wall<'a>(c: &'a mut Case, name: &str) -> &'a mut WallSection {
    c.walls.iter_mut().find(|w| w.name == name).unwrap_or_else(|| panic!("no wall {name}"))
}

/// The phase of that name.
pub fn phase<'a>(c: &'a mut Case, name: &str) -> &'a mut PhaseSection {
    c.phases.iter_mut().find(|p| p.name == name).unwrap_or_else(|| panic!("no phase {name}"))
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

/// A 2D case (as `cases/2d.toml`): material "m" (E = 1e9 Pa, nu 0.3, rho 3900
/// kg/m^3, restitution `e`, friction `mu`), Hertz contact, gravity `gravity`
/// (m/s^2) along -y, time step `dt` (s), one phase "run" of 1 s. Add the particles
/// and walls, then set it up with [`sim2d`].
pub fn case2d(e: f64, mu: f64, gravity: f64, dt: f64) -> CaseBuilder {
    let m = Material { name: "m".into(), youngs_modulus: 1.0e9, poisson_ratio: 0.3, density: 3900.0, restitution: e, friction: mu, rolling_friction: 0.0 };
    CaseBuilder::new(Dimension::Two)
        .timestep(TimeStep::Seconds(dt))
        .gravity([0.0, -gravity, 0.0])
        .domain([-0.05, -0.05, -0.001], [0.05, 0.05, 0.001])
        .contact(ContactSection::new(ModelName::Hertz))
        .material(m)
        .phase(PhaseSection::new("run", 1.0))
}

/// Build a case (named `cases/2d.toml`) and set up its simulation; the error as text.
pub fn sim2d(b: CaseBuilder) -> Result<Simulation, String> {
    b.build(&cases_dir().join("2d.toml")).and_then(Simulation::new).map_err(|e| e.to_string())
}
