//! Rolling resistance (`contact.rolling = "cdt"`, a constant directional
//! torque mu_r F_n R against the rolling spin, LIGGGHTS `rolling_friction cdt`):
//! a sphere rolling on a plane decelerates and stops as the closed form says.

use talus::builder::CaseBuilder;
use talus::case::{ContactSection, ModelName, OutputSection, ParticleEntry, PhaseSection, RollingModel, TimeStep, WallSection};
use talus::contact::Convention;
use talus::dim::Dimension;
use talus::material::Material;
use talus::sim::Simulation;

const R: f64 = 0.002;
const V0: f64 = 0.1;
const G: f64 = 9.81;

fn material(mu_r: f64) -> Material {
    Material { name: "m".into(), youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500.0, restitution: 0.5, friction: 0.5, rolling_friction: mu_r }
}

/// The sphere's static overlap on the plane under its weight (Hertz, R* = r).
fn static_overlap(m: &Material) -> f64 {
    let mass = m.density * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let y = m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio * m.poisson_ratio));
    (3.0 * mass * G / (4.0 * y * R.sqrt())).powf(2.0 / 3.0)
}

/// A sphere resting on the plane z = 0 at its static overlap, rolling along +x
/// at V0 without slipping (spin V0 / c about y, c = r - delta/2 the contact radius).
fn rolling_sphere(mu_r: f64, rolling: Option<RollingModel>) -> Simulation {
    let m = material(mu_r);
    let d = static_overlap(&m);
    let c = R - 0.5 * d;
    let case = CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::Seconds(5e-6))
        .gravity([0.0, 0.0, -G])
        .domain([-0.01, -0.01, -0.01], [0.1, 0.01, 0.01])
        .contact(ContactSection { convention: Convention::Liggghts, rolling, ..ContactSection::new(ModelName::Hertz) })
        .material(m)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, R - d], R).moving([V0, 0.0, 0.0]).spinning([0.0, V0 / c, 0.0])])
        .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
        .phase(PhaseSection::new("roll", 1.0))
        .output(OutputSection { interval: 0.01, ..Default::default() })
        .build(std::path::Path::new("rolling.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    Simulation::new(case).unwrap_or_else(|e| panic!("{e}"))
}

/// Deceleration of a sphere rolling without slip (contact radius c) under the
/// rolling torque mu_r m g r: a = mu_r g r c / (I/m + c^2), I/m = 2/5 r^2
/// (5/7 mu_r g for c = r).
fn deceleration(mu_r: f64) -> f64 {
    let c = R - 0.5 * static_overlap(&material(mu_r));
    mu_r * G * R * c / (0.4 * R * R + c * c)
}

#[test]
fn a_rolling_sphere_decelerates_and_stops_where_the_closed_form_says() {
    for mu_r in [0.05, 0.2] {
        let a = deceleration(mu_r);
        let (t_stop, s_stop) = (V0 / a, V0 * V0 / (2.0 * a));
        let mut sim = rolling_sphere(mu_r, Some(RollingModel::Cdt));
        while sim.time() < 0.5 * t_stop {
            sim.step().unwrap();
        }
        let v = sim.particles().vel[0].x;
        let want = V0 - a * sim.time();
        assert!((v - want).abs() < 0.01 * V0, "mu_r {mu_r}: v = {v} at t = {}, closed form {want}", sim.time());
        while sim.time() < 1.5 * t_stop {
            sim.step().unwrap();
        }
        let p = sim.particles();
        let x = p.pos[0].x;
        eprintln!("mu_r {mu_r}: v(t_stop/2) {v:.6} (closed form {want:.6}); stopped at {x:.6} m (closed form {s_stop:.6}), v {:.2e}", p.vel[0].x);
        assert!((x - s_stop).abs() < 0.015 * s_stop, "mu_r {mu_r}: stopped at x = {x}, closed form {s_stop}");
        assert!(p.vel[0].x.abs() < 0.01 * V0, "mu_r {mu_r}: still moving at {} m/s", p.vel[0].x);
    }
}

#[test]
fn without_rolling_resistance_the_sphere_rolls_on() {
    // the same start with mu_r = 0 under cdt, and with the law off: no deceleration
    for (mu_r, rolling) in [(0.0, Some(RollingModel::Cdt)), (0.0, None)] {
        let mut sim = rolling_sphere(mu_r, rolling);
        while sim.time() < 0.2 {
            sim.step().unwrap();
        }
        let v = sim.particles().vel[0].x;
        assert!((v - V0).abs() < 1e-3 * V0, "v = {v}");
    }
}

#[test]
fn a_rolling_friction_without_a_rolling_law_is_refused_naming_the_key() {
    let m = material(0.1);
    let e = CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::Seconds(5e-6))
        .domain([-0.01, -0.01, -0.01], [0.1, 0.01, 0.01])
        .contact(ContactSection::new(ModelName::Hertz))
        .material(m)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, 0.005], R)])
        .phase(PhaseSection::new("roll", 0.01))
        .build(std::path::Path::new("rolling.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("materials.m.rolling_friction = 0.1") && e.contains("contact.rolling"), "{e}");
}
