//! The run driver behind `talus run`: phases, the observers that write the
//! outputs (`crate::observe`), checkpoints at phase ends, failures and signals,
//! the summary.

use crate::case::Case;
use crate::checkpoint::{read as read_checkpoint, write as write_checkpoint};
use crate::durable::write_atomic;
use crate::error::TalusError;
use crate::observe::{AnalysisLog, Checkpoints, FinalState, Observer, ProbeLog, Progress, RankLog, SnapshotLog};
use crate::output::{Probes, Snapshots};
use crate::parallel::comm::Comm;
use crate::sim::Simulation;
use serde_json::{json, Map, Value};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::rc::Rc;
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
    let interrupted = sim.stop_signal();
    Ok(RunResult { summary, sim, interrupted })
}

/// The observers of a run, in the order they run after each step: analysis,
/// then (writing into `out`) probes, rank log, snapshots, interval
/// checkpoints, progress bar. A simulation restarted from a checkpoint (step >
/// 0) continues the series already in `out`: rows and snapshots after the
/// checkpoint's step are dropped, new ones appended. At step 0 the first probe
/// row and snapshot are written here. Without `out`, only the analysis (a run
/// driven from Python that writes no files).
fn run_observers(sim: &mut Simulation, out: Option<&Path>, progress: bool) -> Result<Vec<Box<dyn Observer>>, TalusError> {
    let root = sim.parallel().comm.is_root();
    let resume = (sim.step_count() > 0).then_some(sim.step_count());
    let mut analysis = AnalysisLog;
    if resume.is_none() {
        analysis.start(sim);
    }
    let mut obs: Vec<Box<dyn Observer>> = vec![Box::new(analysis)];
    let Some(out) = out else { return Ok(obs) };
    let mut probes = ProbeLog::new(sim.parallel().collective(Probes::create(out, sim, resume))?);
    let ranks = RankLog::create(out, sim, resume)?;
    if resume.is_none() {
        probes.write(sim)?;
    }
    obs.push(Box::new(probes));
    obs.push(Box::new(ranks));
    if sim.case().phases.iter().any(|p| !p.inserts.is_empty()) {
        let log = crate::observe::InsertLog::create(out, sim, resume);
        obs.push(Box::new(sim.parallel().collective(log)?));
    }
    if let Some(iv) = sim.case().output.snapshot_interval {
        let domain = sim.fields_domain();
        let two_d = sim.case().simulation.dimension == crate::dim::Dimension::Two;
        let snaps = if root { Some(Snapshots::create(out, resume, sim.dt(), domain, two_d)) } else { None };
        let mut snaps = SnapshotLog::new(sim.parallel().collective(snaps.transpose())?, iv);
        if resume.is_none() {
            snaps.write(sim)?;
        }
        obs.push(Box::new(snaps));
    }
    if let Some(f) = crate::fields::live::FieldsLog::create(sim, out, resume.is_some())? {
        obs.push(Box::new(f));
    }
    if let Some(iv) = sim.case().output.checkpoint_interval {
        obs.push(Box::new(Checkpoints::new(out, iv)));
    }
    if sim.case().output.final_state {
        obs.push(Box::new(FinalState::new(out)));
    }
    // the count is a collective: every rank makes it, rank 0 alone shows the bar
    let n = sim.particle_count() as f64;
    if progress && root {
        obs.push(Box::new(Progress::new(sim, n)));
    }
    Ok(obs)
}

/// A run in progress: the observers, where the outputs go, the clock. `talus
/// run` drives one to the end (`run_sim`); the Python module drives one step
/// by step, with its callbacks between steps. Each step is `end_of_phase`
/// then `step`.
pub struct Runner {
    out: Option<PathBuf>,
    /// Where a failure checkpoint goes (`out`, or a folder named for a run without one).
    fail_dir: PathBuf,
    observers: Vec<Box<dyn Observer>>,
    start: Instant,
    first_step: u64,
    /// The kinetic energy no run of this case can reach unless it goes wrong.
    watch: EnergyWatch,
}

/// A run that blows up (a time step far too large for its contacts: energy
/// made from nothing) is stopped, not run to its end: where nothing feeds the
/// particles energy (no wall moves, nothing is inserted, gravity has no part
/// along a periodic axis), their kinetic energy can never exceed what they
/// started with plus their weight falling through the whole domain. Every
/// `EnergyWatch::EVERY` steps the kinetic energy (a collective) is held
/// against 100 times that.
struct EnergyWatch {
    /// Joules; None where something feeds the particles energy.
    limit: Option<f64>,
    /// What the limit is made of, for the message.
    basis: String,
}

