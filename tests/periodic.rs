//! Periodic boundaries (issue 14, part 1): a particle that leaves through one
//! face comes back through the other; pairs, contact history and walls act
//! across the faces, in 3D and 2D, and the result does not depend on where the
//! face is: each test runs the same motion once across a periodic face and once
//! in the middle of a domain without one, and compares.

mod common;

use talus::builder::CaseBuilder;
use talus::case::{Axis, ContactSection, ModelName, ParticleEntry, PhaseSection, TimeStep, WallSection};
use talus::contact::Convention;
use talus::dim::{Dimension, Vec3};
use talus::material::Material;
use talus::sim::Simulation;

const R: f64 = 0.001;

fn material(e: f64, mu: f64) -> Material {
    Material { name: "m".into(), youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500.0, restitution: e, friction: mu, rolling_friction: 0.0 }
}

fn builder(dim: Dimension, lo: [f64; 3], hi: [f64; 3], gravity: [f64; 3], e: f64, mu: f64) -> CaseBuilder {
    CaseBuilder::new(dim)
        .timestep(TimeStep::Seconds(2e-6))
        .gravity(gravity)
        .domain(lo, hi)
        .contact(ContactSection { convention: Convention::Liggghts, ..ContactSection::new(ModelName::Hertz) })
        .material(material(e, mu))
        .phase(PhaseSection::new("run", 1.0))
}

fn build(b: CaseBuilder) -> Result<Simulation, String> {
    b.build(std::path::Path::new("periodic.toml")).and_then(Simulation::new).map_err(|e| e.to_string())
}

fn run(sim: &mut Simulation, steps: usize) {
    for _ in 0..steps {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
    }
}

/// (position, velocity, spin) of particle `id`.
fn state(sim: &Simulation, id: u64) -> (Vec3, Vec3, Vec3) {
    let p = sim.particles();
    let i = p.index_of(id).unwrap();
    (p.pos[i], p.vel[i], p.omega[i])
}

/// `a` and `b` agree to `tol` (absolute, per component).
fn close(a: Vec3, b: Vec3, tol: f64, what: &str) {
    assert!((a - b).amax() <= tol, "{what}: {a:?} against {b:?} (tolerance {tol:e})");
}

/// x modulo the period [lo, lo + l).
fn wrapped(x: f64, lo: f64, l: f64) -> f64 {
    lo + (x - lo).rem_euclid(l)
}

#[test]
fn a_collision_across_a_periodic_face_is_the_collision_in_the_middle() {
    // two spheres meet head on (oblique, with spin from friction) across x = 0.02
    // in 3D and in 2D; the same pair placed in the middle of a domain without a
    // periodic face gives the same velocities and spins, and positions a period apart
    for dim in [Dimension::Three, Dimension::Two] {
        let (zlo, zhi) = if dim == Dimension::Two { (-0.001, 0.001) } else { (0.0, 0.02) };
        let z = if dim == Dimension::Two { 0.0 } else { 0.01 };
        let pair = |x1: f64, x2: f64| {
            vec![
                ParticleEntry::at(1, [x1, 0.0100, z], R).moving([0.3, 0.0, 0.0]),
                ParticleEntry::at(2, [x2, 0.0104, z], R).moving([-0.2, 0.0, 0.0]).spinning([0.0, 0.0, 5.0]),
            ]
        };
        // across the face: 1 just below hi, 2 just above lo
        let per = builder(dim, [0.0, 0.0, zlo], [0.02, 0.02, zhi], [0.0; 3], 0.5, 0.4)
            .periodic(&[Axis::X, Axis::Y])
            .particle_list("m", pair(0.0185, 0.0015));
        let mid = builder(dim, [-0.02, 0.0, zlo], [0.04, 0.02, zhi], [0.0; 3], 0.5, 0.4).particle_list("m", pair(0.0185, 0.0215));
        let (mut a, mut b) = (build(per).unwrap(), build(mid).unwrap());
        // 0.01 s: each sphere runs through the face, they collide across it and part
        run(&mut a, 5000);
        run(&mut b, 5000);
        for id in [1, 2] {
            let ((xa, va, wa), (xb, vb, wb)) = (state(&a, id), state(&b, id));
            close(va, vb, 1e-9, &format!("{dim:?}: velocity of {id}"));
            close(wa, wb, 1e-6, &format!("{dim:?}: spin of {id}"));
            let xb = Vec3::new(wrapped(xb.x, 0.0, 0.02), xb.y, xb.z);
            close(xa, xb, 1e-9, &format!("{dim:?}: position of {id} (modulo the period)"));
            assert!((0.0..0.02).contains(&xa.x), "{dim:?}: particle {id} is at x = {} outside [0, 0.02)", xa.x);
        }
        // they did collide: the pair's momentum is kept, its energy is not (e = 0.5)
        let (v1, v2) = (state(&a, 1).1, state(&a, 2).1);
        close(v1 + v2, Vec3::new(0.1, 0.0, 0.0), 1e-12, &format!("{dim:?}: momentum"));
        assert!(v1.x < 0.0, "{dim:?}: sphere 1 did not bounce back: {v1:?}");
    }
}

