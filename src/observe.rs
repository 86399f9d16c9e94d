//! Bookkeeping as observers the driver registers: the analysis, probes, the per-rank log,
//! snapshots, interval checkpoints, the progress bar (here), the drag series
//! (`crate::drag`). The time step (`Simulation::step`) knows none of them.
//!
//! After every step the driver calls each observer's `after_step` in the order
//! they were registered; every rank calls it (an observer that gathers is a
//! collective). At the end of a run, or when a signal stops it, `finish` flushes
//! and adds the observer's figures to the summary; after a failure, `flush`
//! saves what was written.

use crate::analysis::Analysis;
use crate::checkpoint;
use crate::error::TalusError;
use crate::output::{Probes, Snapshots};
use crate::sim::Simulation;
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Something the driver calls after every step.
pub trait Observer {
    /// After a step that went from `t_prev` to `sim.time()`.
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError>;
    /// At the end of the run: flush, and add figures to the summary.
    fn finish(&mut self, _sim: &mut Simulation, _summary: &mut Map<String, Value>) -> Result<(), TalusError> {
        Ok(())
    }
    /// After a failure: save what was written so far.
    fn flush(&mut self) -> Result<(), TalusError> {
        Ok(())
    }
    /// When phase `name` has ended (before the phase-end checkpoint is written).
    fn phase_ended(&mut self, _sim: &mut Simulation, _name: &str) -> Result<(), TalusError> {
        Ok(())
    }
}

/// Advance one step, then let every observer see it (in order).
pub fn step(sim: &mut Simulation, observers: &mut [&mut dyn Observer]) -> Result<(), TalusError> {
    let t_prev = sim.time();
    sim.step()?;
    for o in observers.iter_mut() {
        o.after_step(sim, t_prev)?;
    }
    Ok(())
}

/// Whether a step from `t_prev` to `t` crossed a multiple of `interval` (half a
/// step of tolerance, so rounding of t = step dt never skips or repeats one).
pub fn crossed(t_prev: f64, t: f64, interval: f64, dt: f64) -> bool {
    ((t + 0.5 * dt) / interval).floor() > ((t_prev + 0.5 * dt) / interval).floor()
}

/// The case's `[analysis]` (`crate::analysis`): records after every step,
/// samples the mass below `output.mass_below_z` at every output interval, marks
/// phase ends, and puts its figures into the summary. Its running figures live
/// in the simulation's state, so checkpoints save them.
pub struct AnalysisLog;

impl AnalysisLog {
    /// Record the current state (a collective: the tracked particles are
    /// gathered from whichever ranks own them).
    pub fn record(&mut self, sim: &mut Simulation) {
        let ids = sim.analysis().ids();
        let tracked = if ids.is_empty() { Vec::new() } else { sim.tracked(&ids) };
        let mut a = std::mem::replace(sim.analysis_mut(), Analysis::None);
        a.record(sim.state(), &tracked);
        *sim.analysis_mut() = a;
    }

    /// Sample the mass below the probe plane (0 without one; a collective).
    pub fn sample(&mut self, sim: &mut Simulation) {
        let mb = sim.case().output.mass_below_z.map(|z| sim.mass_below(z)).unwrap_or(0.0);
        let t = sim.time();
        sim.analysis_mut().sample(t, mb);
    }

    /// The first record and sample of a run that starts at step 0.
    pub fn start(&mut self, sim: &mut Simulation) {
        self.record(sim);
        self.sample(sim);
    }
}

impl Observer for AnalysisLog {
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError> {
        self.record(sim);
        if crossed(t_prev, sim.time(), sim.case().output.interval, sim.dt()) {
            self.sample(sim);
        }
        Ok(())
    }
    fn phase_ended(&mut self, sim: &mut Simulation, name: &str) -> Result<(), TalusError> {
        let t = sim.time();
        sim.analysis_mut().phase_end(name, t);
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, summary: &mut Map<String, Value>) -> Result<(), TalusError> {
        let tracked = sim.tracked(&sim.analysis().ids());
        summary.extend(sim.analysis().figures(&tracked));
        Ok(())
    }
}

