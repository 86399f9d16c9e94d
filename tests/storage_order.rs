//! Results do not depend on how particles are stored: the same `state_hash`
//! and the same probe rows whether owned particles are kept in id order, by
//! grid cell, along a Hilbert curve, or shuffled at random at every list rebuild.

mod common;
use common::*;
use talus::case::Case;
use talus::run::{run, RunOptions, RunResult};

fn run_in(name: &str, order: &str, extra: &[&str], steps: u64) -> (RunResult, String) {
    let (r, probes, _) = run_with_checkpoint(name, order, extra, steps);
    (r, probes)
}

/// As `run_in`, with the bytes of the end-of-run checkpoint.
fn run_with_checkpoint(name: &str, order: &str, extra: &[&str], steps: u64) -> (RunResult, String, Vec<u8>) {
    let d = tempfile::tempdir().unwrap();
    // the order is remade at every list rebuild (the default is every 1,000 steps)
    let mut sets: Vec<String> = vec![format!("parallel.order=\"{order}\""), "parallel.reorder_interval=0".into()];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let case = Case::load_with(&cases_dir().join(name), &sets).unwrap_or_else(|e| panic!("{e}"));
    let opts = RunOptions { out: d.path().to_path_buf(), max_steps: Some(steps), ..Default::default() };
    let r = run(case, &opts).unwrap_or_else(|e| panic!("{e}"));
    let probes = std::fs::read_to_string(d.path().join("probes.csv")).unwrap();
    let ck = std::fs::read(d.path().join("checkpoint.bin")).unwrap();
    (r, probes, ck)
}

fn is_id_order(r: &RunResult) -> bool {
    r.sim.particles().id.windows(2).all(|w| w[0] < w[1])
}

#[test]
fn a_sheared_bed_gives_the_same_state_in_id_cell_hilbert_and_shuffled_storage() {
    let small = ["particles.lattice.count=1500"];
    let (id, p_id) = run_in("shear-bed.toml", "id", &small, 1500);
    let (hilbert, p_h) = run_in("shear-bed.toml", "hilbert", &small, 1500);
    let (cells, p_c) = run_in("shear-bed.toml", "cells", &small, 1500);
    let (shuffled, p_s) = run_in("shear-bed.toml", "shuffled", &small, 1500);
    // the orders really differ
    assert!(is_id_order(&id));
    assert!(!is_id_order(&hilbert) && !is_id_order(&cells) && !is_id_order(&shuffled));
    assert_ne!(hilbert.sim.particles().id, shuffled.sim.particles().id);
    assert_ne!(hilbert.sim.particles().id, cells.sim.particles().id);
    assert!(hilbert.sim.state().nl.builds > 5, "several rebuilds (and so reorders) happened");
    let h = |r: &RunResult| r.summary["state_hash"].as_str().unwrap().to_string();
    assert_eq!(h(&hilbert), h(&id));
    assert_eq!(h(&cells), h(&id));
    assert_eq!(h(&shuffled), h(&id));
    assert_eq!(p_h, p_id, "probe rows (wall loads, energies, contacts) differ between storage orders");
    assert_eq!(p_c, p_id);
    assert_eq!(p_s, p_id);
}

#[test]
fn gear_derivatives_move_with_their_particles_when_storage_is_shuffled() {
    let edits = ["particles.lattice.count=800", "simulation.integrator=\"gear\"", "simulation.timestep_rayleigh_fraction=0.1"];
    let (id, _, ck_id) = run_with_checkpoint("H1-small.toml", "id", &edits, 1200);
    let (shuffled, _, ck_s) = run_with_checkpoint("H1-small.toml", "shuffled", &edits, 1200);
    assert!(!is_id_order(&shuffled));
    assert_eq!(shuffled.summary["state_hash"], id.summary["state_hash"]);
    // the checkpoint holds every particle, its Gear rows and its history in
    // order of id, whatever the storage order: the same bytes
    assert!(ck_id == ck_s, "the checkpoints of id and shuffled storage differ");
}

#[test]
fn a_sheared_bed_gives_the_same_state_on_1_2_and_3_threads() {
    let mut hashes = Vec::new();
    for t in [1, 2, 3] {
        let threads = format!("parallel.threads={t}");
        let (r, probes) = run_in("shear-bed.toml", "cells", &["particles.lattice.count=1500", &threads], 1500);
        assert_eq!(r.summary["threads"], t);
        hashes.push((r.summary["state_hash"].clone(), probes));
    }
    assert_eq!(hashes[1], hashes[0], "2 threads differ from 1");
    assert_eq!(hashes[2], hashes[0], "3 threads differ from 1");
}

#[test]
fn rolling_spring_history_moves_with_its_contacts_in_any_storage_order_and_thread_count() {
    // the pile under the epsd2 rolling law: the spring torque of every contact
    // is carried through reorders and list rebuilds with the shear history
    let edits = ["contact.rolling=\"epsd2\"", "particles.lattice.count=600"];
    let (id, p_id) = run_in("pile-rolling.toml", "id", &edits, 2400);
    let (shuffled, p_s) = run_in("pile-rolling.toml", "shuffled", &edits, 2400);
    let with2: Vec<&str> = edits.iter().copied().chain(["parallel.threads=2"]).collect();
    let (two, p_2) = run_in("pile-rolling.toml", "hilbert", &with2, 2400);
    assert!(!is_id_order(&shuffled));
    assert!(id.sim.state().nl.pair_roll.iter().any(|t| t.norm() > 0.0), "no rolling spring is loaded");
    let h = |r: &RunResult| r.summary["state_hash"].as_str().unwrap().to_string();
    assert_eq!(h(&shuffled), h(&id));
    assert_eq!(h(&two), h(&id));
    assert_eq!(p_s, p_id);
    assert_eq!(p_2, p_id);
}