#[test]
fn a_sphere_sliding_across_a_periodic_face_keeps_its_floor_contact_history() {
    // a sphere slides and spins up on a frictional floor, crossing x = 0.01
    // ten times; its tangential spring to the floor is carried through each wrap,
    // so it rolls off at 5/7 of its speed (3D) as it does without a face
    let floor = || WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let s = || vec![ParticleEntry::at(1, [0.005, 0.01, R * 0.9999], R).moving([1.0, 0.0, 0.0])];
    let per = builder(Dimension::Three, [0.0, 0.0, 0.0], [0.01, 0.02, 0.02], [0.0, 0.0, -9.81], 0.5, 0.3)
        .periodic(&[Axis::X])
        .particle_list("m", s())
        .wall(floor());
    let long = builder(Dimension::Three, [0.0, 0.0, 0.0], [0.2, 0.02, 0.02], [0.0, 0.0, -9.81], 0.5, 0.3).particle_list("m", s()).wall(floor());
    let (mut a, mut b) = (build(per).unwrap(), build(long).unwrap());
    // 0.12 s: Coulomb sliding ends at t = 2 v0 / (7 mu g) = 0.097 s
    run(&mut a, 60000);
    run(&mut b, 60000);
    let ((xa, va, wa), (xb, vb, wb)) = (state(&a, 1), state(&b, 1));
    assert!(xb.x > 0.1, "the sphere must have crossed the face ten times: x = {}", xb.x);
    close(va, vb, 1e-9, "velocity");
    close(wa, wb, 1e-6, "spin");
    close(xa, Vec3::new(wrapped(xb.x, 0.0, 0.01), xb.y, xb.z), 1e-9, "position (modulo the period)");
    // rolling without slip: v = 5/7 of the start speed
    assert!((va.x - 5.0 / 7.0).abs() < 2e-3, "rolling speed {} against 5/7", va.x);
}

#[test]
fn a_wall_near_one_face_is_touched_from_across_it() {
    // a ball wall centred 1 mm inside x = 0; a sphere dropped from just inside
    // x = 0.02 lands on it through the face and rolls off down its far side:
    // the same as the sphere dropped at x = -0.0005 onto the ball in a domain without a face
    let ball = || WallSection::disc("ball", "m", [0.001, 0.01, 0.005], 0.004);
    let drop = |x: f64| vec![ParticleEntry::at(1, [x, 0.01, 0.0102], R)];
    let per = builder(Dimension::Three, [0.0, 0.0, 0.0], [0.02, 0.02, 0.02], [0.0, 0.0, -9.81], 0.5, 0.3)
        .periodic(&[Axis::X])
        .particle_list("m", drop(0.0195))
        .wall(ball());
    let open = builder(Dimension::Three, [-0.02, 0.0, 0.0], [0.02, 0.02, 0.02], [0.0, 0.0, -9.81], 0.5, 0.3)
        .particle_list("m", drop(-0.0005))
        .wall(ball());
    let (mut a, mut b) = (build(per).unwrap(), build(open).unwrap());
    run(&mut a, 15000);
    run(&mut b, 15000);
    let ((xa, va, _), (xb, vb, _)) = (state(&a, 1), state(&b, 1));
    assert!(vb.x < -0.05, "the sphere must roll off the ball towards -x: v = {vb:?}");
    close(va, vb, 1e-9, "velocity");
    close(xa, Vec3::new(wrapped(xb.x, 0.0, 0.02), xb.y, xb.z), 1e-9, "position (modulo the period)");
    // the ball felt the sphere: the same load in both
    let (fa, fb) = (a.walls()[0].force, b.walls()[0].force);
    close(fa, fb, 1e-9, "ball load");
}

