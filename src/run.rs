//! The run driver behind `talus run`: phases, probes, snapshots, checkpoints,
//! the progress bar and the summary.

use crate::case::Case;
use crate::checkpoint::{read as read_checkpoint, write as write_checkpoint};
use crate::durable::{write_atomic, Series};
use crate::error::TalusError;
use crate::output::{Probes, Snapshots};
use crate::parallel::comm::Comm;
use crate::sim::Simulation;
use std::io::Write;
use std::rc::Rc;
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    pub out: PathBuf,
    /// Stop after this many steps in this invocation.
    pub max_steps: Option<u64>,
    /// Continue from this checkpoint.
    pub restart: Option<PathBuf>,
    pub progress: bool,
}

/// What a finished run reports.
pub struct RunResult {
    pub summary: Map<String, Value>,
    pub sim: Simulation,
    /// The signal (SIGINT, SIGTERM) that stopped the run early, after its
    /// checkpoint and outputs were written.
    pub interrupted: Option<i32>,
}

fn crossed(t_prev: f64, t: f64, interval: f64, dt: f64) -> bool {
    ((t + 0.5 * dt) / interval).floor() > ((t_prev + 0.5 * dt) / interval).floor()
}

/// Run a case into `opts.out` (serial).
pub fn run(case: Case, opts: &RunOptions) -> Result<RunResult, TalusError> {
    run_on(case, opts, Rc::new(Comm::Serial))
}

/// Run a case on a communicator (every rank calls this).
pub fn run_on(case: Case, opts: &RunOptions, comm: Rc<Comm>) -> Result<RunResult, TalusError> {
    let mut sim = Simulation::new_on(case, comm)?;
    if let Some(r) = &opts.restart {
        read_checkpoint(&mut sim, r)?;
    }
    let summary = run_sim(&mut sim, opts)?;
    let interrupted = sim.par.stop;
    Ok(RunResult { summary, sim, interrupted })
}

