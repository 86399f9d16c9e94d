//! Ellipses in the engine (2D) and straight segment walls: rigid-body impacts
//! against the impulse solution, restitution, rest on a floor, boxes.

mod common;
use common::*;
use talus::case::{EllipseEntry, ParticleEntry, WallSection};
use talus::dim::Vec3;

fn run(sim: &mut talus::sim::Simulation, steps: usize) {
    for _ in 0..steps {
        sim.step().unwrap();
    }
}

/// A wall at x = 3 mm facing -x.
fn wall_x() -> WallSection {
    WallSection::plane("w", "m", [0.003, 0.0, 0.0], [-1.0, 0.0, 0.0])
}

fn ellipse(id: u64, aspect_ratio: f64, angle: f64) -> EllipseEntry {
    EllipseEntry { id, aspect_ratio, angle }
}

#[test]
fn a_tilted_ellipse_hitting_a_frictionless_wall_follows_the_rigid_body_impulse_solution() {
    // a = 1.5 mm, b = 1 mm (equivalent radius sqrt(1.5) mm), major axis at 30 degrees,
    // moving at 0.1 m/s along +x into a wall; elastic and frictionless
    let (a, b, th) = (1.5e-3f64, 1.0e-3f64, 30f64.to_radians());
    let r = (a * b).sqrt();
    let case = case2d(1.0, 0.0, 0.0, 2e-8)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0015, 0.0, 0.0], r).moving([0.1, 0.0, 0.0])])
        .ellipses(vec![ellipse(1, a / b, th)])
        .wall(wall_x());
    let mut sim = sim2d(case).unwrap();
    run(&mut sim, 300_000);
    let p = sim.particles();
    assert!(sim.local_contacts() == 0, "contact over");
    // impulse solution: lever arm from the centre to the support point along +x
    let (s, c) = th.sin_cos();
    let (ax, ay) = (a * a * c * c + b * b * s * s, (a * a - b * b) * s * c); // A e_x
    let h = ax.sqrt();
    let ry = ay / h;
    let m = 3900.0 * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let inertia = 0.2 * m * (a * a + b * b);
    let j = 2.0 * 0.1 / (1.0 / m + ry * ry / inertia);
    let (vx, w) = (0.1 - j / m, ry * j / inertia);
    assert!((p.vel[0].x - vx).abs() < 0.01 * 0.1, "v_x {} vs impulse solution {vx}", p.vel[0].x);
    assert!((p.omega[0].z - w).abs() < 0.01 * w.abs(), "spin {} vs impulse solution {w}", p.omega[0].z);
    assert!(p.vel[0].y.abs() < 1e-9, "frictionless wall along x: no y velocity {}", p.vel[0].y);
    // energy conserved (elastic)
    let ke = 0.5 * m * p.vel[0].norm_squared() + 0.5 * inertia * p.omega[0].z.powi(2);
    assert!((ke / (0.5 * m * 0.01) - 1.0).abs() < 1e-3, "kinetic energy ratio {}", ke / (0.5 * m * 0.01));
}

#[test]
fn a_tilted_dumbbell_hitting_a_frictionless_wall_follows_the_rigid_body_impulse_solution() {
    // two 1 mm discs joined at C = 0, tilted 30 degrees, moving at 0.1 m/s into the wall
    let th = 30f64.to_radians();
    let (s, c) = th.sin_cos();
    let rl = 1.0e-3;
    let list = vec![
        ParticleEntry::at(1, [0.001 + rl * c, rl * s, 0.0], rl).moving([0.1, 0.0, 0.0]),
        ParticleEntry::at(2, [0.001 - rl * c, -rl * s, 0.0], rl).moving([0.1, 0.0, 0.0]),
    ];
    let mut sim = sim2d(case2d(1.0, 0.0, 0.0, 2e-8).particle_list("m", list).clumps(vec![[1, 2]]).wall(wall_x())).unwrap();
    run(&mut sim, 300_000);
    assert!(sim.local_contacts() == 0, "contact over");
    let m1 = 3900.0 * 4.0 / 3.0 * std::f64::consts::PI * rl.powi(3);
    let m = 2.0 * m1;
    let inertia = 2.0 * 0.4 * m1 * rl * rl + m * rl * rl;
    let ry = rl * s; // lever arm from C to the contact point, y part
    let j = 2.0 * 0.1 / (1.0 / m + ry * ry / inertia);
    let (vx, w) = (0.1 - j / m, ry * j / inertia);
    let cl = &sim.state().clumps;
    assert!((cl.vel[0].x - vx).abs() < 0.01 * 0.1, "v_x {} vs impulse solution {vx}", cl.vel[0].x);
    assert!((cl.omega[0] - w).abs() < 0.01 * w.abs(), "spin {} vs impulse solution {w}", cl.omega[0]);
}