#[test]
fn bad_periodic_input_is_refused_naming_the_key() {
    let two = |axes: &[Axis]| {
        builder(Dimension::Two, [0.0, 0.0, -0.001], [0.02, 0.02, 0.001], [0.0; 3], 0.5, 0.3)
            .periodic(axes)
            .particle_list("m", vec![ParticleEntry::at(1, [0.01, 0.01, 0.0], R)])
    };
    let e = build(two(&[Axis::Z])).err().unwrap();
    assert!(e.contains("simulation.domain.periodic") && e.contains("x-y plane"), "{e}");
    let e = build(two(&[Axis::X, Axis::X])).err().unwrap();
    assert!(e.contains("simulation.domain.periodic") && e.contains("twice"), "{e}");
    let e = build(two(&[Axis::X]).wall(WallSection::plane("cut", "m", [0.001, 0.0, 0.0], [1.0, 0.0, 0.0]))).err().unwrap();
    assert!(e.contains("wall.cut.normal") && e.contains("parallel"), "{e}");
    // two spheres that overlap across the face at the start
    let across = builder(Dimension::Two, [0.0, 0.0, -0.001], [0.02, 0.02, 0.001], [0.0; 3], 0.5, 0.3)
        .periodic(&[Axis::X])
        .particle_list("m", vec![ParticleEntry::at(1, [0.0005, 0.01, 0.0], R), ParticleEntry::at(2, [0.0195, 0.01, 0.0], R)]);
    let e = build(across).err().unwrap();
    assert!(e.contains("particles 1 and 2 overlap"), "{e}");
    // a period no longer than twice the neighbour reach
    let short = builder(Dimension::Two, [0.0, 0.0, -0.001], [0.004, 0.02, 0.001], [0.0; 3], 0.5, 0.3)
        .periodic(&[Axis::X])
        .particle_list("m", vec![ParticleEntry::at(1, [0.002, 0.01, 0.0], R)]);
    let e = build(short).err().unwrap();
    assert!(e.contains("simulation.domain.periodic") && e.contains("along x") && e.contains("4.0000e-3"), "{e}");
}

#[test]
fn a_cooling_granular_gas_follows_haffs_law() {
    // cases/cooling.toml: 1000 frictionless spheres (radius 1 mm, rho 2500,
    // e = 0.9) in a 35 mm box periodic along all three axes. Haff: dT/dt = -A T^(3/2),
    // so 1/sqrt(T) rises linearly at A/2, A = (4 sqrt(pi) / 3) (1 - e^2) n sigma^2
    // g0 / sqrt(m), g0 = (1 - phi/2) / (1 - phi)^3 (Enskog, Carnahan-Starling);
    // T = (2/3) E_kin / N. Measured: 0.962 of A/2 (soft contacts last a few
    // percent of the time between collisions), straight to R^2 = 0.9998
    let mut sim = common::sim("cooling.toml", |_| {});
    let (n, r, rho, l, e) = (1000.0, 1e-3, 2500.0, 0.035, 0.9);
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    let phi = n * 4.0 / 3.0 * std::f64::consts::PI * r * r * r / (l * l * l);
    let g0 = (1.0 - phi / 2.0) / (1.0 - phi).powi(3);
    let a = 4.0 * std::f64::consts::PI.sqrt() / 3.0 * (1.0 - e * e) * (n / (l * l * l)) * (2.0 * r) * (2.0 * r) * g0 / m.sqrt();
    let dt = sim.dt();
    let (mut t, mut y) = (Vec::new(), Vec::new());
    let mass_speed = (n * m) * 0.5; // total mass times the start's speed per component (kg m/s)
    while sim.time() < 0.25 {
        sim.step().unwrap();
        let k = sim.step_count();
        if k % ((0.005 / dt) as u64) == 0 && sim.time() >= 0.02 {
            t.push(sim.time());
            y.push(1.0 / (2.0 / 3.0 * sim.kinetic_energy() / n).sqrt());
            let p = sim.momentum();
            assert!(p.norm() < 1e-12 * mass_speed, "momentum {p:?} at t = {}", sim.time());
        }
    }
    // least squares line through (t, 1/sqrt(T))
    let k = t.len() as f64;
    let (mt, my) = (t.iter().sum::<f64>() / k, y.iter().sum::<f64>() / k);
    let sxy: f64 = t.iter().zip(&y).map(|(a, b)| (a - mt) * (b - my)).sum();
    let sxx: f64 = t.iter().map(|a| (a - mt) * (a - mt)).sum();
    let slope = sxy / sxx;
    let ss_res: f64 = t.iter().zip(&y).map(|(a, b)| (b - my - slope * (a - mt)).powi(2)).sum();
    let ss_tot: f64 = y.iter().map(|b| (b - my).powi(2)).sum();
    let r2 = 1.0 - ss_res / ss_tot;
    assert!(t.len() >= 40, "{} samples", t.len());
    assert!((slope / (a / 2.0) - 1.0).abs() < 0.08, "1/sqrt(T) rises at {slope:.4e}, Haff's law says {:.4e}", a / 2.0);
    assert!(r2 > 0.999, "1/sqrt(T) is not straight in t: R^2 = {r2}");
    // every particle is still inside the periodic box
    let p = sim.particles();
    assert!((0..p.owned()).all(|i| (0..3).all(|c| p.pos[i][c] >= 0.0 && p.pos[i][c] < l)));
}
