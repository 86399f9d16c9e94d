//! Wall motion (issue 14, part 2): rotation about an axis through a point,
//! sinusoidal oscillation, both with translation, set or changed per phase
//! (`[[phase.move]]`); the contact velocity includes the rotation, and a turning
//! wall reports its torque about its own axis.

mod common;

use nalgebra::{Rotation3, Unit};
use talus::builder::CaseBuilder;
use talus::case::{Case, ContactSection, ModelName, MoveSection, OscillationSection, OutputSection, ParticleEntry, PhaseSection, RotationSection, TimeStep, WallSection};
use talus::contact::Convention;
use talus::dim::{Dimension, Vec3};
use talus::material::Material;
use talus::sim::Simulation;
use talus::walls::{Mesh, Shape};

const G: f64 = 9.81;
const R: f64 = 0.002;

fn material(friction: f64) -> Material {
    Material { name: "m".into(), youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500.0, restitution: 0.5, friction, rolling_friction: 0.0 }
}

fn builder(dt: f64, friction: f64, particles: Vec<ParticleEntry>) -> CaseBuilder {
    CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::Seconds(dt))
        .gravity([0.0, 0.0, -G])
        .domain([-0.2, -0.2, -0.2], [0.2, 0.2, 0.2])
        .contact(ContactSection { convention: Convention::Liggghts, ..ContactSection::new(ModelName::Hertz) })
        .material(material(friction))
        .particle_list("m", particles)
        .output(OutputSection { interval: 0.01, ..Default::default() })
}

fn build(b: CaseBuilder) -> Simulation {
    let case = b.build(std::path::Path::new("motion.toml")).unwrap_or_else(|e| panic!("{e}"));
    Simulation::new(case).unwrap_or_else(|e| panic!("{e}"))
}

fn rot(axis: Vec3, angle: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle)
}

/// A sphere far from the walls, at (0.15, 0.15, z) (run without gravity).
fn far_sphere(z: f64) -> Vec<ParticleEntry> {
    vec![ParticleEntry::at(1, [0.15, 0.15, z], R)]
}

#[test]
fn turning_translating_and_oscillating_walls_follow_the_rigid_motion() {
    // a plane turning about the x axis (which lies in it), and a ball that
    // translates, oscillates and turns about an axis through a point 10 mm from
    // its centre, the axis carried along by the translation and the oscillation
    let (dt, w, v, amp, f) = (1e-5, 2.0, [0.01, 0.0, 0.0], [0.0, 0.002, 0.0], 25.0);
    let mut sim = build(
        builder(dt, 0.5, far_sphere(0.15))
            .gravity([0.0; 3])
            .wall(WallSection::plane("plate", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).turning([1.0, 0.0, 0.0], [0.0, 0.0, 0.0], w))
            .wall(
                WallSection::disc("ball", "m", [0.01, 0.0, 0.0], 0.005)
                    .moving(v)
                    .oscillating(amp, f)
                    .turning([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], -w),
            )
            .phase(PhaseSection::new("go", 1.0)),
    );
    for n in 1..=20_000u64 {
        sim.step().unwrap();
        if n % 5_000 != 0 {
            continue;
        }
        let t = n as f64 * dt;
        let Shape::Plane(p) = &sim.walls()[0].shape else { panic!("plane") };
        let n_expect = rot(Vec3::x(), w * t) * Vec3::z();
        assert!((p.normal - n_expect).norm() < 1e-12, "t {t}: normal {:?} vs {:?}", p.normal, n_expect);
        assert!(p.point.norm() < 1e-15, "the plane's point is on the axis");
        let Shape::Disc(b) = &sim.walls()[1].shape else { panic!("ball") };
        let carried = Vec3::from(v) * t + Vec3::from(amp) * (2.0 * std::f64::consts::PI * f * t).sin();
        let c_expect = carried + rot(Vec3::z(), -w * t) * Vec3::new(0.01, 0.0, 0.0);
        assert!((b.center - c_expect).norm() < 1e-12, "t {t}: centre {:?} vs {:?}", b.center, c_expect);
        // the wall's velocity at a point: translation, oscillation, rotation about the carried axis
        let x = Vec3::new(0.02, 0.01, 0.0);
        let v_expect = Vec3::from(v)
            + Vec3::from(amp) * (2.0 * std::f64::consts::PI * f * (2.0 * std::f64::consts::PI * f * t).cos())
            + Vec3::new(0.0, 0.0, -w).cross(&(x - carried));
        assert!((sim.walls()[1].velocity_at(x) - v_expect).norm() < 1e-12, "t {t}: velocity at {x:?}");
    }
}

