//! Integrators: energy conservation of an elastic frictionless gas, and the
//! measured order of convergence of Verlet and Gear.

mod common;
use common::*;
use talus::case::Case;
use talus::dim::Vec3;
use talus::sim::Simulation;

/// An elastic, frictionless gas of `n^3` spheres in a closed box of six planes.
fn gas_case(integrator: &str, n: usize) -> String {
    let mut list = String::new();
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    let mut id = 1;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let (x, y, z) = (-0.01 + 0.005 * i as f64, -0.01 + 0.005 * j as f64, -0.01 + 0.005 * k as f64);
                list.push_str(&format!(
                    "  {{ id = {id}, position = [{x}, {y}, {z}], velocity = [{}, {}, {}], radius = 0.0015 }},\n",
                    0.5 * rnd(),
                    0.5 * rnd(),
                    0.5 * rnd()
                ));
                id += 1;
            }
        }
    }
    let mut walls = String::new();
    for (k, (p, nrm)) in [
        ([-0.0135, 0.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0135, 0.0, 0.0], [-1.0, 0.0, 0.0]),
        ([0.0, -0.0135, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0135, 0.0], [0.0, -1.0, 0.0]),
        ([0.0, 0.0, -0.0135], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 0.0135], [0.0, 0.0, -1.0]),
    ]
    .iter()
    .enumerate()
    {
        walls.push_str(&format!(
            "[[wall]]\nname = \"w{k}\"\nmaterial = \"m\"\nplane = {{ point = {p:?}, normal = {nrm:?} }}\n\n"
        ));
    }
    format!(
        r#"
[simulation]
timestep = 1e-5
gravity = [0.0, 0.0, 0.0]
integrator = "{integrator}"
domain = {{ lo = [-0.02, -0.02, -0.02], hi = [0.02, 0.02, 0.02] }}

[contact]
model = "hertz"

[[material]]
name = "m"
youngs_modulus = 1.0e6
poisson_ratio = 0.3
density = 2500.0
restitution = 1.0
friction = 0.0

[particles]
material = "m"
list = [
{list}]

{walls}
[[phase]]
name = "run"
duration = 10.0
"#
    )
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
    for integrator in ["verlet", "gear"] {
        let text = gas_case(integrator, 5);
        let mut sim = Simulation::new(Case::parse(&text, std::path::Path::new("gas.toml")).unwrap()).unwrap();
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
        assert!(drift < 1e-4, "{integrator}: relative energy drift {drift:e}");
    }
}

/// A sphere oscillating on a linear undamped wall contact under gravity, never
/// leaving it: z(t) = z_eq + A cos(w t). Returns |z(T) - exact| for n steps.
fn oscillator_error(integrator: &str, steps: usize) -> f64 {
    let kn = 100.0;
    let m = mass();
    let g = 9.81;
    let w = (kn / m).sqrt();
    // end away from a turning point, where the phase error shows at first order
    let t_end = 2.3 * 2.0 * std::f64::consts::PI / w;
    let dt = t_end / steps as f64;
    let z_eq = R - m * g / kn;
    let a = 5e-6;
    let text = format!(
        r#"
[simulation]
timestep = {dt:e}
gravity = [0.0, 0.0, -{g}]
integrator = "{integrator}"
domain = {{ lo = [-0.01, -0.01, -0.01], hi = [0.01, 0.01, 0.01] }}
[contact]
model = "hooke"
stiffness = {{ kn = {kn}, kt = {kn}, gamma_n = 0.0, gamma_t = 0.0 }}
[[material]]
name = "m"
youngs_modulus = 1.0e6
poisson_ratio = 0.3
density = 2500.0
restitution = 1.0
friction = 0.4
[particles]
material = "m"
overlap_tolerance = 0.01   # it starts resting on the floor: overlap m g / kn - A = 0.0016 R
list = [ {{ id = 1, position = [0.0, 0.0, {z}], radius = {R} }} ]
[[wall]]
name = "floor"
material = "m"
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }}
[[phase]]
name = "run"
duration = 1.0
"#,
        z = z_eq + a
    );
    let mut sim = Simulation::new(Case::parse(&text, std::path::Path::new("osc.toml")).unwrap()).unwrap();
    for _ in 0..steps {
        sim.step().unwrap();
    }
    let t = sim.time();
    let exact = Vec3::new(0.0, 0.0, z_eq + a * (w * t).cos());
    (sim.particles().pos[0] - exact).norm()
}

fn observed_order(integrator: &str, base: usize) -> f64 {
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
    let p = observed_order("verlet", 100);
    assert!((p - 2.0).abs() < 0.1, "velocity Verlet observed order {p}");
}

#[test]
fn gear_is_fifth_order() {
    let p = observed_order("gear", 100);
    assert!((p - 5.0).abs() < 0.3, "Gear predictor-corrector observed order {p}");
}