/// `inserted.csv`: every particle a `[[phase.insert]]` inserted, the step at
/// whose start it came in, where, how fast, how big (what the exporters need
/// to bring the same particles into LIGGGHTS or YADE at the same steps).
pub struct InsertLog {
    out: Option<crate::durable::Series>,
}

impl InsertLog {
    pub const HEADER: &'static str = "step,time_s,id,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,radius_m,material";

    /// Open it in `dir` (rank 0 writes; rows after `resume_step` dropped).
    pub fn create(dir: &Path, sim: &Simulation, resume_step: Option<u64>) -> Result<InsertLog, TalusError> {
        let out = if sim.parallel().comm.is_root() {
            Some(crate::durable::Series::open(&dir.join("inserted.csv"), Self::HEADER, 0, resume_step.map(|s| s.saturating_sub(1)))?)
        } else {
            None
        };
        Ok(InsertLog { out })
    }
}

impl Observer for InsertLog {
    fn after_step(&mut self, sim: &mut Simulation, _: f64) -> Result<(), TalusError> {
        // the same rows on every rank: a step that inserts nothing writes nothing
        let rows = sim.take_inserted();
        if rows.is_empty() {
            return Ok(());
        }
        let mut written = Ok(());
        if let Some(out) = self.out.as_mut() {
            written = (|| {
                for r in &rows {
                    let p = &r.init;
                    out.row(&format!(
                        "{},{:.17e},{},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{}",
                        r.step, r.time, p.id, p.pos.x, p.pos.y, p.pos.z, p.vel.x, p.vel.y, p.vel.z, p.radius, r.material
                    ))?;
                }
                out.flush()
            })();
        }
        // rank 0 writes: its failure is every rank's
        sim.parallel().collective(written)
    }
    fn flush(&mut self) -> Result<(), TalusError> {
        match self.out.as_mut() {
            Some(o) => o.flush(),
            None => Ok(()),
        }
    }
}

/// `probes.csv` every `output.interval`.
pub struct ProbeLog {
    probes: Probes,
}

impl ProbeLog {
    pub fn new(probes: Probes) -> ProbeLog {
        ProbeLog { probes }
    }

    /// The row of the current state (a collective).
    pub fn write(&mut self, sim: &mut Simulation) -> Result<(), TalusError> {
        sim.parallel().collective(self.probes.write(sim))?;
        Ok(())
    }
}

impl Observer for ProbeLog {
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError> {
        if crossed(t_prev, sim.time(), sim.case().output.interval, sim.dt()) {
            self.write(sim)?;
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, _: &mut Map<String, Value>) -> Result<(), TalusError> {
        sim.parallel().collective(self.probes.flush())
    }
    fn flush(&mut self) -> Result<(), TalusError> {
        self.probes.flush()
    }
}

/// HDF5 snapshots every `output.snapshot_interval` (rank 0 writes).
pub struct SnapshotLog {
    snaps: Option<Snapshots>,
    interval: f64,
}

impl SnapshotLog {
    pub fn new(snaps: Option<Snapshots>, interval: f64) -> SnapshotLog {
        SnapshotLog { snaps, interval }
    }

