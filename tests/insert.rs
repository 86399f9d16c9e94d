//! Particle insertion (`[[phase.insert]]`, cases/pour.toml): batches bring the
//! count up to rate x time, new particles start at the velocity given, the run
//! is the same for any storage order and thread count, bad insertions are
//! refused naming the key, and a region too full stops the run naming the
//! insertion. (Ranks and restarts: tests/mpi.rs.)

mod common;
use common::*;
use talus::case::Case;
use talus::run::{run, RunOptions};
use talus::sim::Simulation;

fn pour(sets: &[&str]) -> Result<Case, String> {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    Case::load_with(&cases_dir().join("pour.toml"), &sets).map_err(|e| e.to_string())
}

#[test]
fn batches_bring_the_count_up_to_rate_times_time_at_the_velocity_given() {
    let case = pour(&["phase[0].insert[0].count=320", "phase[0].insert[0].velocity=[0.1,0.0,-0.3]"]).unwrap();
    let mut sim = Simulation::new(case).unwrap();
    assert_eq!(sim.particles().len(), 0);
    let dt = sim.dt();
    let mut seen = 0;
    while sim.time() < 0.1 {
        let t = sim.time();
        sim.step().unwrap();
        let n = sim.particles().len();
        // batch k (50 spheres) is placed at the first step starting at or after k x 10 ms
        let k = ((t + 0.5 * dt) / 0.01).floor() as usize;
        assert_eq!(n, (50 * (k + 1)).min(320), "t = {t}");
        if n > seen {
            // the newcomers: inserted at the start of the step at the velocity
            // given, one step later at that plus g dt
            let p = sim.particles();
            for i in 0..n {
                if p.id[i] > seen as u64 {
                    let v = p.vel[i];
                    assert!((v.x - 0.1).abs() < 1e-12 && v.y.abs() < 1e-12 && (v.z - (-0.3 - 9.81 * dt)).abs() < 1e-12, "{v:?}");
                }
            }
            seen = n;
        }
    }
    assert_eq!(seen, 320);
}

#[test]
fn a_pour_is_the_same_in_any_storage_order_and_on_any_thread_count() {
    let d = tempfile::tempdir().unwrap();
    let mut hashes = Vec::new();
    for (order, threads) in [("id", 1), ("shuffled", 1), ("hilbert", 2)] {
        let case = pour(&[
            "phase[0].insert[0].count=600",
            &format!("parallel.order=\"{order}\""),
            "parallel.reorder_interval=0",
            &format!("parallel.threads={threads}"),
        ])
        .unwrap();
        let opts = RunOptions { out: d.path().join(order), max_steps: Some(3000), ..Default::default() };
        let r = run(case, &opts).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.sim.particles().len(), 600);
        let probes = std::fs::read_to_string(d.path().join(order).join("probes.csv")).unwrap();
        hashes.push((r.summary["state_hash"].clone(), probes));
    }
    assert!(hashes[0].1.lines().next().unwrap().contains(",particles,"));
    assert_eq!(hashes[1], hashes[0], "shuffled storage differs");
    assert_eq!(hashes[2], hashes[0], "2 threads differ");
}

#[test]
fn bad_insertions_are_refused_naming_the_key() {
    for (sets, want) in [
        (vec!["phase[0].insert[0].rate=-5.0"], "phase.pour.insert[0].rate = -5"),
        (vec!["phase[0].insert[0].material=\"sand\""], "phase.pour.insert[0].material = \"sand\""),
        (vec!["phase[0].insert[0].region.cylinder.hi=0.3"], "phase.pour.insert[0].region"),
        (vec!["phase[0].insert[0].radius.max=0.001"], "phase.pour.insert[0].radius.max = 0.001"),
        (vec!["simulation.integrator=\"gear\""], "simulation.integrator"),
    ] {
        let e = pour(&sets).unwrap_err();
        assert!(e.contains(want) && e.contains("pour.toml"), "{sets:?}: {e}");
    }
    // an interval shorter than the time step (known once the run is set up)
    let e = match Simulation::new(pour(&["phase[0].insert[0].interval=1e-9"]).unwrap()) {
        Ok(_) => panic!("accepted an interval of 1e-9 s"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("pour.toml: phase.pour.insert[0].interval = 0.000000001: shorter than the time step"), "{e}");
    // a count without its rate
    let text = std::fs::read_to_string(cases_dir().join("pour.toml")).unwrap().replace("rate = 5000.0\n", "");
    let e = Case::parse(&text, &cases_dir().join("pour.toml")).unwrap_err().to_string();
    assert!(e.contains("phase.pour.insert[0]") && e.contains("count and rate"), "{e}");
}

#[test]
fn a_region_too_full_for_its_batch_stops_the_run_naming_the_insertion() {
    let d = tempfile::tempdir().unwrap();
    let case = pour(&["phase[0].insert[0].rate=100000.0"]).unwrap();
    let opts = RunOptions { out: d.path().to_path_buf(), ..Default::default() };
    let e = match run(case, &opts) {
        Ok(_) => panic!("the run went on"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("phase.pour.insert[0]: batch 0") && e.contains("no free place in the region"), "{e}");
}