#[test]
fn a_turning_mesh_keeps_its_shape_and_turns_by_the_angle() {
    // the drum of cases/drum.toml turning from t = 0 at 3 rad/s
    let mut sim = common::sim("drum.toml", |c: &mut Case| {
        common::lattice(c).count = 20;
        c.phases.truncate(1);
        c.phases[0].duration = 0.1;
        common::wall(c, "drum").rotation = Some(RotationSection { axis: [0.0, 1.0, 0.0], point: [0.0, 0.0, 0.0], angular_velocity: 3.0 });
    });
    let m0 = Mesh::from_stl(&common::cases_dir().join("meshes/drum.stl")).unwrap();
    let dt = sim.dt();
    for _ in 0..1000 {
        sim.step().unwrap();
    }
    let Shape::Mesh(m) = &sim.walls()[0].shape else { panic!("mesh") };
    let r = rot(Vec3::y(), 3.0 * 1000.0 * dt);
    let worst = m.vertices.iter().zip(&m0.vertices).map(|(a, b)| (a - r * b).norm()).fold(0.0, f64::max);
    assert!(worst < 1e-14, "vertices off the rigid rotation by {worst:e} m");
    let worst_n = m.normals.iter().zip(&m0.normals).map(|(a, b)| (a - r * b).norm()).fold(0.0, f64::max);
    assert!(worst_n < 1e-12, "normals off by {worst_n:e}");
}

#[test]
fn a_sphere_on_a_turntable_is_dragged_to_two_sevenths_of_the_table_speed() {
    // a sphere at rest on a plate turning about the vertical axis, 0.1 m from it:
    // the plate slides under it at V = w r0; friction accelerates it (mu g) and
    // spins it up (5 mu g / 2r) until it rolls, at t* = 2 V / (7 mu g), at 2/7 V
    let (w, r0, mu) = (1.0, 0.1, 0.5);
    let big_v = w * r0;
    let m = material(mu);
    let mass = m.density * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    let y = m.youngs_modulus / (2.0 * (1.0 - m.poisson_ratio.powi(2)));
    let d = (3.0 * mass * G / (4.0 * y * R.sqrt())).powf(2.0 / 3.0);
    let dt = 2e-6;
    let mut sim = build(
        builder(dt, mu, vec![ParticleEntry::at(1, [r0, 0.0, R - d], R)])
            .wall(WallSection::plane("table", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).turning([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], w))
            .phase(PhaseSection::new("spin", 1.0)),
    );
    let t_star = 2.0 * big_v / (7.0 * mu * G);
    let steps = (1.5 * t_star / dt) as u64;
    let (n1, n2) = ((0.2 * t_star / dt) as u64, (0.8 * t_star / dt) as u64);
    let (mut v1, mut v2) = (Vec3::zeros(), Vec3::zeros());
    for n in 1..=steps {
        sim.step().unwrap();
        if n == n1 {
            v1 = sim.particles().vel[0];
        }
        if n == n2 {
            v2 = sim.particles().vel[0];
        }
    }
    // while it slides: dv/dt = mu g along +y, the table's motion under it (the
    // first two steps add an impulse: the tangential dashpot acts on the full
    // slip before the spring reaches the Coulomb cap, as in LIGGGHTS)
    let a = (v2.y - v1.y) / ((n2 - n1) as f64 * dt);
    assert!((a - mu * G).abs() < 1e-3 * mu * G, "sliding: dv_y/dt {a} vs mu g {}", mu * G);
    // rolling: 2/7 of the table's speed along +y (the sphere's angular momentum
    // about the contact point is kept while it slides, whatever the force's history)
    // rolling: 2/7 of the table's speed, along +y
    let v = sim.particles().vel[0];
    assert!((v.y - 2.0 / 7.0 * big_v).abs() < 0.01 * big_v, "rolling: v_y {} vs 2/7 V {}", v.y, 2.0 / 7.0 * big_v);
    assert!(v.x.abs() < 0.01 * big_v, "v_x {}", v.x);
    // and no slip at the contact: the sphere's contact point moves with the table
    let p = &sim.particles();
    let contact_v = p.vel[0] + p.omega[0].cross(&Vec3::new(0.0, 0.0, -R));
    let table_v = sim.walls()[0].velocity_at(Vec3::new(p.pos[0].x, p.pos[0].y, 0.0));
    assert!((contact_v - table_v).norm() < 0.01 * big_v, "slip {:?}", contact_v - table_v);
}

