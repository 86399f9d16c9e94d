//! MPI: results do not depend on the number of ranks (bit for bit, balancing on
//! or off), checkpoints restart on another number of ranks, and a failing rank
//! ends the job naming itself. Runs the `talus` binary under
//! `mpirun --oversubscribe -n P` (OpenMPI from Debian: `openmpi-bin`).

mod common;
use common::*;
use std::path::Path;
use std::process::Command;
use talus::case::{Case, ParallelSection};

/// Run talus on P ranks (P = 0: without mpirun). Returns (success, stdout + stderr, summary).
fn talus(p: usize, case: &Path, out: &Path, extra: &[&str]) -> (bool, String, Option<serde_json::Value>) {
    let bin = env!("CARGO_BIN_EXE_talus");
    let mut args: Vec<String> = Vec::new();
    let mut cmd = if p == 0 {
        Command::new(bin)
    } else {
        args.extend(["--allow-run-as-root", "--oversubscribe", "-n", &p.to_string(), bin].map(String::from));
        Command::new("mpirun")
    };
    args.extend(["run".to_string(), case.display().to_string(), "--out".into(), out.display().to_string(), "--quiet".into()]);
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = cmd
        .args(&args)
        .env("TALUS_CHECK_COLLECTIVES", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .unwrap_or_else(|e| panic!("cannot start {}: {e} (is openmpi-bin installed?)", if p == 0 { bin } else { "mpirun" }));
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    let summary = std::fs::read_to_string(out.join("summary.json")).ok().map(|s| serde_json::from_str(&s).unwrap());
    (o.status.success(), text, summary)
}

/// `talus ARGS` on P ranks (P = 0: without mpirun) as a user types it: no
/// `--quiet`, with a terminal (util-linux `script` gives the job one) or
/// without; the ranks check that they make the same collectives. A run that
/// has not ended after two minutes is stopped (coreutils `timeout`: exit 124).
/// Returns (exit code, stdout + stderr).
fn as_a_user(p: usize, args: &[&str], env: &[(&str, &str)], tty: bool) -> (i32, String) {
    let bin = env!("CARGO_BIN_EXE_talus");
    let mut line: Vec<String> = vec!["timeout".into(), "-k".into(), "5".into(), "120".into()];
    if p > 0 {
        line.extend(["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", &p.to_string()].map(String::from));
    }
    line.push(bin.into());
    line.extend(args.iter().map(|s| s.to_string()));
    let mut cmd = if tty {
        let mut c = Command::new("script");
        c.args(["-qec", &line.join(" "), "/dev/null"]);
        c
    } else {
        let mut c = Command::new(&line[0]);
        c.args(&line[1..]);
        c
    };
    let o = cmd
        .envs(env.iter().copied())
        .env("TALUS_CHECK_COLLECTIVES", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("cannot start {:?}: {e}", line));
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    (o.status.code().unwrap_or(-1), text)
}

fn summary_hash(out: &Path) -> String {
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    s["state_hash"].as_str().unwrap().to_string()
}

#[test]
fn a_run_without_quiet_ends_on_1_to_4_ranks_with_and_without_a_terminal() {
    // README's command as a user types it, progress bar and all: before the
    // fix rank 0 alone counted the particles for the bar (a collective), so
    // SC-pair aborted (MPI_ERR_TRUNCATE) and H1-small hung
    let d = tempfile::tempdir().unwrap();
    let pair = cases_dir().join("SC-pair.toml");
    let mut hashes = Vec::new();
    for tty in [false, true] {
        for p in [0, 1, 2, 3, 4] {
            let out = d.path().join(format!("pair-{p}-{tty}"));
            let (code, text) = as_a_user(p, &["run", pair.to_str().unwrap(), "--steps", "200", "--out", out.to_str().unwrap()], &[], tty);
            assert_eq!(code, 0, "SC-pair on {p} ranks, terminal {tty}: {text}");
            assert_eq!(text.matches("finished; outputs in").count(), 1, "rank 0 alone reports: {text}");
            hashes.push(summary_hash(&out));
        }
    }
    assert!(hashes.iter().all(|h| h == &hashes[0]), "{hashes:?}");
    let small = write_case(d.path(), "H1-small.toml", |c| lattice(c).count = 1500);
    let mut hashes = Vec::new();
    for (p, tty) in [(0, false), (2, false), (3, true)] {
        let out = d.path().join(format!("small-{p}"));
        let (code, text) = as_a_user(p, &["run", small.to_str().unwrap(), "--steps", "400", "--out", out.to_str().unwrap()], &[], tty);
        assert_eq!(code, 0, "H1-small on {p} ranks, terminal {tty}: {text}");
        hashes.push(summary_hash(&out));
    }
    assert!(hashes.iter().all(|h| h == &hashes[0]), "{hashes:?}");
}

#[test]
fn a_collective_on_some_ranks_only_ends_the_job_naming_each_ranks_collective() {
    let d = tempfile::tempdir().unwrap();
    let pair = cases_dir().join("SC-pair.toml");
    for rank in ["0", "1"] {
        let out = d.path().join(format!("extra-{rank}"));
        let args = ["run", pair.to_str().unwrap(), "--steps", "50", "--quiet", "--out", out.to_str().unwrap()];
        let (code, text) = as_a_user(2, &args, &[("TALUS_TEST_EXTRA_COLLECTIVE_RANK", rank)], false);
        assert!(code != 0 && code != 124, "exit {code}: {text}");
        assert!(text.contains("the ranks' collectives differ"), "{text}");
        // each rank's collective, with the line that called it
        assert!(text.contains("rank 0: collective #") && text.contains("rank 1: collective #"), "{text}");
        assert!(text.contains("`sum_u64` called from src/run.rs:"), "{text}");
    }
    // a rank that never joins: the others say where they wait instead of spinning forever
    let out = d.path().join("stall");
    let args = ["run", pair.to_str().unwrap(), "--steps", "50", "--quiet", "--out", out.to_str().unwrap()];
    let (code, text) = as_a_user(2, &args, &[("TALUS_TEST_STALL_RANK", "1:30"), ("TALUS_COLLECTIVE_TIMEOUT", "2")], false);
    assert!(code != 0 && code != 124, "exit {code}: {text}");
    assert!(text.contains("rank 0 of 2 waited 2 s in collective #") && text.contains("for the other ranks to join"), "{text}");
}

#[test]
fn a_drag_study_under_mpirun_deals_its_beds_to_the_ranks_and_writes_the_serial_files() {
    let d = tempfile::tempdir().unwrap();
    // c1 cut short: 150 granules, three beds, a millimetre of travel
    let mut t: toml::Table = toml::from_str(&std::fs::read_to_string(cases_dir().join("drag/c1.toml")).unwrap()).unwrap();
    let drag = t.get_mut("drag").unwrap().as_table_mut().unwrap();
    drag.insert("count".into(), 150.into());
    drag.insert("growth_time".into(), 0.002.into());
    drag.insert("settle_time".into(), 0.001.into());
    drag.insert("travel".into(), 0.001.into());
    drag.insert("average_window".into(), toml::Value::Array(vec![0.0002.into(), 0.0008.into()]));
    drag.insert("seeds".into(), toml::Value::Array(vec![3.into(), 1.into(), 2.into()]));
    let case = d.path().join("c1-short.toml");
    std::fs::write(&case, toml::to_string(&t).unwrap()).unwrap();
    let files = ["beds.csv", "drag_vs_displacement.csv", "snapshots.csv"];
    let read = |out: &Path| files.map(|f| std::fs::read_to_string(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}")));
    let serial = d.path().join("serial");
    let (code, text) = as_a_user(0, &["drag", case.to_str().unwrap(), "--out", serial.to_str().unwrap()], &[], false);
    assert_eq!(code, 0, "{text}");
    for p in [2, 3] {
        let out = d.path().join(format!("p{p}"));
        let (code, text) = as_a_user(p, &["drag", case.to_str().unwrap(), "--out", out.to_str().unwrap()], &[], false);
        assert_eq!(code, 0, "{p} ranks: {text}");
        assert_eq!(text.matches("finished; outputs in").count(), 1, "rank 0 alone reports: {text}");
        assert!(read(&out) == read(&serial), "{p} ranks: the study's files differ from the serial run's");
    }
}

fn hash_of(p: usize, case: &Path, out: &Path, extra: &[&str]) -> String {
    let (ok, text, s) = talus(p, case, out, extra);
    assert!(ok, "talus on {p} ranks failed: {text}");
    let s = s.unwrap();
    assert_eq!(s["ranks"].as_u64().unwrap(), p.max(1) as u64);
    s["state_hash"].as_str().unwrap().to_string()
}

#[test]
fn h1_small_is_bit_identical_on_1_to_4_ranks_with_and_without_balancing() {
    let d = tempfile::tempdir().unwrap();
    // the gate opens at 0.25 s (step 2342): the last 1,100 steps discharge
    use talus::parallel::BalanceMode::{Contacts, Count, Off, Time};
    let runs = [(0, Off), (2, Time), (3, Count), (4, Contacts), (4, Off)];
    let mut reference: Option<(String, String)> = None;
    for (k, (p, mode)) in runs.into_iter().enumerate() {
        let dir = d.path().join(format!("case{k}"));
        let case = write_case(&dir, "H1-small.toml", |c| {
            lattice(c).count = 2500;
            phase(c, "fill").duration = 0.25;
            c.output.snapshot_interval = Some(10.0);
            c.parallel = ParallelSection { balance: mode, imbalance_percent: 2.0, balance_interval: 50, ..Default::default() };
        });
        let out = dir.join("out");
        let h = hash_of(p, &case, &out, &["--steps", "3400"]);
        let probes = std::fs::read_to_string(out.join("probes.csv")).unwrap();
        match &reference {
            None => reference = Some((h, probes)),
            Some((h0, p0)) => {
                assert_eq!(&h, h0, "{p} ranks, balance {mode:?}: particle states differ from the serial run");
                // energies, contacts, wall forces and torques, discharged mass: exact sums, same text
                assert!(&probes == p0, "{p} ranks, balance {mode:?}: probes.csv differs from the serial run");
            }
        }
    }
}

#[test]
fn sheared_bed_is_bit_identical_on_1_to_4_ranks_and_restarts_on_another_count() {
    let d = tempfile::tempdir().unwrap();
    let small = |c: &mut Case| lattice(c).count = 1500;
    let case = write_case(d.path(), "shear-bed.toml", small);
    let serial = hash_of(0, &case, &d.path().join("s"), &["--steps", "2500"]);
    for (p, grid) in [(2, None), (3, None), (4, Some([2, 2, 1]))] {
        let dir = d.path().join(format!("p{p}"));
        let c = match grid {
            Some(g) => write_case(&dir, "shear-bed.toml", |c| {
                small(c);
                c.parallel.grid = Some(g);
                c.parallel.balance = talus::parallel::BalanceMode::Count;
            }),
            None => case.clone(),
        };
        assert_eq!(hash_of(p, &c, &dir.join("out"), &["--steps", "2500"]), serial, "{p} ranks (grid {grid:?})");
    }
    // 1,200 steps on 2 ranks, then 1,300 more from its checkpoint on 3 ranks
    let a = d.path().join("a");
    let h_a = hash_of(2, &case, &a, &["--steps", "1200"]);
    assert_ne!(h_a, serial);
    let ck = a.join("checkpoint.bin");
    let h_b = hash_of(3, &case, &d.path().join("b"), &["--steps", "1300", "--restart", ck.to_str().unwrap()]);
    assert_eq!(h_b, serial, "2 ranks then 3 ranks from the checkpoint differ from one serial run");
}

#[test]
fn gear_integrator_is_bit_identical_across_ranks() {
    // Gear's derivatives migrate with the particles (Gear needs a smaller step
    // than Verlet: at 0.2 of the Rayleigh time this hopper blows up, at 0.1 it runs)
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "H1-small.toml", |c| {
        c.simulation.timestep = talus::case::TimeStep::RayleighFraction(0.1);
        lattice(c).count = 2000;
        c.simulation.integrator = talus::integrate::IntegratorKind::Gear;
        c.output.snapshot_interval = Some(10.0);
    });
    let serial = hash_of(0, &case, &d.path().join("s"), &["--steps", "3000"]);
    assert_eq!(hash_of(3, &case, &d.path().join("p3"), &["--steps", "3000"]), serial);
}

#[test]
fn a_failing_rank_ends_the_job_naming_the_rank_and_the_particle_and_all_write_a_checkpoint() {
    let d = tempfile::tempdir().unwrap();
    // the floor moved below the domain: the bed falls out through the bottom of the domain, on the lowest slab's rank
    let case = write_case(d.path(), "shear-bed.toml", |c| {
        let talus::case::WallShape::Plane(p) = &mut wall(c, "floor").shape else { panic!("the floor is a plane") };
        p.point = [0.0, 0.0, -1.0];
    });
    let out = d.path().join("out");
    let (ok, text, _) = talus(2, &case, &out, &[]);
    assert!(!ok, "the run should fail: {text}");
    assert!(text.contains("rank 0 of 2") && text.contains("left the domain") && text.contains("particle id"), "{text}");
    assert!(out.join("failure_checkpoint.bin").exists());
    // the failure checkpoint is a whole state: it restarts (and fails again) on another number of ranks
    let (ok, text, _) = talus(3, &case, &d.path().join("again"), &["--restart", out.join("failure_checkpoint.bin").to_str().unwrap()]);
    assert!(!ok && text.contains("left the domain"), "{text}");
}

#[test]
fn a_grid_that_does_not_match_the_ranks_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "shear-bed.toml", |c| c.parallel.grid = Some([1, 1, 3]));
    let (ok, text, _) = talus(2, &case, &d.path().join("out"), &["--steps", "10"]);
    assert!(!ok);
    assert!(text.contains("parallel.grid = [1, 1, 3]") && text.contains("2 MPI ranks"), "{text}");
}