impl EnergyWatch {
    const EVERY: u64 = 20;
    const FACTOR: f64 = 100.0;

    /// A collective (every rank makes the same sums).
    fn new(sim: &Simulation) -> EnergyWatch {
        let c = sim.case();
        let moves = c.walls.iter().any(|w| w.velocity != [0.0; 3] || w.rotation.is_some() || w.oscillation.is_some() || w.servo.is_some())
            || c.phases.iter().any(|p| !p.moves.is_empty() || !p.inserts.is_empty());
        let d = &c.simulation.domain;
        let g = c.simulation.gravity;
        let periodic_fall = (0..3).any(|k| d.is_periodic(k) && g[k] != 0.0);
        let ke = sim.kinetic_energy();
        let mut m = [crate::fixed::to_fixed(sim.particles().total_mass())];
        sim.sum_exact(&mut m);
        let mass = crate::fixed::from_fixed(m[0]);
        let fall: f64 = mass * (0..3).map(|k| g[k].abs() * (d.hi[k] - d.lo[k])).sum::<f64>();
        let base = ke + fall;
        let limit = (!moves && !periodic_fall && base > 0.0).then_some(Self::FACTOR * base);
        let basis = format!("the initial kinetic energy {ke:.4e} J plus the particles' weight falling through the whole domain, {fall:.4e} J");
        EnergyWatch { limit, basis }
    }

    /// Whether the run has gone wrong at this step (a collective on the steps it checks).
    fn check(&self, sim: &Simulation) -> Result<(), TalusError> {
        let Some(limit) = self.limit else { return Ok(()) };
        if sim.step_count() % Self::EVERY != 0 {
            return Ok(());
        }
        // each rank's own sum in floating point (no fixed-point conversion per
        // particle: this runs while the run goes), then the ranks' sums exactly
        let mine = sim.particles().kinetic_energy_float();
        // (a NaN or an energy past 1e15 J counts as 1e15 J: the fixed-point sum holds 9e18 J)
        let mut v = [crate::fixed::to_fixed(if mine.is_finite() { mine.min(1e15) } else { 1e15 })];
        sim.sum_exact(&mut v);
        let ke = crate::fixed::from_fixed(v[0]);
        if ke <= limit {
            return Ok(());
        }
        let s = &sim.case().simulation;
        let dt = sim.dt();
        let step = match s.timestep {
            crate::case::TimeStep::Seconds(x) => format!("simulation.timestep = {x}"),
            crate::case::TimeStep::RayleighFraction(f) => format!("simulation.timestep_rayleigh_fraction = {f}"),
        };
        Err(TalusError::Run(format!(
            "the kinetic energy grew to {ke:.4e} J, more than {} times what the case can give ({}), with no wall moving and nothing inserted: the run made energy from nothing; is the time step ({step}: {dt:.4e} s, {:.0}% of the Rayleigh time) too large for its contacts?",
            Self::FACTOR,
            self.basis,
            100.0 * dt / sim.rayleigh_time()
        )))
    }
}