#[test]
fn ellipses_meeting_tip_to_tip_rebound_with_restitution_e_and_no_spin() {
    for e in [0.3, 0.7] {
        let r = 1e-3;
        let list = vec![
            ParticleEntry::at(1, [-0.0013, 0.0, 0.0], r).moving([0.1, 0.0, 0.0]),
            ParticleEntry::at(2, [0.0013, 0.0, 0.0], r).moving([-0.1, 0.0, 0.0]),
        ];
        let case = case2d(e, 0.3, 0.0, 2e-8).particle_list("m", list).ellipses(vec![ellipse(1, 1.375, 0.0), ellipse(2, 1.375, 0.0)]);
        let mut sim = sim2d(case).unwrap();
        run(&mut sim, 200_000);
        let p = sim.particles();
        assert_eq!(sim.local_contacts(), 0);
        assert!((p.vel[1].x - 0.1 * e).abs() < 0.005 * 0.1, "e = {e}: v_out {}", p.vel[1].x);
        assert!(p.omega[0].z.abs() < 1e-9 && p.vel[0].y.abs() < 1e-12);
    }
}

#[test]
fn an_ellipse_rocking_on_its_flank_has_the_rolling_pendulum_period() {
    // a = 1.5 mm, b = 1 mm lying on a rough floor, tilted by 3 degrees and let go.
    // Rolling without slip about the contact point: the centre of curvature there
    // lies a^2 / b above the floor, the centre of mass b, so the metacentric
    // height is (a^2 - b^2) / b and omega^2 = g (a^2 - b^2) / b / (I / m + b^2).
    let (a, b) = (1.5e-3f64, 1.0e-3f64);
    let r = (a * b).sqrt();
    let th = 3f64.to_radians();
    let (s, c) = th.sin_cos();
    let reach = (a * a * s * s + b * b * c * c).sqrt();
    let dt = 2e-7;
    let case = case2d(0.3, 0.5, 9.81, dt)
        .particle_list("m", vec![ParticleEntry::at(1, [0.0, reach, 0.0], r)])
        .ellipses(vec![ellipse(1, a / b, th)])
        .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]));
    let mut sim = sim2d(case).unwrap();
    let mut crossings = Vec::new();
    let mut prev = sim.particles().angle[0];
    while crossings.len() < 3 && sim.time() < 0.3 {
        sim.step().unwrap();
        let ang = sim.particles().angle[0];
        if prev > 0.0 && ang <= 0.0 || prev < 0.0 && ang >= 0.0 {
            crossings.push(sim.time() - dt * ang / (ang - prev));
        }
        prev = ang;
    }
    assert_eq!(crossings.len(), 3, "rocks");
    let period = crossings[2] - crossings[0];
    let w2 = 9.81 * (a * a - b * b) / b / (0.2 * (a * a + b * b) + b * b);
    let expect = std::f64::consts::TAU / w2.sqrt();
    assert!((period / expect - 1.0).abs() < 0.02, "period {period} s vs rolling pendulum {expect} s");
    // it stays on its flank
    let p = sim.particles();
    assert!((p.pos[0].y - b).abs() < 0.01 * b, "height {} vs b = {b}", p.pos[0].y);
}