    /// Gather every particle and let rank 0 write a snapshot (a collective).
    pub fn write(&mut self, sim: &Simulation) -> Result<(), TalusError> {
        let (p, _) = sim.parallel().gather_particles(sim.particles(), &sim.state().gear);
        let contacts = sim.case().output.contacts.then(|| sim.all_contacts());
        let r = match self.snaps.as_mut() {
            Some(s) => s.write(sim.state(), &p, contacts.as_deref()),
            None => Ok(()),
        };
        sim.parallel().collective(r)
    }
}

impl Observer for SnapshotLog {
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError> {
        if crossed(t_prev, sim.time(), self.interval, sim.dt()) {
            self.write(sim)?;
        }
        // a snapshot after the next step: its sweep keeps the wall contacts
        if sim.case().output.contacts && crossed(sim.time(), sim.time() + sim.dt(), self.interval, sim.dt()) {
            sim.want_wall_contacts();
        }
        Ok(())
    }
}

/// `final.csv` at the end of the run (`output.final_state`): every particle in
/// id order, gathered to rank 0 and replaced atomically.
pub struct FinalState {
    path: PathBuf,
}

impl FinalState {
    pub fn new(dir: &Path) -> FinalState {
        FinalState { path: dir.join("final.csv") }
    }
}

impl Observer for FinalState {
    fn after_step(&mut self, _sim: &mut Simulation, _t_prev: f64) -> Result<(), TalusError> {
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, _summary: &mut Map<String, Value>) -> Result<(), TalusError> {
        use std::io::Write as _;
        // in order of id
        let (p, _) = sim.parallel().gather_particles(sim.particles(), &sim.state().gear);
        let r = if sim.parallel().comm.is_root() {
            crate::durable::write_atomic(&self.path, |w| {
                writeln!(w, "id,x,y,z,vx,vy,vz,radius")?;
                for i in 0..p.len() {
                    let (x, v) = (p.pos[i], p.vel[i]);
                    writeln!(w, "{},{:e},{:e},{:e},{:e},{:e},{:e},{:e}", p.id[i], x.x, x.y, x.z, v.x, v.y, v.z, p.radius[i])?;
                }
                Ok(())
            })
        } else {
            Ok(())
        };
        sim.parallel().collective(r)
    }
}

/// `checkpoint.bin` every `output.checkpoint_interval`.
pub struct Checkpoints {
    path: PathBuf,
    interval: f64,
}

impl Checkpoints {
    pub fn new(dir: &Path, interval: f64) -> Checkpoints {
        Checkpoints { path: dir.join("checkpoint.bin"), interval }
    }
}

impl Observer for Checkpoints {
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError> {
        if crossed(t_prev, sim.time(), self.interval, sim.dt()) {
            checkpoint::write(sim, &self.path)?;
        }
        Ok(())
    }
}

/// Progress (rank 0 alone): step, simulated time, particle-steps per second,
/// ETA. On a terminal, a bar (indicatif); elsewhere (a pipe, a log, and every
/// run under mpirun, which gives the ranks no terminal on stderr) a plain line
/// on stderr every `LINE_EVERY`, the first after that long: short runs print none.
pub struct Progress {
    shown: Shown,
    start: Instant,
    first_step: u64,
    planned: u64,
    particles: f64,
}

enum Shown {
    Bar(indicatif::ProgressBar),
    /// When the last line was printed.
    Lines(Instant),
}

/// How often a run without a terminal prints a progress line.
const LINE_EVERY: std::time::Duration = std::time::Duration::from_secs(10);

impl Progress {
    pub fn new(sim: &Simulation, particles: f64) -> Progress {
        use std::io::IsTerminal;
        let planned = (sim.planned_time() / sim.dt()).ceil() as u64;
        let shown = if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(planned);
            bar.set_style(
                indicatif::ProgressStyle::with_template("{bar:30} step {pos}/{len}  {msg}  ETA {eta}").expect("a valid template"),
            );
            bar.set_position(sim.step_count());
            Shown::Bar(bar)
        } else {
            Shown::Lines(Instant::now())
        };
        Progress { shown, start: Instant::now(), first_step: sim.step_count(), planned, particles }
    }
}

impl Observer for Progress {
    fn after_step(&mut self, sim: &mut Simulation, _: f64) -> Result<(), TalusError> {
        let steps = sim.step_count() - self.first_step;
        if steps % 200 != 0 {
            return Ok(());
        }
        let elapsed = self.start.elapsed().as_secs_f64();
        let rate = self.particles * steps as f64 / elapsed;
        match &mut self.shown {
            Shown::Bar(bar) => {
                bar.set_position(sim.step_count());
                bar.set_message(format!("t = {:.4} s  {rate:.2e} particle-steps/s", sim.time()));
            }
            Shown::Lines(last) if last.elapsed() >= LINE_EVERY => {
                *last = Instant::now();
                let left = self.planned.saturating_sub(sim.step_count());
                let eta = left as f64 * elapsed / steps as f64;
                let pct = 100.0 * sim.step_count() as f64 / self.planned.max(1) as f64;
                eprintln!(
                    "talus: step {}/{} ({pct:.0}%), t = {:.4} s, {rate:.2e} particle-steps/s, ETA {:.0} s",
                    sim.step_count(),
                    self.planned,
                    sim.time(),
                    eta
                );
            }
            Shown::Lines(_) => {}
        }
        Ok(())
    }
    fn finish(&mut self, _: &mut Simulation, _: &mut Map<String, Value>) -> Result<(), TalusError> {
        if let Shown::Bar(bar) = &self.shown {
            bar.finish_and_clear();
        }
        Ok(())
    }
}

