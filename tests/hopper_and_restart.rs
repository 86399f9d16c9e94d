//! H1-small at the end of filling (walls + gate carry the weight), and bitwise
//! restarts from checkpoints.

mod common;
use common::*;
use talus::integrate::IntegratorKind;
use talus::run::{run, RunOptions};

#[test]
fn h1_small_fill_walls_plus_gate_carry_the_total_weight() {
    // fill only: the discharge phase is cut to one output interval
    let s = run_case("H1-small.toml", |c| {
        phase(c, "discharge").duration = 0.01;
        c.output.snapshot_interval = Some(10.0);
    });
    let w = num(&s, "fill_end_wall_force_z_n");
    let g = num(&s, "fill_end_gate_force_z_n");
    let weight = num(&s, "total_weight_n");
    // 5000 spheres of radius U(1.95, 2.35) mm, density 2500: W = N rho 4/3 pi E[r^3] g
    let er3 = (2.35e-3f64.powi(4) - 1.95e-3f64.powi(4)) / (4.0 * 0.4e-3);
    let w_expect = 5000.0 * 2500.0 * 4.0 / 3.0 * std::f64::consts::PI * er3 * 9.81;
    assert!((weight / w_expect - 1.0).abs() < 0.01, "weight {weight} vs {w_expect}");
    assert!(((w + g) / weight - 1.0).abs() < 0.01, "walls {w} + gate {g} vs weight {weight}");
    // both carry a real share: the converging walls hold part of the pile (Janssen)
    assert!(w > 0.2 * weight && g > 0.1 * weight, "walls {w}, gate {g}");
}

fn restart_matches(integrator: IntegratorKind) {
    let case = || {
        edited("H1-small.toml", |c| {
            lattice(c).count = 800;
            c.simulation.integrator = integrator;
            phase(c, "fill").duration = 0.032; // the gate goes at step 300, between the two halves
            c.output.snapshot_interval = Some(10.0);
        })
    };
    let d = tempfile::tempdir().unwrap();
    let whole = run(case(), &RunOptions { out: d.path().join("whole"), max_steps: Some(500), ..Default::default() }).unwrap();
    let half = run(case(), &RunOptions { out: d.path().join("a"), max_steps: Some(250), ..Default::default() }).unwrap();
    assert_ne!(half.summary["state_hash"], whole.summary["state_hash"]);
    let rest = run(
        case(),
        &RunOptions {
            out: d.path().join("b"),
            max_steps: Some(250),
            restart: Some(d.path().join("a").join("checkpoint.bin")),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(rest.summary["steps"], whole.summary["steps"]);
    assert_eq!(rest.summary["state_hash"], whole.summary["state_hash"], "{integrator:?}: restart differs");
    let (a, b) = (rest.sim.particles(), whole.sim.particles());
    for i in 0..a.len() {
        assert_eq!(a.pos[i], b.pos[i]);
        assert_eq!(a.omega[i], b.omega[i]);
    }
}

#[test]
fn restart_from_checkpoint_is_bitwise_identical_verlet() {
    restart_matches(IntegratorKind::Verlet);
}

#[test]
fn restart_from_checkpoint_is_bitwise_identical_gear() {
    restart_matches(IntegratorKind::Gear);
}