#[test]
fn a_disc_bounces_off_a_segment_face_with_e_and_off_its_end_along_the_centre_line() {
    let seg = WallSection::segment("s", "m", [-0.004, 0.0015, 0.0], [0.004, 0.0015, 0.0]);
    // face: straight up into the segment from below
    let parts = vec![ParticleEntry::at(1, [0.0, 0.0004, 0.0], 0.001).moving([0.0, 0.1, 0.0])];
    let mut sim = sim2d(case2d(0.5, 0.0, 0.0, 2e-8).particle_list("m", parts).wall(seg.clone())).unwrap();
    run(&mut sim, 200_000);
    let v = sim.particles().vel[0];
    assert!((v.y + 0.05).abs() < 0.005 * 0.1 && v.x.abs() < 1e-12, "face bounce {v}");
    // end point: moving along +x at the height of the segment towards its left end
    let parts = vec![ParticleEntry::at(1, [-0.0049, 0.0021, 0.0], 0.001).moving([0.1, 0.0, 0.0])];
    let mut sim = sim2d(case2d(1.0, 0.0, 0.0, 2e-8).particle_list("m", parts).wall(seg)).unwrap();
    run(&mut sim, 300_000);
    let (p, v) = (sim.particles().pos[0], sim.particles().vel[0]);
    assert!((v.norm() - 0.1).abs() < 1e-3 * 0.1, "elastic: speed {}", v.norm());
    // the impulse is along the line from the end point to the centre at impact:
    // (dx, dy) with dy = 0.6 mm and |d| = r, so the outgoing velocity satisfies
    // v = v0 - 2 (v0.n) n with n = (-0.8, 0.6)
    let n = Vec3::new(-0.8, 0.6, 0.0);
    let v0 = Vec3::new(0.1, 0.0, 0.0);
    let expect = v0 - n * (2.0 * v0.dot(&n));
    assert!((v - expect).norm() < 0.01 * 0.1, "end bounce {v} vs {expect} (at {p})");
}

#[test]
fn a_box_wall_holds_a_settled_bed_and_carries_its_weight() {
    let mut list = Vec::new();
    for i in 0..6 {
        for j in 0..4 {
            let (x, y) = (-0.005 + 0.0021 * i as f64, 0.0011 + 0.0023 * j as f64);
            list.push(ParticleEntry::at(list.len() as u64 + 1, [x, y, 0.0], 0.001));
        }
    }
    let case = case2d(0.3, 0.3, 9.81, 2e-7)
        .particle_list("m", list)
        .ellipses(vec![ellipse(3, 1.3, 0.4), ellipse(10, 1.2, 0.0)])
        .wall(WallSection::boxed("box", "m", [-0.0065, 0.0, 0.0], [0.0065, 0.02, 0.0]));
    let mut sim = sim2d(case).unwrap();
    run(&mut sim, 1_000_000);
    let p = sim.particles();
    let weight: f64 = p.mass.iter().sum::<f64>() * 9.81;
    assert!(p.vel.iter().all(|v| v.norm() < 1e-3), "settled");
    assert!((sim.walls()[0].force.y / -weight - 1.0).abs() < 0.01, "box force {} vs weight {weight}", sim.walls()[0].force);
    assert!(p.pos.iter().all(|x| x.x.abs() < 0.0065 && x.y > 0.0), "all inside");
}

#[test]
fn ellipse_and_segment_input_errors_name_the_key() {
    let one = || case2d(0.5, 0.3, 0.0, 1e-7).particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.0, 0.0], 0.001)]);
    for (case, key) in [
        (one().ellipses(vec![ellipse(1, 0.5, 0.0)]), "particles.ellipses[0].aspect_ratio = 0.5"),
        (one().ellipses(vec![ellipse(7, 1.5, 0.0)]), "particles.ellipses[0].id = 7"),
        (one().wall(WallSection::segment("s", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])), "wall.s.segment"),
        (one().wall(WallSection::boxed("b", "m", [0.0, 0.0, 0.0], [-1.0, 1.0, 0.0])), "wall.b.box"),
    ] {
        let err = sim2d(case).err().unwrap_or_else(|| panic!("accepted: {key}"));
        assert!(err.contains(key), "{err}");
    }
}