impl Runner {
    /// Start a run of `sim` writing into `out` (created; a failure checkpoint
    /// left there by an earlier run is removed), or writing no files with
    /// `out` None (then a failure checkpoint goes into `fail_dir`). Computes
    /// the forces at the current state first.
    pub fn start(sim: &mut Simulation, out: Option<&Path>, fail_dir: &Path, progress: bool) -> Result<Runner, TalusError> {
        let root = sim.parallel().comm.is_root();
        if let Some(out) = out {
            let prepared = std::fs::create_dir_all(out)
                .map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))
                .and_then(|()| if root { remove_stale_failure(out) } else { Ok(()) });
            sim.parallel().collective(prepared)?;
        }
        sim.prepare()?;
        let observers = run_observers(sim, out, progress)?;
        test_hooks(sim);
        let watch = EnergyWatch::new(sim);
        Ok(Runner {
            out: out.map(Path::to_path_buf),
            fail_dir: out.unwrap_or(fail_dir).to_path_buf(),
            observers,
            start: Instant::now(),
            first_step: sim.step_count(),
            watch,
        })
    }

    /// The output folder, if the run writes files.
    pub fn out(&self) -> Option<&Path> {
        self.out.as_deref()
    }

    /// Whether the current phase is over: if so, the observers mark its end and
    /// (with an output folder) the phase-end checkpoint is written. Returns
    /// false once every phase is done.
    pub fn end_of_phase(&mut self, sim: &mut Simulation) -> Result<bool, TalusError> {
        let phase = sim.phase();
        let more = sim.advance_phase()?;
        if sim.phase() != phase {
            // a checkpoint at the end of each phase (to restart, say, the discharge on another P)
            let name = sim.case().phases[phase].name.clone();
            for o in self.observers.iter_mut() {
                o.phase_ended(sim, &name)?;
            }
            if let Some(out) = &self.out {
                write_checkpoint(sim, &out.join(format!("checkpoint_after_{name}.bin")))?;
            }
        }
        Ok(more)
    }

    /// One time step, then every observer. A failure (NaN, a particle leaving
    /// the domain) writes the failure checkpoint and flushes the outputs first.
    pub fn step(&mut self, sim: &mut Simulation) -> Result<(), TalusError> {
        let t_prev = sim.time();
        if let Err(e) = sim.step().and_then(|()| self.watch.check(sim)) {
            return Err(failed(sim, &self.fail_dir, &mut self.observers, e));
        }
        for o in self.observers.iter_mut() {
            o.after_step(sim, t_prev)?;
        }
        Ok(())
    }

    /// One step of the run: `end_of_phase`, then `step` unless every phase
    /// was done (then false).
    pub fn advance(&mut self, sim: &mut Simulation) -> Result<bool, TalusError> {
        if !self.end_of_phase(sim)? {
            return Ok(false);
        }
        self.step(sim)?;
        Ok(true)
    }

    /// The summary so far (the observers' figures and the run's), without
    /// ending the run or writing anything.
    pub fn summary(&mut self, sim: &mut Simulation) -> Result<Map<String, Value>, TalusError> {
        let mut summary = Map::new();
        AnalysisLog.finish(sim, &mut summary)?;
        summary.extend(self.figures(sim));
        Ok(summary)
    }

    /// End the run: the observers flush and add their figures; with an output
    /// folder, `checkpoint.bin` and `summary.json` are written. Returns the summary.
    pub fn finish(&mut self, sim: &mut Simulation) -> Result<Map<String, Value>, TalusError> {
        let mut summary = Map::new();
        for o in self.observers.iter_mut() {
            o.finish(sim, &mut summary)?;
        }
        if let Some(out) = &self.out {
            write_checkpoint(sim, &out.join("checkpoint.bin"))?;
        }
        summary.extend(self.figures(sim));
        if let Some(out) = &self.out {
            let path = out.join("summary.json");
            let written = if sim.parallel().comm.is_root() {
                let text = serde_json::to_string_pretty(&summary).unwrap() + "\n";
                write_atomic(&path, |w| w.write_all(text.as_bytes()))
            } else {
                Ok(())
            };
            sim.parallel().collective(written)?;
        }
        Ok(summary)
    }

    /// The run's own figures: counts, times, throughput, the state hash (a collective).
    fn figures(&self, sim: &Simulation) -> Map<String, Value> {
        let wall = self.start.elapsed().as_secs_f64();
        let n = sim.particle_count() as f64;
        let steps = sim.step_count() - self.first_step;
        let mut summary = Map::new();
        summary.insert("case".into(), json!(sim.case().path.display().to_string()));
        summary.insert("particles".into(), json!(n as u64));
        summary.insert("ranks".into(), json!(sim.parallel().size()));
        summary.insert("threads".into(), json!(sim.threads()));
        summary.insert("grid".into(), json!(sim.parallel().dec.grid()));
        summary.insert("balance".into(), json!(sim.case().parallel.balance));
        summary.insert("rebalances".into(), json!(sim.parallel().rebalances));
        summary.insert("steps".into(), json!(sim.step_count()));
        summary.insert("steps_this_run".into(), json!(steps));
        summary.insert("time_s".into(), json!(sim.time()));
        summary.insert("timestep_s".into(), json!(sim.dt()));
        summary.insert("rayleigh_time_s".into(), json!(sim.rayleigh_time()));
        summary.insert("neighbor_builds".into(), json!(sim.state().nl.builds));
        let tm = &sim.parallel().timers;
        // this rank's (rank 0's) seconds in each stage of the step, this run
        summary.insert(
            "stage_seconds".into(),
            json!({
                "forces": tm.forces, "integrate": tm.integrate, "list_build": tm.list_build,
                "migrate_and_ghosts": tm.migrate, "ghost_refresh": tm.ghost_refresh,
                "check_and_agree": tm.check, "wall_sums": tm.wall_sums,
            }),
        );
        summary.insert("wall_clock_s".into(), json!(wall));
        summary.insert("particle_steps_per_s".into(), json!(if wall > 0.0 { n * steps as f64 / wall } else { 0.0 }));
        summary.insert("state_hash".into(), json!(sim.state_hash()));
        if let Some(sig) = sim.stop_signal() {
            summary.insert("stopped_by_signal".into(), json!(crate::signals::name(sig)));
        }
        summary
    }
}

