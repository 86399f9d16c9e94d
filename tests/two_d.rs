//! Two-dimensional runs (spheres moving in the x-y plane, as LIGGGHTS
//! `dimension 2`) and the rigid disc wall that the drag paper pulls through its bed.

mod common;
use common::*;
use talus::builder::CaseBuilder;
use talus::case::{ContactSection, ModelName, OutputSection, ParticleEntry, PhaseSection, TimeStep, WallSection};
use talus::contact::Convention;
use talus::dim::Dimension;
use talus::material::Material;

/// One 2 mm particle at rest at the origin and the drag paper's cylinder
/// (diameter 3.175 mm) moving at 0.5 m/s along +x into it; material "m"
/// (E = 1e6 Pa, nu 0.3, rho 2500 kg/m^3, restitution `e`, friction 0.4).
fn disc_case(e: f64) -> CaseBuilder {
    let m = Material { name: "m".into(), youngs_modulus: 1.0e6, poisson_ratio: 0.3, density: 2500.0, restitution: e, friction: 0.4, rolling_friction: 0.0 };
    CaseBuilder::new(Dimension::Two)
        .timestep(TimeStep::Seconds(5e-6))
        .domain([-0.02, -0.02, -0.001], [0.02, 0.02, 0.001])
        .contact(ContactSection { convention: Convention::Talus, ..ContactSection::new(ModelName::Hertz) })
        .material(m)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, 0.0], 0.002)])
        .wall(WallSection::disc("cylinder", "m", [-0.00370, 0.0, 0.0], 0.0015875).moving([0.5, 0.0, 0.0]))
        .phase(PhaseSection::new("hit", 0.004))
        .output(OutputSection { interval: 1e-5, track: vec![1], ..Default::default() })
}

fn disc_sim(e: f64) -> talus::sim::Simulation {
    sim2d(disc_case(e)).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_moving_disc_wall_throws_a_particle_off_with_restitution_e() {
    // in the frame of the (infinitely heavy) wall the particle comes in at -v and leaves at +e v:
    // in the lab frame it leaves at (1 + e) v
    for e in [0.2, 0.5, 0.8] {
        let mut sim = disc_sim(e);
        while sim.time() < 0.004 {
            sim.step().unwrap();
        }
        let v = sim.particles().vel[0];
        assert!((v.x - (1.0 + e) * 0.5).abs() < 0.005 * 0.5, "e = {e}: v_out {v}");
        assert!(v.y.abs() < 1e-12 && v.z == 0.0, "head-on stays on the line of centres: {v}");
    }
}

#[test]
fn elastic_impact_on_the_disc_follows_hertz_with_the_curved_effective_radius() {
    let mut sim = disc_sim(1.0);
    let mut max_overlap: f64 = 0.0;
    let mut max_force: f64 = 0.0;
    while sim.time() < 0.004 {
        sim.step().unwrap();
        let w = &sim.walls()[0];
        let talus::walls::Shape::Disc(d) = &w.shape else { unreachable!() };
        max_overlap = max_overlap.max(0.002 + d.radius - (sim.particles().pos[0] - d.center).norm());
        max_force = max_force.max(w.force.norm());
    }
    // R* = r R / (r + R); the wall is rigid and infinitely heavy: m* = m
    let rw = 0.0015875;
    let r_eff = R * rw / (R + rw);
    let (d, _, f) = hertz_theory(y_eff(), r_eff, mass(), 0.5);
    assert!((max_overlap / d - 1.0).abs() < 0.01, "peak overlap {max_overlap} vs Hertz {d}");
    assert!((max_force / f - 1.0).abs() < 0.01, "peak force {max_force} vs Hertz {f}");
}

#[test]
fn two_d_input_out_of_the_plane_is_refused() {
    let bad = [
        (disc_case(0.5).particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, 0.0005], 0.002)]), "particle id 1"),
        (disc_case(0.5).wall(WallSection::disc("cylinder", "m", [-0.00370, 0.0, 0.0], 0.0015875).moving([0.5, 0.0, 0.1])), "wall.cylinder.velocity"),
    ];
    for (case, key) in bad {
        let err = sim2d(case).err().unwrap_or_else(|| panic!("{key} accepted"));
        assert!(err.contains(key) && err.contains("2D"), "{err}");
    }
}

/// Two 1 mm discs touching at the origin, joined as a dumbbell, spinning at
/// `spin` rad/s and moving at 0.1 m/s along x; no gravity, no walls.
fn dumbbell(spin: f64) -> talus::sim::Simulation {
    let list = vec![
        ParticleEntry::at(1, [0.001, 0.0, 0.0], 0.001).moving([0.1, spin * 0.001, 0.0]).spinning([0.0, 0.0, spin]),
        ParticleEntry::at(2, [-0.001, 0.0, 0.0], 0.001).moving([0.1, -spin * 0.001, 0.0]).spinning([0.0, 0.0, spin]),
    ];
    sim2d(case2d(0.5, 0.3, 0.0, 1e-6).particle_list("m", list).clumps(vec![[1, 2]])).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_free_dumbbell_moves_as_one_rigid_body() {
    let spin = 50.0;
    let mut sim = dumbbell(spin);
    for _ in 0..10_000 {
        sim.step().unwrap();
    }
    let p = sim.particles();
    let t = sim.time();
    // the lobes touch but never push each other: no contact, rigid distance, uniform motion
    assert_eq!(sim.local_contacts(), 0);
    assert!(((p.pos[0] - p.pos[1]).norm() - 0.002).abs() < 1e-12);
    let c = (p.pos[0] + p.pos[1]) * 0.5;
    assert!((c.x - 0.1 * t).abs() < 1e-12 && c.y.abs() < 1e-12, "centre {c}");
    let d = p.pos[0] - p.pos[1];
    let angle = d.y.atan2(d.x);
    let expect = (spin * t + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    assert!((angle - expect).abs() < 1e-9, "angle {angle} vs {expect}");
    assert!((p.omega[0].z - spin).abs() < 1e-12 && (p.vel[0] - p.vel[1]).norm() > 0.0);
}

#[test]
fn a_dumbbell_hitting_a_wall_with_one_lobe_starts_to_spin_and_keeps_its_shape() {
    // the same dumbbell, not spinning, now with a wall at x = 2.5 mm: its lobe 1
    // hits; momentum about the contact point turns into spin (torque about C)
    let mut sim = dumbbell(0.0);
    let wall = talus::walls::Wall::new(
        "w",
        talus::walls::Shape::Plane(talus::walls::Plane {
            point: talus::dim::Vec3::new(0.0025, 0.0, 0.0),
            normal: talus::dim::Vec3::new(-1.0, 0.0, 0.0),
        }),
        0,
    );
    sim.add_wall(wall);
    // tilt the dumbbell by 30 degrees so that only one lobe reaches the wall first
    sim.set_clump_angle(0, 30f64.to_radians());
    for _ in 0..10_000 {
        sim.step().unwrap();
    }
    let c = &sim.state().clumps;
    assert!(c.vel[0].x < 0.0, "bounced back: {}", c.vel[0]);
    assert!(c.omega[0].abs() > 1.0, "spins after an off-centre impact: {}", c.omega[0]);
    let p = sim.particles();
    assert!(((p.pos[0] - p.pos[1]).norm() - 0.002).abs() < 1e-12);
}