#[test]
fn an_input_error_under_mpi_is_printed_once_by_rank_0() {
    let d = tempfile::tempdir().unwrap();
    let case = d.path().join("SC-wall.toml");
    std::fs::write(&case, case_text("SC-wall.toml", &[("poisson_ratio = 0.3", "poisson_ratio = 0.7")])).unwrap();
    let (ok, text, _) = talus(2, &case, &d.path().join("out"), &[]);
    assert!(!ok, "{text}");
    let msg = format!(
        "talus: error: {}: materials.seed-soft.poisson_ratio = 0.7: Poisson's ratio must lie in [0, 0.5)\n",
        case.display()
    );
    assert_eq!(text.matches(&msg).count(), 1, "{text}");
    assert_eq!(text.matches("poisson_ratio").count(), 1, "{text}");
    // a bad command line likewise, and an error found while building the simulation
    let (ok, text, _) = talus(2, &case, &d.path().join("out"), &["--steps", "-5"]);
    assert!(!ok && text.matches("talus: error: --steps -5: must be a whole number of steps, 0 or more\n").count() == 1, "{text}");
    std::fs::write(&case, case_text("SC-wall.toml", &[("position = [0.0, 0.0, 0.0021]", "position = [0.0, 0.0, 0.0019]")])).unwrap();
    let (ok, text, _) = talus(2, &case, &d.path().join("out"), &[]);
    assert!(!ok && text.matches("overlaps wall \"plate\"").count() == 1, "{text}");
}