/// Test hooks for the check that every rank makes the same collectives
/// (`crate::parallel::comm::SequenceCheck`, tests/mpi.rs), as a run starts:
/// `TALUS_TEST_EXTRA_COLLECTIVE_RANK=R` makes rank R alone count the
/// particles (a collective: the mistake the check is there to catch);
/// `TALUS_TEST_STALL_RANK=R:S` makes rank R sleep S seconds.
fn test_hooks(sim: &Simulation) {
    let rank = sim.parallel().rank().to_string();
    if std::env::var("TALUS_TEST_EXTRA_COLLECTIVE_RANK").is_ok_and(|r| r == rank) {
        sim.particle_count();
    }
    if let Some((r, s)) = std::env::var("TALUS_TEST_STALL_RANK").ok().as_deref().and_then(|v| v.split_once(':')) {
        if r == rank {
            std::thread::sleep(std::time::Duration::from_secs_f64(s.parse().unwrap_or(0.0)));
        }
    }
}

/// Run an already built simulation; writes outputs and summary.json into `opts.out`
/// and returns the summary.
pub fn run_sim(sim: &mut Simulation, opts: &RunOptions) -> Result<Map<String, Value>, TalusError> {
    let mut runner = Runner::start(sim, Some(&opts.out), &opts.out, opts.progress)?;
    let first_step = sim.step_count();
    loop {
        // the step limit is checked first, so a checkpoint taken here restarts at
        // exactly the point where an uninterrupted run would go on
        if opts.max_steps.is_some_and(|m| sim.step_count() - first_step >= m) {
            break;
        }
        if !runner.advance(sim)? {
            break;
        }
        if sim.stop_signal().is_some() {
            // a signal: every rank agreed on this step; the checkpoint and the
            // outputs are written below as at the end of a run
            break;
        }
    }
    if std::env::var_os("TALUS_PROFILE").is_some() {
        let t = sim.parallel().timers;
        eprintln!(
            "talus profile rank {}: migrate+ghosts {:.3} s, list builds {:.3} s, ghost refresh {:.3} s, agree {:.3} s, wall sums {:.3} s, compute since the last output row {:.3} s, of {:.3} s",
            sim.parallel().rank(), t.migrate, t.list_build, t.ghost_refresh, t.agree, t.wall_sums, t.compute_s,
            runner.start.elapsed().as_secs_f64()
        );
    }
    runner.finish(sim)
}

/// A step failed (NaN, a particle leaving the domain): every rank gets here at
/// the same step (failures are agreed on collectively), so all write the
/// failure checkpoint together; the series written so far are flushed.
fn failed(sim: &mut Simulation, out: &Path, observers: &mut [Box<dyn Observer>], e: TalusError) -> TalusError {
    let ck = out.join("failure_checkpoint.bin");
    let made = std::fs::create_dir_all(out).map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e));
    let saved = match sim.parallel().collective(made).and_then(|()| write_checkpoint(sim, &ck)) {
        Ok(()) => format!("checkpoint of all ranks written to {}", ck.display()),
        Err(w) => format!("no checkpoint: {w}"),
    };
    let flushed: Vec<String> = observers.iter_mut().filter_map(|o| o.flush().err().map(|e| e.to_string())).collect();
    let lost = if flushed.is_empty() { String::new() } else { format!("; {}", flushed.join("; ")) };
    TalusError::Run(format!("run stopped at step {} (t = {:.6e} s): {e}; {saved}{lost}", sim.step_count(), sim.time()))
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

/// Load a case file and run it.
pub fn run_file(case: &Path, opts: &RunOptions) -> Result<RunResult, TalusError> {
    run(Case::load(case)?, opts)
}
