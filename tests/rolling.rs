//! Rolling resistance (`contact.rolling = "cdt"`, a constant directional
//! torque mu_r F_n R against the rolling spin, LIGGGHTS `rolling_friction cdt`;
//! `"epsd2"`, an elastic-plastic rolling spring capped at the same torque,
//! LIGGGHTS `rolling_friction epsd2`): a sphere rolling on a plane decelerates
//! and stops as the closed form says; under epsd2 a sphere on a slope gentler
//! than its rolling friction holds still, on a steeper one it rolls down as the
//! closed form says; the rolling spring's torque survives a checkpoint.

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
    rolling_sphere_tilted(mu_r, rolling, 0.0, V0)
}

/// As [`rolling_sphere`], with gravity tilted by `slope` (rad) towards +x (a
/// floor inclined at that angle) and the sphere rolling at v0.
fn rolling_sphere_tilted(mu_r: f64, rolling: Option<RollingModel>, slope: f64, v0: f64) -> Simulation {
    let m = material(mu_r);
    let d = static_overlap(&m);
    let c = R - 0.5 * d;
    let case = CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::Seconds(5e-6))
        .gravity([G * slope.sin(), 0.0, -G * slope.cos()])
        .domain([-0.01, -0.01, -0.01], [0.1, 0.01, 0.01])
        .contact(ContactSection { convention: Convention::Liggghts, rolling, ..ContactSection::new(ModelName::Hertz) })
        .material(m)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, R - d], R).moving([v0, 0.0, 0.0]).spinning([0.0, v0 / c, 0.0])])
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
    // epsd2's spring winds up to its cap within a few steps of the start
    // (k_r = k_t r^2: a windup angle of 4e-5 rad), then brakes as cdt does;
    // once stopped it rocks on the spring (about 0.2% of V0)
    for (mu_r, law) in [(0.05, RollingModel::Cdt), (0.2, RollingModel::Cdt), (0.05, RollingModel::Epsd2), (0.2, RollingModel::Epsd2)] {
        let a = deceleration(mu_r);
        let (t_stop, s_stop) = (V0 / a, V0 * V0 / (2.0 * a));
        let mut sim = rolling_sphere(mu_r, Some(law));
        while sim.time() < 0.5 * t_stop {
            sim.step().unwrap();
        }
        let v = sim.particles().vel[0].x;
        let want = V0 - a * sim.time();
        assert!((v - want).abs() < 0.01 * V0, "{law:?} mu_r {mu_r}: v = {v} at t = {}, closed form {want}", sim.time());
        while sim.time() < 1.5 * t_stop {
            sim.step().unwrap();
        }
        let p = sim.particles();
        let x = p.pos[0].x;
        eprintln!("{law:?} mu_r {mu_r}: v(t_stop/2) {v:.6} (closed form {want:.6}); stopped at {x:.6} m (closed form {s_stop:.6}), v {:.2e}", p.vel[0].x);
        assert!((x - s_stop).abs() < 0.015 * s_stop, "{law:?} mu_r {mu_r}: stopped at x = {x}, closed form {s_stop}");
        assert!(p.vel[0].x.abs() < 0.01 * V0, "{law:?} mu_r {mu_r}: still moving at {} m/s", p.vel[0].x);
    }
}