#[test]
fn shuffled_storage_on_2_ranks_gives_the_serial_id_order_state() {
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "shear-bed.toml", |c| lattice(c).count = 1500);
    let serial = hash_of(0, &case, &d.path().join("s"), &["--steps", "1500", "--set", "parallel.order=\"id\""]);
    let shuffled = hash_of(2, &case, &d.path().join("p2"), &["--steps", "1500", "--set", "parallel.order=\"shuffled\"", "--set", "parallel.reorder_interval=0"]);
    assert_eq!(shuffled, serial);
}

#[test]
fn ranks_times_threads_give_the_serial_single_thread_state() {
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "H1-small.toml", |c| {
        lattice(c).count = 1500;
        c.output.snapshot_interval = None;
    });
    let serial = hash_of(0, &case, &d.path().join("s"), &["--steps", "1500", "--threads", "1"]);
    let two_by_two = hash_of(2, &case, &d.path().join("p2"), &["--steps", "1500", "--threads", "2"]);
    assert_eq!(two_by_two, serial, "2 ranks x 2 threads differ from 1 rank x 1 thread");
}

/// `steps` steps of `case` give the same state on 1 and 2 ranks, and the same
/// as 2 ranks for `first` steps then 3 ranks from that checkpoint (in `dir`).
fn same_on_1_2_ranks_and_after_a_restart_on_3(case: &Path, dir: &Path, steps: u64, first: u64) {
    let all = steps.to_string();
    let serial = hash_of(0, case, &dir.join("s"), &["--steps", &all]);
    assert_eq!(hash_of(2, case, &dir.join("p2"), &["--steps", &all]), serial, "2 ranks differ from the serial run");
    let a = dir.join("a");
    hash_of(2, case, &a, &["--steps", &first.to_string()]);
    let ck = a.join("checkpoint.bin");
    let rest = (steps - first).to_string();
    let h_b = hash_of(3, case, &dir.join("b"), &["--steps", &rest, "--restart", ck.to_str().unwrap()]);
    assert_eq!(h_b, serial, "2 ranks then 3 ranks from the checkpoint after step {first} differ from one serial run");
}