#[test]
fn a_turning_wall_reports_the_torque_about_its_own_axis() {
    // a sphere resting on a floor whose (resting) axis runs along y through
    // x = 0.05: its weight m g at x0 gives the floor a torque m g (x0 - 0.05) about +y
    let x0 = 0.01;
    let mut sim = build(
        builder(1e-5, 0.5, vec![ParticleEntry::at(1, [x0, 0.0, R], R)])
            .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).turning([0.0, 1.0, 0.0], [0.05, 0.0, 0.0], 0.0))
            .phase(PhaseSection::new("rest", 1.0)),
    );
    for _ in 0..40_000 {
        sim.step().unwrap();
    }
    let m = sim.particles().mass[0];
    let t = sim.walls()[0].axis_torque().unwrap();
    let expect = m * G * (x0 - 0.05);
    assert!((t - expect).abs() < 1e-6 * expect.abs(), "axis torque {t} vs {expect}");
    // about the origin it is m g x0 (the column the wall has had all along)
    let t0 = sim.walls()[0].torque.y;
    assert!((t0 - m * G * x0).abs() < 1e-6 * m * G * x0, "torque about the origin {t0}");
}

#[test]
fn phases_start_stop_and_change_a_walls_motion() {
    // a lid at z = 0.05: still in phase 1, down at 0.01 m/s in phase 2, stopped
    // in phase 3, oscillating from the start of phase 4
    let dt = 1e-5;
    let mv = |velocity: [f64; 3], oscillation: Option<OscillationSection>| MoveSection {
        wall: "lid".into(),
        velocity,
        rotation: None,
        oscillation,
    };
    let mut down = PhaseSection::new("down", 0.1);
    down.moves.push(mv([0.0, 0.0, -0.01], None));
    let mut stop = PhaseSection::new("stop", 0.05);
    stop.moves.push(mv([0.0; 3], None));
    let mut shake = PhaseSection::new("shake", 0.1);
    shake.moves.push(mv([0.0; 3], Some(OscillationSection { amplitude: [0.0, 0.0, 0.001], frequency: 20.0 })));
    let mut sim = build(
        builder(dt, 0.5, far_sphere(-0.15))
            .gravity([0.0; 3])
            .wall(WallSection::plane("lid", "m", [0.0, 0.0, 0.05], [0.0, 0.0, -1.0]))
            .phase(PhaseSection::new("still", 0.05))
            .phase(down)
            .phase(stop)
            .phase(shake),
    );
    let z = |sim: &Simulation| match &sim.walls()[0].shape {
        Shape::Plane(p) => p.point.z,
        _ => unreachable!(),
    };
    let mut seen = Vec::new();
    loop {
        sim.step().unwrap();
        let more = sim.advance_phase().unwrap();
        let t = sim.state().time;
        for (at, expect) in [
            (0.04, 0.05),
            (0.1, 0.05 - 0.01 * 0.05),
            (0.15, 0.049),
            (0.18, 0.049),
            (0.2 + 1.0 / 80.0, 0.049 + 0.001),
            (0.2 + 3.0 / 80.0, 0.049 - 0.001),
        ] {
            if (t - at).abs() < 0.5 * dt {
                assert!((z(&sim) - expect).abs() < 1e-12, "t {t}: lid at {} vs {expect}", z(&sim));
                seen.push(at);
            }
        }
        if !more {
            break;
        }
    }
    assert_eq!(seen.len(), 6, "checked at {seen:?}");
}

#[test]
fn a_turning_drum_restarts_from_a_checkpoint_to_the_uninterrupted_state() {
    // the wall's pose and motion are in the checkpoint
    let edit = |c: &mut Case| {
        common::lattice(c).count = 200;
        c.phases[0].duration = 0.02;
        c.phases[1].duration = 0.05;
        c.phases[1].moves[0].rotation.as_mut().unwrap().angular_velocity = 30.0;
    };
    let mut a = common::sim("drum.toml", edit);
    let mut b = common::sim("drum.toml", edit);
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("ck.bin");
    let run_to = |s: &mut Simulation, n: u64| {
        while s.state().step < n {
            s.step().unwrap();
            s.advance_phase().unwrap();
        }
    };
    run_to(&mut a, 600);
    talus::checkpoint::write(&a, &ck).unwrap();
    run_to(&mut a, 900);
    talus::checkpoint::read(&mut b, &ck).unwrap();
    run_to(&mut b, 900);
    assert_eq!(a.state_hash(), b.state_hash());
    let (Shape::Mesh(ma), Shape::Mesh(mb)) = (&a.walls()[0].shape, &b.walls()[0].shape) else { panic!("mesh") };
    assert_eq!(ma.vertices, mb.vertices);
}

