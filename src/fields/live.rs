//! `[output.fields]`: the fields sampled while the run goes, every
//! `interval` from `from` to `to`, from every particle and contact gathered
//! in order of id (so the fields do not depend on the rank or thread count),
//! written after each sample (replaced atomically) and at the end.

use super::Fields;
use crate::error::TalusError;
use crate::observe::{crossed, Observer};
use crate::sim::Simulation;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

pub struct FieldsLog {
    fields: Fields,
    dir: PathBuf,
    interval: f64,
    from: f64,
    to: f64,
}

impl FieldsLog {
    /// The case's `[output.fields]`, or None. On a restart the averages
    /// start again from the restart (the sums before it are not kept).
    pub fn create(sim: &Simulation, dir: &Path, resume: bool) -> Result<Option<FieldsLog>, TalusError> {
        let Some(f) = &sim.case().output.fields else { return Ok(None) };
        let (kernel, points) = super::plan(&f.kernel, f.width, f.profile.as_deref(), f.grid, f.points)
            .map_err(|(k, v, why)| TalusError::Input(format!("{}: output.fields.{k} = {v}: {why}", sim.case().path.display())))?;
        let fields = Fields::new(kernel, points, sim.fields_domain()).map_err(|e| TalusError::Input(format!("{}: output.fields: {e}", sim.case().path.display())))?;
        if resume && sim.parallel().comm.is_root() {
            eprintln!("talus: note: [output.fields] averages from the restart on (the samples before it are not in the checkpoint)");
        }
        Ok(Some(FieldsLog { fields, dir: dir.to_path_buf(), interval: f.interval, from: f.from.unwrap_or(0.0), to: f.to.unwrap_or(f64::INFINITY) }))
    }

    /// Whether a sample falls in the step from `t_prev` to `t`.
    fn due(&self, t_prev: f64, t: f64, dt: f64) -> bool {
        t + 0.5 * dt >= self.from && t - 0.5 * dt <= self.to && crossed(t_prev, t, self.interval, dt)
    }

    /// Take a sample (a collective) and write the averages so far (rank 0).
    pub fn sample(&mut self, sim: &Simulation) -> Result<(), TalusError> {
        let (p, contacts) = sim.fields_sample();
        let r = if sim.parallel().comm.is_root() {
            self.fields.add(&super::Sample::of(&p, &contacts));
            self.fields.write_to(&self.dir).map(|_| ())
        } else {
            Ok(())
        };
        sim.parallel().collective(r)
    }
}

impl Observer for FieldsLog {
    fn after_step(&mut self, sim: &mut Simulation, t_prev: f64) -> Result<(), TalusError> {
        let (t, dt) = (sim.time(), sim.dt());
        if self.due(t_prev, t, dt) {
            self.sample(sim)?;
        }
        // a sample after the next step: its sweep keeps the wall contacts
        if self.due(t, t + dt, dt) {
            sim.want_wall_contacts();
        }
        Ok(())
    }

    fn finish(&mut self, sim: &mut Simulation, summary: &mut Map<String, Value>) -> Result<(), TalusError> {
        if sim.parallel().comm.is_root() {
            summary.insert("fields_samples".into(), Value::from(self.fields.samples));
        }
        Ok(())
    }
}