#[test]
fn rolling_spring_history_is_bit_identical_across_ranks_and_restarts_on_another_count() {
    // the pile with the epsd2 rolling law: each contact's rolling spring torque
    // migrates with its particles and is checkpointed (issue 14)
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "pile-rolling.toml", |c| {
        c.contact.rolling = Some(talus::case::RollingModel::Epsd2);
        lattice(c).count = 600;
    });
    same_on_1_2_ranks_and_after_a_restart_on_3(&case, d.path(), 2400, 1200);
}

#[test]
fn a_pour_is_bit_identical_across_ranks_and_restarts_mid_pour_on_another_count() {
    // particles inserted in batches (cases/pour.toml, shortened): every rank
    // places the same batch and keeps those its box owns; a checkpoint taken
    // between batches carries each insertion's progress
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "pour.toml", |c| {
        c.phases[0].inserts[0].count = Some(800);
    });
    same_on_1_2_ranks_and_after_a_restart_on_3(&case, d.path(), 3000, 1000);
}

#[test]
fn spheres_inserted_fast_get_the_same_skins_and_list_builds_on_any_rank_count() {
    // each particle's skin grows with its speed (`SkinRule`); on several
    // ranks the build's largest skin is agreed first, and a batch inserted
    // at 3 m/s, faster than anything in the pile, joins at that build: its
    // speed must count, or its skins are capped on 2 ranks and not on 1
    let d = tempfile::tempdir().unwrap();
    let case = write_case(d.path(), "pour.toml", |c| {
        c.phases[0].inserts[0].count = Some(400);
        c.phases[0].inserts[0].velocity = [0.0, 0.0, -3.0];
        // (a rebalance rebuilds the lists: off, so the builds can be compared)
        c.parallel.balance = talus::parallel::BalanceMode::Off;
    });
    let mut seen = Vec::new();
    for p in [0, 2] {
        let out = d.path().join(format!("fast{p}"));
        let (ok, text, s) = talus(p, &case, &out, &["--steps", "2000"]);
        assert!(ok, "talus on {p} ranks failed: {text}");
        let s = s.unwrap();
        seen.push((s["state_hash"].as_str().unwrap().to_string(), s["neighbor_builds"].as_u64().unwrap()));
    }
    assert_eq!(seen[0], seen[1], "(state hash, list builds) on 1 and 2 ranks");
}

