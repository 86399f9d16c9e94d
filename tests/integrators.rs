//! Integrators: energy conservation of an elastic frictionless gas, and the
//! measured order of convergence of Verlet and Gear.

mod common;
use common::*;
use std::path::Path;
use talus::builder::CaseBuilder;
use talus::case::{Case, ContactSection, ModelName, ParticleEntry, PhaseSection, TimeStep, WallSection};
use talus::contact::hooke::HookeExplicit;
use talus::dim::{Dimension, Vec3};
use talus::integrate::IntegratorKind;
use talus::material::Material;
use talus::sim::Simulation;

/// Material "m": E = 1e6 Pa, nu 0.3, rho 2500 kg/m^3, restitution `e`, friction `mu`.
fn material(e: f64, mu: f64) -> Material {
    Material { name: "m".into(), youngs_modulus: 1.0e6, poisson_ratio: 0.3, density: 2500.0, restitution: e, friction: mu, rolling_friction: 0.0 }
}

/// An elastic, frictionless gas of `n^3` spheres in a closed box of six planes.
fn gas_case(integrator: IntegratorKind, n: usize) -> Case {
    let mut list = Vec::new();
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let (x, y, z) = (-0.01 + 0.005 * i as f64, -0.01 + 0.005 * j as f64, -0.01 + 0.005 * k as f64);
                let v = [0.5 * rnd(), 0.5 * rnd(), 0.5 * rnd()];
                list.push(ParticleEntry::at(list.len() as u64 + 1, [x, y, z], 0.0015).moving(v));
            }
        }
    }
    let mut b = CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::Seconds(1e-5))
        .integrator(integrator)
        .domain([-0.02; 3], [0.02; 3])
        .contact(ContactSection::new(ModelName::Hertz))
        .material(material(1.0, 0.0))
        .particle_list("m", list)
        .phase(PhaseSection::new("run", 10.0));
    for (k, (p, nrm)) in [
        ([-0.0135, 0.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0135, 0.0, 0.0], [-1.0, 0.0, 0.0]),
        ([0.0, -0.0135, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0135, 0.0], [0.0, -1.0, 0.0]),
        ([0.0, 0.0, -0.0135], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 0.0135], [0.0, 0.0, -1.0]),
    ]
    .into_iter()
    .enumerate()
    {
        b = b.wall(WallSection::plane(&format!("w{k}"), "m", p, nrm));
    }
    b.build(Path::new("gas.toml")).unwrap()
}

/// Kinetic plus Hertz elastic energy 8/15 Y* sqrt(R*) delta^(5/2) of every contact.
fn total_energy(sim: &Simulation) -> f64 {
    let p = sim.particles();
    let y = E / (2.0 * (1.0 - NU * NU));
    let mut e = p.kinetic_energy();
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            let d = p.radius[i] + p.radius[j] - (p.pos[i] - p.pos[j]).norm();
            if d > 0.0 {
                let r = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
                e += 8.0 / 15.0 * y * r.sqrt() * d.powf(2.5);
            }
        }
        for w in sim.walls() {
            if let talus::walls::Shape::Plane(pl) = &w.shape {
                let d = p.radius[i] - pl.distance(&p.pos[i]);
                if d > 0.0 {
                    e += 8.0 / 15.0 * y * p.radius[i].sqrt() * d.powf(2.5);
                }
            }
        }
    }
    e
}

#[test]
fn elastic_gas_conserves_energy_over_100000_steps() {
    for integrator in [IntegratorKind::Verlet, IntegratorKind::Gear] {
        let mut sim = Simulation::new(gas_case(integrator, 5)).unwrap();
        sim.prepare().unwrap();
        let e0 = total_energy(&sim);
        let mut collisions = 0usize;
        for _ in 0..100_000 {
            sim.step().unwrap();
            collisions += sim.local_contacts();
        }
        let e1 = total_energy(&sim);
        let drift = (e1 - e0).abs() / e0;
        assert!(collisions > 100_000, "the gas must collide: {collisions} contact-steps");
        assert!(drift < 1e-4, "{integrator:?}: relative energy drift {drift:e}");
    }
}

/// A sphere oscillating on a linear undamped wall contact under gravity, never
/// leaving it: z(t) = z_eq + A cos(w t). Returns |z(T) - exact| for n steps.
fn oscillator_error(integrator: IntegratorKind, steps: usize) -> f64 {
    let kn = 100.0;
    let m = mass();
    let g = 9.81;
    let w = (kn / m).sqrt();
    // end away from a turning point, where the phase error shows at first order
    let t_end = 2.3 * 2.0 * std::f64::consts::PI / w;
    let dt = t_end / steps as f64;
    let z_eq = R - m * g / kn;
    let a = 5e-6;
    let stiffness = HookeExplicit { kn, kt: kn, gamma_n: 0.0, gamma_t: 0.0 };
    let case = CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::Seconds(dt))
        .gravity([0.0, 0.0, -g])
        .integrator(integrator)
        .domain([-0.01; 3], [0.01; 3])
        .contact(ContactSection { stiffness: Some(stiffness), ..ContactSection::new(ModelName::Hooke) })
        .material(material(1.0, 0.4))
        // it starts resting on the floor: overlap m g / kn - A = 0.0016 R
        .overlap_tolerance(0.01)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, z_eq + a], R)])
        .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
        .phase(PhaseSection::new("run", 1.0))
        .build(Path::new("osc.toml"))
        .unwrap();
    let mut sim = Simulation::new(case).unwrap();
    for _ in 0..steps {
        sim.step().unwrap();
    }
    let t = sim.time();
    let exact = Vec3::new(0.0, 0.0, z_eq + a * (w * t).cos());
    (sim.particles().pos[0] - exact).norm()
}

fn observed_order(integrator: IntegratorKind, base: usize) -> f64 {
    let errs: Vec<f64> = (0..4).map(|k| oscillator_error(integrator, base << k)).collect();
    // least-squares slope of log(error) against log(dt)
    let xs: Vec<f64> = (0..4).map(|k| -(k as f64) * 2f64.ln()).collect();
    let ys: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / 4.0, ys.iter().sum::<f64>() / 4.0);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    sxy / sxx
}

#[test]
fn verlet_is_second_order() {
    let p = observed_order(IntegratorKind::Verlet, 100);
    assert!((p - 2.0).abs() < 0.1, "velocity Verlet observed order {p}");
}

#[test]
fn gear_is_fifth_order() {
    let p = observed_order(IntegratorKind::Gear, 100);
    assert!((p - 5.0).abs() < 0.3, "Gear predictor-corrector observed order {p}");
}
