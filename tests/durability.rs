//! Nothing a user ran is lost: checkpoints are replaced atomically and refuse
//! damaged files, series survive a kill and continue on a restart into the same
//! folder, SIGINT / SIGTERM stop a run with a checkpoint (on every rank at the
//! same step under MPI). Runs the `talus` binary on a small hopper.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_talus");

/// A small H1 hopper: 1,000 spheres, the gate removed at 0.03 s, 700 steps in
/// all (0.075 s), probes every 0.005 s, a checkpoint every 0.01 s.
fn small_hopper(dir: &Path) -> PathBuf {
    write_case(dir, "H1-small.toml", |c| {
        lattice(c).count = 1000;
        phase(c, "fill").duration = 0.03;
        phase(c, "discharge").duration = 0.045;
        c.output.interval = 0.005;
        c.output.checkpoint_interval = Some(0.01);
        c.output.snapshot_interval = Some(0.02);
    })
}

fn cmd(case: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.args(["run", case.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"]).args(extra);
    c
}

fn finish(o: Output) -> (Option<i32>, String) {
    (o.status.code(), String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr))
}

fn run(case: &Path, out: &Path, extra: &[&str]) -> (Option<i32>, String) {
    finish(cmd(case, out, extra).output().unwrap())
}

fn spawn(c: &mut Command) -> Child {
    c.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()
}

fn summary(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// Wait (at most 60 s) until `cond` holds; false if the process ended first.
fn wait_for(child: &mut Child, cond: impl Fn() -> bool) -> bool {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(60) {
        if cond() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!("timed out");
}

fn signal(child: &Child, sig: &str) {
    assert!(Command::new("kill").args([sig, &child.id().to_string()]).status().unwrap().success());
}

/// The uninterrupted run: (state_hash, probes.csv).
fn uninterrupted(dir: &Path, case: &Path) -> (String, String) {
    let out = dir.join("whole");
    let (code, text) = run(case, &out, &[]);
    assert_eq!(code, Some(0), "{text}");
    (summary(&out)["state_hash"].as_str().unwrap().into(), std::fs::read_to_string(out.join("probes.csv")).unwrap())
}

/// Restart from `ck` into `out` (the same folder): the run ends with the
/// uninterrupted run's `state_hash` and `probes.csv`.
fn restart_matches_uninterrupted(dir: &Path, case: &Path, out: &Path, ck: &Path) {
    let (code, text) = run(case, out, &["--restart", ck.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{text}");
    let (hash, probes) = uninterrupted(dir, case);
    assert_eq!(summary(out)["state_hash"], hash.as_str());
    assert_eq!(std::fs::read_to_string(out.join("probes.csv")).unwrap(), probes, "probes.csv continued");
}

#[test]
fn kill_9_during_a_checkpoint_write_leaves_the_previous_checkpoint_usable() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    let (ck, partial) = (out.join("checkpoint.bin"), out.join("checkpoint.bin.partial"));
    // every checkpoint write pauses 2 s halfway: the first completes, the
    // second is killed in the middle
    let mut child = spawn(cmd(&case, &out, &[]).env("TALUS_TEST_CHECKPOINT_PAUSE_MS", "2000"));
    assert!(wait_for(&mut child, || ck.exists() && partial.exists()), "the run ended before its second checkpoint");
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(partial.exists(), "the half-written file is where the kill left it");
    // the previous checkpoint restarts and the run ends as an uninterrupted one
    restart_matches_uninterrupted(d.path(), &case, &out, &ck);
}

#[test]
fn a_checkpoint_on_a_full_device_fails_the_run_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    // the checkpoint's temporary file is a link to a device that is always full
    std::os::unix::fs::symlink("/dev/full", out.join("checkpoint.bin.partial")).unwrap();
    let (code, text) = run(&case, &out, &[]);
    assert_ne!(code, Some(0), "{text}");
    assert!(text.contains("checkpoint.bin.partial") && text.contains("No space left on device"), "{text}");
    assert!(!out.join("checkpoint.bin").exists(), "no checkpoint may claim to be whole");
}

#[test]
fn kill_9_mid_run_then_a_restart_into_the_same_folder_gives_the_uninterrupted_probes_and_state() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    let ck = out.join("checkpoint.bin");
    // slow checkpoints (0.3 s each) keep the run going long enough to kill it
    // between two of them, with probe rows written after the last
    let mut child = spawn(cmd(&case, &out, &[]).env("TALUS_TEST_CHECKPOINT_PAUSE_MS", "300"));
    let rows = || std::fs::read_to_string(out.join("probes.csv")).map(|s| s.lines().count()).unwrap_or(0);
    assert!(wait_for(&mut child, || ck.exists() && rows() >= 6), "the run ended too soon");
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!out.join("summary.json").exists(), "killed before the end");
    let before = rows();
    assert!(before > 1, "probe rows are flushed at every interval: {before} lines after the kill");
    restart_matches_uninterrupted(d.path(), &case, &out, &ck);
    // snapshots continued too: the same groups, and an XDMF naming each once
    let names = |o: &Path| hdf5_metno::File::open(o.join("snapshots.h5")).unwrap().member_names().unwrap();
    assert_eq!(names(&out), names(&d.path().join("whole")));
    assert_eq!(
        std::fs::read_to_string(out.join("snapshots.xdmf")).unwrap(),
        std::fs::read_to_string(d.path().join("whole").join("snapshots.xdmf")).unwrap()
    );
}

#[test]
fn sigint_writes_a_checkpoint_that_restarts_to_the_uninterrupted_state() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    let mut child = spawn(cmd(&case, &out, &[]).env("TALUS_TEST_CHECKPOINT_PAUSE_MS", "300"));
    let rows = || std::fs::read_to_string(out.join("probes.csv")).map(|s| s.lines().count()).unwrap_or(0);
    assert!(wait_for(&mut child, || rows() >= 4), "the run ended too soon");
    signal(&child, "-INT");
    let (code, text) = finish(child.wait_with_output().unwrap());
    assert_eq!(code, Some(130), "{text}");
    assert!(text.contains("stopped by SIGINT at step") && text.contains("checkpoint.bin"), "{text}");
    let s = summary(&out);
    assert_eq!(s["stopped_by_signal"], "SIGINT");
    assert!(s["steps"].as_u64().unwrap() < 700, "stopped early: {s}");
    restart_matches_uninterrupted(d.path(), &case, &out, &out.join("checkpoint.bin"));
}

