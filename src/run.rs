//! The run driver behind `talus run`: phases, probes, snapshots, checkpoints,
//! the progress bar and the summary.

use crate::case::Case;
use crate::error::TalusError;
use crate::output::{read_checkpoint, write_checkpoint, Probes, Snapshots};
use crate::sim::Simulation;
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
}

fn crossed(t_prev: f64, t: f64, interval: f64, dt: f64) -> bool {
    ((t + 0.5 * dt) / interval).floor() > ((t_prev + 0.5 * dt) / interval).floor()
}

/// Run a case into `opts.out`.
pub fn run(case: Case, opts: &RunOptions) -> Result<RunResult, TalusError> {
    let mut sim = Simulation::new(case)?;
    if let Some(r) = &opts.restart {
        read_checkpoint(&mut sim, r)?;
    }
    let summary = run_sim(&mut sim, opts)?;
    Ok(RunResult { summary, sim })
}

/// Run an already built simulation; writes outputs and summary.json into `opts.out`
/// and returns the summary.
pub fn run_sim(sim: &mut Simulation, opts: &RunOptions) -> Result<Map<String, Value>, TalusError> {
    let out = &opts.out;
    std::fs::create_dir_all(out).map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))?;
    let mut probes = Probes::create(out, sim)?;
    let mut snaps = match sim.case.output.snapshot_interval {
        Some(_) => Some(Snapshots::create(out)?),
        None => None,
    };
    let dt = sim.set.dt;
    let interval = sim.case.output.interval;
    sim.prepare()?;
    if sim.state.step == 0 {
        probes.write(sim)?;
        if let Some(s) = snaps.as_mut() {
            s.write(&sim.state)?;
        }
    }
    let n = sim.state.p.len() as f64;
    let planned_steps = (sim.planned_time() / dt).ceil() as u64;
    let bar = if opts.progress {
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
        if !sim.advance_phase()? {
            break;
        }
        let t_prev = sim.state.time;
        if let Err(e) = sim.step() {
            let ck = out.join("failure_checkpoint.bin");
            let saved = match write_checkpoint(sim, &ck) {
                Ok(()) => format!("checkpoint written to {}", ck.display()),
                Err(w) => format!("no checkpoint: {w}"),
            };
            probes.flush()?;
            return Err(TalusError::Run(format!(
                "run stopped at step {} (t = {:.6e} s): {e}; {saved}",
                sim.state.step, sim.state.time
            )));
        }
        steps += 1;
        let t = sim.state.time;
        if crossed(t_prev, t, interval, dt) {
            let mb = probes.write(sim)?;
            sim.state.analysis.sample(t, mb.unwrap_or(0.0));
        }
        if let (Some(s), Some(iv)) = (snaps.as_mut(), sim.case.output.snapshot_interval) {
            if crossed(t_prev, t, iv, dt) {
                s.write(&sim.state)?;
            }
        }
        if let Some(iv) = sim.case.output.checkpoint_interval {
            if crossed(t_prev, t, iv, dt) {
                write_checkpoint(sim, &out.join("checkpoint.bin"))?;
            }
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
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    probes.flush()?;
    write_checkpoint(sim, &out.join("checkpoint.bin"))?;
    let mut summary = Map::new();
    summary.insert("case".into(), json!(sim.case.path.display().to_string()));
    summary.insert("particles".into(), json!(sim.state.p.len()));
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
    for (k, v) in sim.state.analysis.figures(&sim.state) {
        summary.insert(k, v);
    }
    let path = out.join("summary.json");
    std::fs::write(&path, serde_json::to_string_pretty(&summary).unwrap() + "\n")
        .map_err(|e| TalusError::io(format!("writing {}", path.display()), e))?;
    Ok(summary)
}

/// Load a case file and run it.
pub fn run_file(case: &Path, opts: &RunOptions) -> Result<RunResult, TalusError> {
    run(Case::load(case)?, opts)
}