#[test]
fn a_periodic_chute_is_bit_identical_across_ranks_grids_and_restarts() {
    // cases/chute.toml, periodic along x and y: images are ghosts, serially as
    // under MPI; a pair across a periodic face is evaluated from the owners'
    // position bits plus whole periods, so slabs along the periodic x, a 2 x 2
    // grid, shuffled storage and a restart on another count all give the serial bits
    let d = tempfile::tempdir().unwrap();
    let case = cases_dir().join("chute.toml");
    same_on_1_2_ranks_and_after_a_restart_on_3(&case, d.path(), 3000, 1700);
    let serial = hash_of(0, &case, &d.path().join("s2"), &["--steps", "3000"]);
    let grid = hash_of(4, &case, &d.path().join("g4"), &["--steps", "3000", "--set", "parallel.grid=[2,2,1]"]);
    assert_eq!(grid, serial, "a 2 x 2 grid over the periodic axes differs from the serial run");
    let shuffled = hash_of(2, &case, &d.path().join("sh"), &["--steps", "3000", "--set", "parallel.order=shuffled"]);
    assert_eq!(shuffled, serial, "shuffled storage on 2 ranks differs from the serial run");
}

#[test]
fn a_periodic_2d_flow_is_bit_identical_across_ranks_and_restarts() {
    // 2D: 300 discs on a floor, periodic along x, gravity tilted 30 degrees; slabs
    // cut the periodic axis, so every rank holds images from its neighbours across
    // the face, and rank 0 and the last rank are neighbours through it
    use talus::builder::CaseBuilder;
    use talus::case::{Axis, ContactSection, ModelName, OutputSection, ParticleEntry, PhaseSection, TimeStep, WallSection};
    use talus::dim::Dimension;
    use talus::material::Material;
    let d = tempfile::tempdir().unwrap();
    let mut discs = Vec::new();
    for k in 0..300u64 {
        let (i, j) = (k % 25, k / 25);
        let x = 0.0012 + 0.0024 * i as f64 + 0.0001 * ((k * 7919) % 5) as f64;
        discs.push(ParticleEntry::at(k + 1, [x, 0.0012 + 0.0024 * j as f64, 0.0], 0.0007 + 0.0001 * (k % 3) as f64).moving([0.1 * ((k % 7) as f64 - 3.0), 0.0, 0.0]));
    }
    let m = Material { name: "m".into(), youngs_modulus: 1.0e7, poisson_ratio: 0.3, density: 2500.0, restitution: 0.5, friction: 0.4, rolling_friction: 0.0 };
    let case = CaseBuilder::new(Dimension::Two)
        .timestep(TimeStep::Seconds(1e-5))
        .gravity([4.905, -8.496, 0.0])
        .domain([0.0, 0.0, -0.001], [0.06, 0.05, 0.001])
        .periodic(&[Axis::X])
        .contact(ContactSection::new(ModelName::Hertz))
        .material(m)
        .particle_list("m", discs)
        .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
        .phase(PhaseSection::new("flow", 0.1))
        .output(OutputSection { interval: 0.01, ..Default::default() })
        .build(&d.path().join("flow2d.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let path = d.path().join("flow2d.toml");
    std::fs::write(&path, case.to_toml().unwrap()).unwrap();
    same_on_1_2_ranks_and_after_a_restart_on_3(&path, d.path(), 6000, 2500);
}