/// Per-rank diagnostics (`ranks.csv`): at each output interval, every rank's
/// owned particles, ghosts, contacts evaluated, compute and communication time
/// over the interval, and the imbalance (max over mean) of compute time and of
/// work (particles + contacts). Rank 0 writes; the means per phase go into the
/// summary (`imbalance_time_<phase>`, `imbalance_work_<phase>`) of a parallel run.
pub struct RankLog {
    out: Option<crate::durable::Series>,
    /// Per phase: (sum of time imbalance, sum of work imbalance, rows).
    per_phase: Vec<(String, f64, f64, u64)>,
}

impl RankLog {
    pub fn create(dir: &Path, sim: &Simulation, resume: Option<u64>) -> Result<RankLog, TalusError> {
        const HEADER: &str = "time_s,step,phase,rank,owned,ghosts,contacts,compute_s,comm_s,imbalance_time,imbalance_work";
        let out = if sim.parallel().comm.is_root() {
            Some(crate::durable::Series::open(&dir.join("ranks.csv"), HEADER, 1, resume))
        } else {
            None
        };
        let out = sim.parallel().collective(out.transpose())?;
        Ok(RankLog { out, per_phase: Vec::new() })
    }

    fn write(&mut self, sim: &mut Simulation) -> Result<(), TalusError> {
        let c = sim.rank_counters();
        let imb = |f: &dyn Fn(&crate::parallel::RankCounters) -> f64| {
            let v: Vec<f64> = c.iter().map(f).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            if mean > 0.0 { v.iter().cloned().fold(0.0, f64::max) / mean } else { 1.0 }
        };
        let it = imb(&|r| r.compute_s);
        let iw = imb(&|r| (r.owned + r.contacts) as f64);
        let phase = sim.phase_name().to_string();
        match self.per_phase.iter_mut().find(|x| x.0 == phase) {
            Some(e) => {
                e.1 += it;
                e.2 += iw;
                e.3 += 1;
            }
            None => self.per_phase.push((phase.clone(), it, iw, 1)),
        }
        let mut written = Ok(());
        if let Some(w) = self.out.as_mut() {
            written = (|| {
                for (r, x) in c.iter().enumerate() {
                    w.row(&format!(
                        "{:.9e},{},{phase},{r},{},{},{},{:.6e},{:.6e},{it:.5},{iw:.5}",
                        sim.time(), sim.step_count(), x.owned, x.ghosts, x.contacts, x.compute_s, x.comm_s
                    ))?;
                }
                w.flush()
            })();
        }
        // rank 0 writes: its failure is every rank's
        sim.parallel().collective(written)
    }
}

impl Observer for RankLog {
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError> {
        if crossed(t_prev, sim.time(), sim.case().output.interval, sim.dt()) {
            self.write(sim)?;
        }
        Ok(())
    }
    fn finish(&mut self, sim: &mut Simulation, summary: &mut Map<String, Value>) -> Result<(), TalusError> {
        if sim.parallel().size() > 1 {
            for (ph, it, iw, n) in &self.per_phase {
                summary.insert(format!("imbalance_time_{ph}"), json!(it / *n as f64));
                summary.insert(format!("imbalance_work_{ph}"), json!(iw / *n as f64));
            }
        }
        let flushed = self.flush();
        sim.parallel().collective(flushed)
    }
    fn flush(&mut self) -> Result<(), TalusError> {
        match self.out.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}