#[test]
fn sigterm_exits_143_and_a_second_signal_ends_the_run_at_once() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    // SIGTERM: 143, with its checkpoint (slow checkpoints keep the run going)
    let mut child = spawn(cmd(&case, &out, &[]).env("TALUS_TEST_CHECKPOINT_PAUSE_MS", "300"));
    assert!(wait_for(&mut child, || out.join("probes.csv").exists()), "the run ended too soon");
    signal(&child, "-TERM");
    let (code, text) = finish(child.wait_with_output().unwrap());
    assert_eq!(code, Some(143), "{text}");
    assert!(out.join("checkpoint.bin").exists());
    // a second signal while the checkpoint is being written (paused 20 s) ends it at once
    let out2 = d.path().join("out2");
    let partial = out2.join("checkpoint.bin.partial");
    let mut child = spawn(cmd(&case, &out2, &[]).env("TALUS_TEST_CHECKPOINT_PAUSE_MS", "20000"));
    assert!(wait_for(&mut child, || partial.exists()), "the run ended too soon");
    let t = Instant::now();
    signal(&child, "-INT");
    std::thread::sleep(Duration::from_millis(200));
    signal(&child, "-INT");
    let (code, _) = finish(child.wait_with_output().unwrap());
    assert_eq!(code, Some(130));
    assert!(t.elapsed() < Duration::from_secs(15), "the second signal did not end the run");
    assert!(!out2.join("checkpoint.bin").exists(), "the interrupted write never replaced a checkpoint");
}

#[test]
fn sigterm_to_one_mpi_rank_stops_every_rank_at_the_same_step_with_a_checkpoint() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    let mut child = spawn(
        Command::new("mpirun")
            .args(["--allow-run-as-root", "--oversubscribe", "-n", "2", BIN, "run", case.to_str().unwrap()])
            .args(["--out", out.to_str().unwrap(), "--quiet"])
            .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
            .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
            .env("TALUS_TEST_CHECKPOINT_PAUSE_MS", "300"),
    );
    let rows = || std::fs::read_to_string(out.join("probes.csv")).map(|s| s.lines().count()).unwrap_or(0);
    assert!(wait_for(&mut child, || rows() >= 4), "the run ended too soon");
    // signal one rank only (the youngest talus process under this mpirun)
    let pids = String::from_utf8(Command::new("pgrep").args(["-n", "-P", &child.id().to_string()]).output().unwrap().stdout).unwrap();
    let pid = pids.trim();
    assert!(!pid.is_empty(), "no rank found");
    assert!(Command::new("kill").args(["-TERM", pid]).status().unwrap().success());
    let (code, text) = finish(child.wait_with_output().unwrap());
    assert_ne!(code, Some(0), "{text}");
    let s = summary(&out);
    assert_eq!(s["stopped_by_signal"], "SIGTERM", "{text}");
    assert_eq!(s["ranks"], 2);
    // the checkpoint holds every particle at one step, and restarts serially to the uninterrupted state
    restart_matches_uninterrupted(d.path(), &case, &out, &out.join("checkpoint.bin"));
}

#[test]
fn a_damaged_checkpoint_is_refused_naming_the_file() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    let (code, text) = run(&case, &out, &["--steps", "50"]);
    assert_eq!(code, Some(0), "{text}");
    let ck = out.join("checkpoint.bin");
    let good = std::fs::read(&ck).unwrap();
    let bad = d.path().join("bad.bin");
    for (what, bytes, needle) in [
        ("one flipped byte", { let mut b = good.clone(); b[good.len() / 2] ^= 1; b }, "corrupt checkpoint: checksum"),
        ("truncated", good[..good.len() - 100].to_vec(), "truncated or damaged checkpoint"),
        ("a huge length", { let mut b = good.clone(); b[12..20].copy_from_slice(&u64::MAX.to_le_bytes()); b }, "announces 18446744073709551615 bytes"),
        ("foreign", b"id,x,y,z,radius\n".to_vec(), "not a talus checkpoint"),
    ] {
        std::fs::write(&bad, bytes).unwrap();
        let (code, text) = run(&case, &d.path().join("r"), &["--restart", bad.to_str().unwrap()]);
        assert_eq!(code, Some(1), "{what}: {text}");
        assert!(text.contains("bad.bin") && text.contains(needle), "{what}: {text}");
    }
}

#[test]
fn a_new_run_removes_a_stale_failure_checkpoint() {
    let d = tempfile::tempdir().unwrap();
    let case = small_hopper(d.path());
    let out = d.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("failure_checkpoint.bin"), b"from an earlier run").unwrap();
    let (code, text) = run(&case, &out, &["--steps", "5"]);
    assert_eq!(code, Some(0), "{text}");
    assert!(!out.join("failure_checkpoint.bin").exists());
}
