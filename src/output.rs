//! Run outputs: the probe time series (CSV) and HDF5 snapshots with an XDMF
//! index that ParaView opens. Checkpoints are in [`crate::checkpoint`].
//!
//! Both survive a kill and continue on a restart into the same folder: probe
//! rows are flushed at every output interval, and a restart keeps the rows and
//! snapshots up to the checkpoint's step and appends after them.

use crate::durable::{write_atomic, Series};
use crate::error::TalusError;
use crate::particles::Record;
use crate::sim::{Simulation, State};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The probe CSV writer. Every rank calls `create` and `write` (the values
/// are sums over ranks); rank 0 writes the file.
pub struct Probes {
    out: Option<Series>,
    mass_below_z: Option<f64>,
    track: Vec<u64>,
}

impl Probes {
    /// Open `probes.csv` in `dir`: anew, or, with `resume_step` (a restart),
    /// keeping the rows up to that step and appending after them.
    pub fn create(dir: &Path, sim: &Simulation, resume_step: Option<u64>) -> Result<Probes, TalusError> {
        let o = &sim.case().output;
        let found = sim.tracked(&o.track);
        for (&id, r) in o.track.iter().zip(&found) {
            if r.is_none() {
                return Err(TalusError::Input(format!("{}: output.track: no particle with id {id}", sim.case().path.display())));
            }
        }
        let track = o.track.clone();
        if !sim.parallel().comm.is_root() {
            return Ok(Probes { out: None, mass_below_z: o.mass_below_z, track });
        }
        let mut h = String::from("time_s,step,phase,kinetic_energy_j,contacts");
        for w in sim.walls() {
            for c in ["x", "y", "z"] {
                h.push_str(&format!(",{}_force_{c}_n", w.name));
            }
            for c in ["x", "y", "z"] {
                h.push_str(&format!(",{}_torque_{c}_n_m", w.name));
            }
        }
        if o.mass_below_z.is_some() {
            h.push_str(",mass_below_kg");
        }
        for id in &track {
            for q in [
                "x_m", "y_m", "z_m", "vx_m_s", "vy_m_s", "vz_m_s", "wx_rad_s", "wy_rad_s", "wz_rad_s", "fx_n", "fy_n",
                "fz_n",
            ] {
                h.push_str(&format!(",p{id}_{q}"));
            }
        }
        let out = Series::open(&dir.join("probes.csv"), &h, 1, resume_step)?;
        Ok(Probes { out: Some(out), mass_below_z: o.mass_below_z, track })
    }

    /// A collective: every rank calls it; returns the mass below the probe plane.
    pub fn write(&mut self, sim: &Simulation) -> Result<Option<f64>, TalusError> {
        let st = sim.state();
        let phase = sim.phase_name();
        let ke = sim.kinetic_energy();
        let contacts = sim.contacts();
        let mb = self.mass_below_z.map(|z| sim.mass_below(z));
        let tracked = if self.track.is_empty() { Vec::new() } else { sim.tracked(&self.track) };
        let Some(out) = self.out.as_mut() else { return Ok(mb) };
        let mut line = format!("{:.9e},{},{},{:.9e},{}", st.time, st.step, phase, ke, contacts);
        for w in &st.walls {
            for v in [w.force, w.torque] {
                for k in 0..3 {
                    line.push_str(&format!(",{:.9e}", v[k]));
                }
            }
        }
        if let Some(m) = mb {
            line.push_str(&format!(",{m:.9e}"));
        }
        for r in tracked.iter().flatten() {
            for v in [r.pos, r.vel, r.omega, r.force] {
                for k in 0..3 {
                    line.push_str(&format!(",{:e}", v[k]));
                }
            }
        }
        out.row(&line)?;
        out.flush()?;
        Ok(mb)
    }

    pub fn flush(&mut self) -> Result<(), TalusError> {
        match self.out.as_mut() {
            Some(o) => o.flush(),
            None => Ok(()),
        }
    }
}

/// HDF5 snapshots in one file, one group per snapshot, and an XDMF index.
pub struct Snapshots {
    h5: PathBuf,
    xdmf: PathBuf,
    file: hdf5_metno::File,
    entries: Vec<(String, f64, usize)>,
}

impl Snapshots {
    /// Open `snapshots.h5` in `dir`: anew, or, with `resume_step` (a restart),
    /// the existing file with the snapshots after that step removed, so new
    /// ones are appended after the ones kept (the XDMF index is rewritten to
    /// match). A file HDF5 cannot open (a kill in the middle of a write) is
    /// kept aside as `snapshots.h5.damaged` with a warning, and a new one begun.
    pub fn create(dir: &Path, resume_step: Option<u64>, dt: f64) -> Result<Snapshots, TalusError> {
        let h5 = dir.join("snapshots.h5");
        let xdmf = dir.join("snapshots.xdmf");
        if let (Some(step), true) = (resume_step, h5.exists()) {
            match hdf5_metno::File::open_rw(&h5) {
                Ok(file) => {
                    let err = |e: hdf5_metno::Error| TalusError::Run(format!("continuing {}: {e}", h5.display()));
                    let mut entries = Vec::new();
                    for name in file.member_names().map_err(err)? {
                        let Some(s) = name.strip_prefix("step_").and_then(|s| s.parse::<u64>().ok()) else { continue };
                        if s > step {
                            file.unlink(&name).map_err(err)?;
                            continue;
                        }
                        let g = file.group(&name).map_err(err)?;
                        let t = g.attr("time_s").and_then(|a| a.read_scalar::<f64>()).unwrap_or(s as f64 * dt);
                        let n = g.dataset("radius").map_err(err)?.shape().first().copied().unwrap_or(0);
                        entries.push((name, t, n));
                    }
                    file.flush().map_err(err)?;
                    let snaps = Snapshots { h5, xdmf, file, entries };
                    snaps.write_xdmf()?;
                    return Ok(snaps);
                }
                Err(e) => {
                    let aside = dir.join("snapshots.h5.damaged");
                    eprintln!("talus: warning: {} cannot be continued ({e}); kept as {}, new snapshots begin", h5.display(), aside.display());
                    std::fs::rename(&h5, &aside).map_err(|e| TalusError::io(format!("cannot rename {}", h5.display()), e))?;
                }
            }
        }
        let file = hdf5_metno::File::create(&h5)
            .map_err(|e| TalusError::Run(format!("cannot create HDF5 file {}: {e}", h5.display())))?;
        Ok(Snapshots { h5, xdmf, file, entries: Vec::new() })
    }

    /// Write every particle (gathered from all ranks, in id order) as one snapshot.
    pub fn write(&mut self, st: &State, recs: &[Record]) -> Result<(), TalusError> {
        let name = format!("step_{:09}", st.step);
        let err = |e: hdf5_metno::Error| TalusError::Run(format!("writing {}: {e}", self.h5.display()));
        let g = self.file.create_group(&name).map_err(err)?;
        g.new_attr::<f64>().create("time_s").map_err(err)?.write_scalar(&st.time).map_err(err)?;
        let n = recs.len();
        let vec3 = |f: &dyn Fn(&Record) -> crate::dim::Vec3| -> Vec<f64> {
            recs.iter().flat_map(|r| { let x = f(r); [x.x, x.y, x.z] }).collect()
        };
        for (label, data) in [("position", vec3(&|r| r.pos)), ("velocity", vec3(&|r| r.vel)), ("spin", vec3(&|r| r.omega))] {
            g.new_dataset::<f64>().shape((n, 3)).create(label).map_err(err)?.write_raw(&data).map_err(err)?;
        }
        let radius: Vec<f64> = recs.iter().map(|r| r.radius).collect();
        let id: Vec<u64> = recs.iter().map(|r| r.id).collect();
        g.new_dataset::<f64>().shape(n).create("radius").map_err(err)?.write_raw(&radius).map_err(err)?;
        g.new_dataset::<u64>().shape(n).create("id").map_err(err)?.write_raw(&id).map_err(err)?;
        self.file.flush().map_err(err)?;
        self.entries.push((name, st.time, n));
        self.write_xdmf()
    }

    /// The XDMF index of every snapshot in the file, replaced atomically.
    fn write_xdmf(&self) -> Result<(), TalusError> {
        let h5 = self.h5.file_name().unwrap().to_string_lossy().to_string();
        let mut s = String::from(
            "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n<Domain>\n<Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
        );
        for (g, t, n) in &self.entries {
            s.push_str(&format!("<Grid Name=\"{g}\" GridType=\"Uniform\">\n<Time Value=\"{t:.9e}\"/>\n"));
            s.push_str(&format!(
                "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\"/>\n<Geometry GeometryType=\"XYZ\">\n<DataItem Dimensions=\"{n} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{h5}:/{g}/position</DataItem>\n</Geometry>\n"
            ));
            for (a, dims, ty) in [("velocity", "3", "Vector"), ("spin", "3", "Vector"), ("radius", "", "Scalar")] {
                let d = if dims.is_empty() { format!("{n}") } else { format!("{n} {dims}") };
                s.push_str(&format!(
                    "<Attribute Name=\"{a}\" AttributeType=\"{ty}\" Center=\"Node\">\n<DataItem Dimensions=\"{d}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{h5}:/{g}/{a}</DataItem>\n</Attribute>\n"
                ));
            }
            s.push_str("</Grid>\n");
        }
        s.push_str("</Grid>\n</Domain>\n</Xdmf>\n");
        write_atomic(&self.xdmf, |w| w.write_all(s.as_bytes()))
    }
}