#[test]
fn bad_motion_is_refused_naming_the_key_and_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("meshes");
    std::fs::create_dir_all(&m).unwrap();
    std::fs::copy(common::cases_dir().join("meshes/drum.stl"), m.join("drum.stl")).unwrap();
    for (from, to, expect) in [
        ("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]", "phase.turn.move[0].rotation.axis"),
        ("angular_velocity = 3.0", "angular_velocity = nan", "phase.turn.move[0].rotation.angular_velocity"),
        ("wall = \"drum\"\nrotation", "wall = \"barrel\"\nrotation", "phase.turn.move[0].wall = \"barrel\": no wall of that name"),
        ("stl = \"meshes/drum.stl\"", "stl = \"meshes/drum.stl\"\noscillation = { amplitude = [0.0, 0.0, 0.001], frequency = -5.0 }", "wall.drum.oscillation.frequency = -5"),
        ("rotation = {", "spin = 1.0\nrotation = {", "spin"),
    ] {
        let text = common::case_text("drum.toml", &[(from, to)]);
        let path = dir.path().join("drum.toml");
        std::fs::write(&path, text).unwrap();
        let e = Case::load(&path).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains(expect) && e.contains("drum.toml"), "{from} -> {to}: {e}");
    }
}

#[test]
fn a_servo_wall_comes_in_at_its_speed_limit_then_holds_its_target_load() {
    // the lid of cases/shear-servo.toml, raised 5 mm above the bed: it comes down at
    // max_speed (travel = v_max t to rounding) until it touches, then presses until
    // the bed pushes back with the target (10 N) and comes to rest there
    let mut sim = common::sim("shear-servo.toml", |c: &mut Case| {
        c.phases.truncate(1);
        c.phases[0].duration = 0.4;
        match &mut common::wall(c, "lid").shape {
            talus::case::WallShape::Plane(p) => p.point[2] += 0.005,
            _ => unreachable!(),
        }
    });
    let dt = sim.dt();
    let servo = |s: &Simulation| s.walls().iter().find(|w| w.name == "lid").unwrap().servo.clone().unwrap();
    let v_max = servo(&sim).max_speed;
    for _ in 0..500 {
        sim.step().unwrap();
    }
    let travel = servo(&sim).travel;
    assert!((travel - v_max * 500.0 * dt).abs() < 1e-12, "free approach: travel {travel} vs {}", v_max * 500.0 * dt);
    let mut pushes = Vec::new();
    while sim.state().time < 0.4 - 0.5 * dt {
        sim.step().unwrap();
        if sim.state().time > 0.35 {
            let w = sim.walls().iter().find(|w| w.name == "lid").unwrap();
            pushes.push(-w.force.dot(&w.servo.as_ref().unwrap().direction));
        }
    }
    let mean = pushes.iter().sum::<f64>() / pushes.len() as f64;
    assert!((mean - 10.0).abs() < 0.1, "the bed's push on the lid over 0.35-0.4 s: {mean} N against the target 10 N");
    let lid = sim.walls().iter().find(|w| w.name == "lid").unwrap();
    assert!(lid.velocity.norm() < 0.05 * v_max, "the lid comes to rest: {:?}", lid.velocity);
}

#[test]
fn a_bad_servo_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let b = dir.path().join("beds");
    std::fs::create_dir_all(&b).unwrap();
    std::fs::copy(common::cases_dir().join("beds/shear-cell.csv"), b.join("shear-cell.csv")).unwrap();
    let servo = "servo = { force = 10.0, gain = 0.01, max_speed = 0.05 }";
    for (to, expect) in [
        ("servo = { force = 10.0, pressure = 5.0, area = 2.0, gain = 0.01, max_speed = 0.05 }", "wall.lid.servo = force Some(10.0), pressure Some(5.0), area Some(2.0): give the load to hold"),
        ("servo = { force = 10.0, gain = -0.01, max_speed = 0.05 }", "wall.lid.servo.gain = -0.01"),
        ("servo = { force = 10.0, gain = 0.01, max_speed = 0.05, direction = [0.0, 0.0, 0.0] }", "wall.lid.servo.direction"),
        ("servo = { force = 10.0, gain = 0.01, max_speed = 0.05 }\nvelocity = [0.0, 0.0, -0.1]", "leave out its velocity"),
    ] {
        let text = common::case_text("shear-servo.toml", &[(servo, to)]);
        let path = dir.path().join("shear-servo.toml");
        std::fs::write(&path, text).unwrap();
        let e = Case::load(&path).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains(expect) && e.contains("shear-servo.toml"), "{to}: {e}");
    }
}