/// Run an already built simulation; writes outputs and summary.json into `opts.out`
/// and returns the summary. A simulation restarted from a checkpoint (step > 0)
/// continues the series already in `opts.out`: rows and snapshots after the
/// checkpoint's step are dropped, new ones appended.
pub fn run_sim(sim: &mut Simulation, opts: &RunOptions) -> Result<Map<String, Value>, TalusError> {
    let out = &opts.out;
    let root = sim.par.comm.is_root();
    let dt = sim.set.dt;
    let prepared = std::fs::create_dir_all(out)
        .map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))
        .and_then(|()| if root { remove_stale_failure(out) } else { Ok(()) });
    sim.par.collective(prepared)?;
    let resume = (sim.state.step > 0).then_some(sim.state.step);
    let mut probes = sim.par.collective(Probes::create(out, sim, resume))?;
    let snaps = match (sim.case.output.snapshot_interval, root) {
        (Some(_), true) => Some(Snapshots::create(out, resume, dt)),
        _ => None,
    }
    .transpose();
    let mut snaps = sim.par.collective(snaps)?;
    let want_snaps = sim.case.output.snapshot_interval.is_some();
    let mut ranks = RankLog::create(out, sim, resume)?;
    let interval = sim.case.output.interval;
    sim.prepare()?;
    if sim.state.step == 0 {
        sim.par.collective(probes.write(sim))?;
        if want_snaps {
            write_snapshot(sim, &mut snaps)?;
        }
    }
    let n = sim.particle_count() as f64;
    let planned_steps = (sim.planned_time() / dt).ceil() as u64;
    let bar = if opts.progress && root {
        let b = indicatif::ProgressBar::new(planned_steps);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:30} step {pos}/{len}  {msg}  ETA {eta}",
            )
            .unwrap(),
        );
        b.set_position(sim.state.step);
        Some(b)
    } else {
        None
    };
    let start = Instant::now();
    let first_step = sim.state.step;
    let mut steps = 0u64;
    loop {
        // the step limit is checked first, so a checkpoint taken here restarts at
        // exactly the point where an uninterrupted run would go on
        if opts.max_steps.is_some_and(|m| steps >= m) {
            break;
        }
        let phase = sim.state.phase;
        let more = sim.advance_phase()?;
        if sim.state.phase != phase {
            // a checkpoint at the end of each phase (to restart, say, the discharge on another P)
            let name = sim.case.phases[phase].name.clone();
            write_checkpoint(sim, &out.join(format!("checkpoint_after_{name}.bin")))?;
        }
        if !more {
            break;
        }
        let t_prev = sim.state.time;
        if let Err(e) = sim.step() {
            // every rank gets here at the same step (failures are agreed on
            // collectively), so all write the checkpoint together
            let ck = out.join("failure_checkpoint.bin");
            let saved = match write_checkpoint(sim, &ck) {
                Ok(()) => format!("checkpoint of all ranks written to {}", ck.display()),
                Err(w) => format!("no checkpoint: {w}"),
            };
            probes.flush()?;
            ranks.flush()?;
            return Err(TalusError::Run(format!(
                "run stopped at step {} (t = {:.6e} s): {e}; {saved}",
                sim.state.step, sim.state.time
            )));
        }
        steps += 1;
        let t = sim.state.time;
        if crossed(t_prev, t, interval, dt) {
            let mb = sim.par.collective(probes.write(sim))?;
            sim.state.analysis.sample(t, mb.unwrap_or(0.0));
            ranks.write(sim)?;
        }
        if let Some(iv) = sim.case.output.snapshot_interval {
            if crossed(t_prev, t, iv, dt) {
                write_snapshot(sim, &mut snaps)?;
            }
        }
        if let Some(iv) = sim.case.output.checkpoint_interval {
            if crossed(t_prev, t, iv, dt) {
                write_checkpoint(sim, &out.join("checkpoint.bin"))?;
            }
        }
        if sim.par.stop.is_some() {
            // a signal: every rank agreed on this step; the checkpoint and the
            // outputs are written below as at the end of a run
            break;
        }
        if let Some(b) = &bar {
            if steps % 200 == 0 {
                let rate = n * steps as f64 / start.elapsed().as_secs_f64();
                b.set_position(sim.state.step);
                b.set_message(format!("t = {t:.4} s  {:.2e} particle-steps/s", rate));
            }
        }
    }
    let wall = start.elapsed().as_secs_f64();
    if std::env::var_os("TALUS_PROFILE").is_some() {
        let t = sim.par.timers;
        eprintln!(
            "talus profile rank {}: migrate+ghosts {:.3} s, list builds {:.3} s, ghost refresh {:.3} s, agree {:.3} s, wall sums {:.3} s, compute since the last output row {:.3} s, of {wall:.3} s",
            sim.par.rank(), t.migrate, t.list_build, t.ghost_refresh, t.agree, t.wall_sums, t.compute_s
        );
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    sim.par.collective(probes.flush())?;
    ranks.flush()?;
    write_checkpoint(sim, &out.join("checkpoint.bin"))?;
    let mut summary = Map::new();
    summary.insert("case".into(), json!(sim.case.path.display().to_string()));
    summary.insert("particles".into(), json!(n as u64));
    summary.insert("ranks".into(), json!(sim.par.size()));
    summary.insert("grid".into(), json!(sim.par.dec.grid()));
    summary.insert("balance".into(), json!(sim.case.parallel.balance));
    summary.insert("rebalances".into(), json!(sim.par.rebalances));
    for (k, v) in ranks.summary(sim) {
        summary.insert(k, v);
    }
    summary.insert("steps".into(), json!(sim.state.step));
    summary.insert("steps_this_run".into(), json!(sim.state.step - first_step));
    summary.insert("time_s".into(), json!(sim.state.time));
    summary.insert("timestep_s".into(), json!(dt));
    summary.insert("rayleigh_time_s".into(), json!(sim.set.rayleigh_time));
    summary.insert("neighbor_builds".into(), json!(sim.state.nl.builds));
    summary.insert("wall_clock_s".into(), json!(wall));
    summary.insert(
        "particle_steps_per_s".into(),
        json!(if wall > 0.0 { n * steps as f64 / wall } else { 0.0 }),
    );
    summary.insert("state_hash".into(), json!(sim.state_hash()));
    if let Some(sig) = sim.par.stop {
        summary.insert("stopped_by_signal".into(), json!(crate::signals::name(sig)));
    }
    let tracked = sim.tracked(&sim.state.analysis.ids());
    for (k, v) in sim.state.analysis.figures(&tracked) {
        summary.insert(k, v);
    }
    let path = out.join("summary.json");
    let written = if root {
        let text = serde_json::to_string_pretty(&summary).unwrap() + "\n";
        write_atomic(&path, |w| w.write_all(text.as_bytes()))
    } else {
        Ok(())
    };
    sim.par.collective(written)?;
    Ok(summary)
}