#[test]
fn without_rolling_resistance_the_sphere_rolls_on() {
    // the same start with mu_r = 0 under cdt, and with the law off: no deceleration
    for (mu_r, rolling) in [(0.0, Some(RollingModel::Cdt)), (0.0, Some(RollingModel::Epsd2)), (0.0, None)] {
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

#[test]
fn under_epsd2_a_sphere_holds_on_a_slope_gentler_than_its_rolling_friction() {
    // placed at rest on a floor inclined by atan(0.1) with mu_r = 0.2: the
    // rolling spring holds the torque m g sin(a) c it needs (below its cap
    // mu_r m g cos(a) r); cdt, a torque only against a spin, chatters about
    // zero spin and creeps (reported, not checked)
    let slope = 0.1f64.atan();
    let mut sim = rolling_sphere_tilted(0.2, Some(RollingModel::Epsd2), slope, 0.0);
    while sim.time() < 0.2 {
        sim.step().unwrap();
    }
    let x = sim.particles().pos[0].x;
    // the spring's windup: theta = m g sin(a) c / k_r, a few 1e-5 rad; x = theta r
    assert!(x.abs() < 1e-6, "epsd2: the sphere crept {x} m down the slope");
    let mut sim = rolling_sphere_tilted(0.2, Some(RollingModel::Cdt), slope, 0.0);
    while sim.time() < 0.2 {
        sim.step().unwrap();
    }
    let x_cdt = sim.particles().pos[0].x;
    let mut sim = rolling_sphere_tilted(0.0, None, slope, 0.0);
    while sim.time() < 0.2 {
        sim.step().unwrap();
    }
    let x_free = sim.particles().pos[0].x;
    eprintln!("after 0.2 s on a slope of 0.1: epsd2 moved {x:.3e} m, cdt {x_cdt:.3e} m, no rolling law {x_free:.3e} m");
    // free: x = g sin(a) t^2 / 2 / (1 + I / (m c^2)) = 10 mm
    assert!(x_free > 5e-3, "free: moved only {x_free} m");
}

#[test]
fn under_epsd2_a_sphere_on_a_steeper_slope_rolls_down_as_the_closed_form_says() {
    // tan(a) = 0.3 > mu_r = 0.2: the spring sits at its cap mu_r N r and the
    // sphere rolls down: a = g (sin a - mu_r cos a r / c) / (1 + I / (m c^2))
    let slope = 0.3f64.atan();
    let mu_r = 0.2;
    // placed at the flat floor's overlap, the sphere first hops a little: the
    // acceleration is measured over [0.05, 0.1] s, the contact steady
    let mut sim = rolling_sphere_tilted(mu_r, Some(RollingModel::Epsd2), slope, 0.0);
    while sim.time() < 0.05 {
        sim.step().unwrap();
    }
    let (v1, t1) = (sim.particles().vel[0].x, sim.time());
    while sim.time() < 0.1 {
        sim.step().unwrap();
    }
    let got = (sim.particles().vel[0].x - v1) / (sim.time() - t1);
    let m = material(mu_r);
    // the static overlap under the normal part of gravity (sets the contact radius c)
    let mass = m.density * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let y = m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio * m.poisson_ratio));
    let d = (3.0 * mass * G * slope.cos() / (4.0 * y * R.sqrt())).powf(2.0 / 3.0);
    let c = R - 0.5 * d;
    let a = G * (slope.sin() - mu_r * slope.cos() * R / c) / (1.0 + 0.4 * R * R / (c * c));
    eprintln!("acceleration down the slope {got:.6} m/s^2, closed form {a:.6}");
    assert!((got - a).abs() < 1e-3 * a, "acceleration {got}, closed form {a}");
    // without the rolling law it rolls down faster, at g sin(a) / (1 + I / (m c^2))
    assert!(got < 0.4 * G * slope.sin() / 1.4);
}

#[test]
fn the_rolling_springs_torque_survives_a_checkpoint() {
    // a run stopped halfway, checkpointed and continued ends in the same bits
    // as one that ran straight through: the spring's torque is part of the
    // contact history (its loss would free the sphere for a step)
    let dir = std::env::temp_dir().join(format!("talus-epsd2-ck-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ck = dir.join("half.ckpt");
    let slope = 0.1f64.atan();
    let mut straight = rolling_sphere_tilted(0.2, Some(RollingModel::Epsd2), slope, 0.02);
    let mut first = rolling_sphere_tilted(0.2, Some(RollingModel::Epsd2), slope, 0.02);
    for _ in 0..2000 {
        straight.step().unwrap();
        first.step().unwrap();
    }
    talus::checkpoint::write(&first, &ck).unwrap_or_else(|e| panic!("{e}"));
    let mut resumed = rolling_sphere_tilted(0.2, Some(RollingModel::Epsd2), slope, 0.02);
    talus::checkpoint::read(&mut resumed, &ck).unwrap_or_else(|e| panic!("{e}"));
    for _ in 0..2000 {
        straight.step().unwrap();
        resumed.step().unwrap();
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(straight.state_hash(), resumed.state_hash());
    assert!(straight.particles().omega[0].norm() > 0.0);
}

