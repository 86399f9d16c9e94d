//! Two-dimensional runs (spheres moving in the x-y plane, as LIGGGHTS
//! `dimension 2`) and the rigid disc wall that the drag paper pulls through its bed.

mod common;
use common::*;

const DISC_CASE: &str = r#"
[simulation]
dimension = "2"
timestep = 5e-6
gravity = [0.0, 0.0, 0.0]
domain = { lo = [-0.02, -0.02, -0.001], hi = [0.02, 0.02, 0.001] }

[contact]
model = "hertz"
convention = "talus"

[[material]]
name = "m"
youngs_modulus = 1.0e6
poisson_ratio = 0.3
density = 2500.0
restitution = 0.5
friction = 0.4

[particles]
material = "m"
list = [ { id = 1, position = [0.0, 0.0, 0.0], radius = 0.002 } ]

# the drag paper's cylinder (diameter 3.175 mm), moving at 0.5 m/s along +x into the particle
[[wall]]
name = "cylinder"
material = "m"
disc = { center = [-0.00370, 0.0, 0.0], radius = 0.0015875 }
velocity = [0.5, 0.0, 0.0]

[[phase]]
name = "hit"
duration = 0.004

[output]
interval = 1e-5
track = [1]
"#;

fn disc_case(edits: &[(&str, &str)]) -> talus::sim::Simulation {
    let mut t = DISC_CASE.to_string();
    for (a, b) in edits {
        assert!(t.contains(a));
        t = t.replacen(a, b, 1);
    }
    let c = talus::case::Case::parse(&t, &cases_dir().join("disc.toml")).unwrap_or_else(|e| panic!("{e}"));
    talus::sim::Simulation::new(c).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_moving_disc_wall_throws_a_particle_off_with_restitution_e() {
    // in the frame of the (infinitely heavy) wall the particle comes in at -v and leaves at +e v:
    // in the lab frame it leaves at (1 + e) v
    for e in [0.2, 0.5, 0.8] {
        let mut sim = disc_case(&[("restitution = 0.5", &format!("restitution = {e}"))]);
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
    let mut sim = disc_case(&[("restitution = 0.5", "restitution = 1.0")]);
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
        ("position = [0.0, 0.0, 0.0]", "position = [0.0, 0.0, 0.0005]", "particle id 1"),
        ("velocity = [0.5, 0.0, 0.0]", "velocity = [0.5, 0.0, 0.1]", "wall.cylinder.velocity"),
    ];
    for (a, b, key) in bad {
        let t = DISC_CASE.replacen(a, b, 1);
        let err = talus::case::Case::parse(&t, &cases_dir().join("disc.toml"))
            .and_then(talus::sim::Simulation::new)
            .err()
            .unwrap_or_else(|| panic!("{b} accepted"))
            .to_string();
        assert!(err.contains(key) && err.contains("2D"), "{err}");
    }
}

/// Two 1 mm discs touching at the origin, joined as a dumbbell, spinning at
/// `spin` rad/s and moving at 0.1 m/s along x; no gravity, no walls.
fn dumbbell(spin: f64) -> talus::sim::Simulation {
    let parts = format!(
        r#"list = [
  {{ id = 1, position = [0.001, 0.0, 0.0], velocity = [0.1, {v}, 0.0], spin = [0.0, 0.0, {spin}], radius = 0.001 }},
  {{ id = 2, position = [-0.001, 0.0, 0.0], velocity = [0.1, {mv}, 0.0], spin = [0.0, 0.0, {spin}], radius = 0.001 }},
]
clumps = [[1, 2]]"#,
        v = spin * 0.001,
        mv = -spin * 0.001
    );
    case2d(0.5, 0.3, 0.0, &parts, "", 1e-6).unwrap_or_else(|e| panic!("{e}"))
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
    let wall = talus::walls::Wall {
        name: "w".into(),
        shape: talus::walls::Shape::Plane(talus::walls::Plane {
            point: talus::dim::Vec3::new(0.0025, 0.0, 0.0),
            normal: talus::dim::Vec3::new(-1.0, 0.0, 0.0),
        }),
        material: 0,
        velocity: talus::dim::Vec3::zeros(),
        active: true,
        remove_at: None,
        force: talus::dim::Vec3::zeros(),
        torque: talus::dim::Vec3::zeros(),
        load: [0; 6],
    };
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