/// A failure checkpoint left by an earlier run in this folder would be taken
/// for this run's: removed when a run starts.
fn remove_stale_failure(out: &Path) -> Result<(), TalusError> {
    let f = out.join("failure_checkpoint.bin");
    match std::fs::remove_file(&f) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(TalusError::io(format!("cannot remove {}", f.display()), e)),
        _ => Ok(()),
    }
}

/// Gather every particle and let rank 0 write a snapshot (a collective).
fn write_snapshot(sim: &Simulation, snaps: &mut Option<Snapshots>) -> Result<(), TalusError> {
    let (recs, _) = sim.par.gather_all(&sim.state.p, &sim.state.gear);
    let r = match snaps.as_mut() {
        Some(s) => s.write(&sim.state, &recs),
        None => Ok(()),
    };
    sim.par.collective(r)
}

/// Per-rank diagnostics (`ranks.csv`): at each output interval, every rank's
/// owned particles, ghosts, contacts evaluated, compute and communication time
/// over the interval, and the imbalance (max over mean) of compute time and of
/// work (particles + contacts). Rank 0 writes; the means per phase go into the summary.
struct RankLog {
    out: Option<Series>,
    /// Per phase: (sum of time imbalance, sum of work imbalance, rows).
    per_phase: Vec<(String, f64, f64, u64)>,
}

impl RankLog {
    fn create(dir: &Path, sim: &Simulation, resume: Option<u64>) -> Result<RankLog, TalusError> {
        const HEADER: &str = "time_s,step,phase,rank,owned,ghosts,contacts,compute_s,comm_s,imbalance_time,imbalance_work";
        let out = if sim.par.comm.is_root() { Some(Series::open(&dir.join("ranks.csv"), HEADER, 1, resume)) } else { None };
        let out = sim.par.collective(out.transpose())?;
        Ok(RankLog { out, per_phase: Vec::new() })
    }

    fn write(&mut self, sim: &mut Simulation) -> Result<(), TalusError> {
        let c = sim.par.gather_counters(&sim.state.p);
        let imb = |f: &dyn Fn(&crate::parallel::RankCounters) -> f64| {
            let v: Vec<f64> = c.iter().map(f).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            if mean > 0.0 { v.iter().cloned().fold(0.0, f64::max) / mean } else { 1.0 }
        };
        let it = imb(&|r| r.compute_s);
        let iw = imb(&|r| (r.owned + r.contacts) as f64);
        let phase = sim.case.phases.get(sim.state.phase).map(|p| p.name.clone()).unwrap_or_else(|| "end".into());
        match self.per_phase.iter_mut().find(|x| x.0 == phase) {
            Some(e) => {
                e.1 += it;
                e.2 += iw;
                e.3 += 1;
            }
            None => self.per_phase.push((phase.clone(), it, iw, 1)),
        }
        if let Some(w) = self.out.as_mut() {
            for (r, x) in c.iter().enumerate() {
                w.row(&format!(
                    "{:.9e},{},{phase},{r},{},{},{},{:.6e},{:.6e},{it:.5},{iw:.5}",
                    sim.state.time, sim.state.step, x.owned, x.ghosts, x.contacts, x.compute_s, x.comm_s
                ))?;
            }
            w.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), TalusError> {
        match self.out.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }

    /// Mean imbalance per phase (max over mean across ranks, averaged over the output rows).
    fn summary(&self, sim: &Simulation) -> Vec<(String, Value)> {
        if sim.par.size() == 1 {
            return Vec::new();
        }
        let mut v = Vec::new();
        for (ph, it, iw, n) in &self.per_phase {
            v.push((format!("imbalance_time_{ph}"), json!(it / *n as f64)));
            v.push((format!("imbalance_work_{ph}"), json!(iw / *n as f64)));
        }
        v
    }
}

/// Load a case file and run it.
pub fn run_file(case: &Path, opts: &RunOptions) -> Result<RunResult, TalusError> {
    run(Case::load(case)?, opts)
}
