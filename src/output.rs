//! Run outputs: the probe time series (CSV), HDF5 snapshots with an XDMF index
//! that ParaView opens, checkpoints (bincode of the whole state), summary.json.

use crate::error::TalusError;
use crate::integrate::GearState;
use crate::neighbor::{History, NeighborList};
use crate::particles::{Particles, Record};
use crate::sim::{Simulation, State};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The probe CSV writer. Every rank calls `create` and `write` (the values
/// are sums over ranks); rank 0 writes the file.
pub struct Probes {
    out: Option<std::io::BufWriter<std::fs::File>>,
    mass_below_z: Option<f64>,
    track: Vec<u64>,
}

impl Probes {
    pub fn create(dir: &Path, sim: &Simulation) -> Result<Probes, TalusError> {
        let o = &sim.case.output;
        let found = sim.tracked(&o.track);
        for (&id, r) in o.track.iter().zip(&found) {
            if r.is_none() {
                return Err(TalusError::Input(format!("{}: output.track: no particle with id {id}", sim.case.path.display())));
            }
        }
        let track = o.track.clone();
        if !sim.par.comm.is_root() {
            return Ok(Probes { out: None, mass_below_z: o.mass_below_z, track });
        }
        let path = dir.join("probes.csv");
        let f = std::fs::File::create(&path).map_err(|e| TalusError::io(format!("cannot create {}", path.display()), e))?;
        let mut out = std::io::BufWriter::new(f);
        let mut h = String::from("time_s,step,phase,kinetic_energy_j,contacts");
        for w in &sim.state.walls {
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
        writeln!(out, "{h}").map_err(|e| TalusError::io("probes.csv", e))?;
        Ok(Probes { out: Some(out), mass_below_z: o.mass_below_z, track })
    }

    /// A collective: every rank calls it; returns the mass below the probe plane.
    pub fn write(&mut self, sim: &Simulation) -> Result<Option<f64>, TalusError> {
        let st = &sim.state;
        let phase = sim.case.phases.get(st.phase).map(|p| p.name.as_str()).unwrap_or("end");
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
        writeln!(out, "{line}").map_err(|e| TalusError::io("probes.csv", e))?;
        Ok(mb)
    }

    pub fn flush(&mut self) -> Result<(), TalusError> {
        match self.out.as_mut() {
            Some(o) => o.flush().map_err(|e| TalusError::io("probes.csv", e)),
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
    pub fn create(dir: &Path) -> Result<Snapshots, TalusError> {
        let h5 = dir.join("snapshots.h5");
        let file = hdf5_metno::File::create(&h5)
            .map_err(|e| TalusError::Run(format!("cannot create HDF5 file {}: {e}", h5.display())))?;
        Ok(Snapshots { h5, xdmf: dir.join("snapshots.xdmf"), file, entries: Vec::new() })
    }

    /// Write every particle (gathered from all ranks, in id order) as one snapshot.
    pub fn write(&mut self, st: &State, recs: &[Record]) -> Result<(), TalusError> {
        let name = format!("step_{:09}", st.step);
        let err = |e: hdf5_metno::Error| TalusError::Run(format!("writing {}: {e}", self.h5.display()));
        let g = self.file.create_group(&name).map_err(err)?;
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
        self.write_xdmf().map_err(|e| TalusError::io(format!("writing {}", self.xdmf.display()), e))
    }

    fn write_xdmf(&self) -> std::io::Result<()> {
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
        std::fs::write(&self.xdmf, s)
    }
}

/// A checkpoint: the case text's hash and the whole state of all ranks, as
/// one serial state (every particle in id order, the contact history keyed by
/// ids), so that a run restarts from it on any number of ranks.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    pub case_hash: u64,
    /// Ranks of the run that wrote it (for information).
    pub ranks: usize,
    pub state: State,
    pub history: History,
}

/// Hash of the case text, without its `[parallel]` section: how the work is
/// split does not change results, so a checkpoint restarts under any.
pub fn case_hash(sim: &Simulation) -> u64 {
    let mut case = sim.case.clone();
    case.parallel = Default::default();
    let text = toml::to_string(&case).unwrap_or_default();
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// All ranks write one checkpoint together (a collective: gathered, rank 0 writes).
pub fn write_checkpoint(sim: &Simulation, path: &Path) -> Result<(), TalusError> {
    let st = &sim.state;
    let (recs, rows) = sim.par.gather_all(&st.p, &st.gear);
    let history = sim.par.gather_history(st.nl.take_history(&st.p));
    let result = if sim.par.comm.is_root() {
        let mut gear = GearState { initialised: st.gear.initialised, ..Default::default() };
        gear.set_all(&rows);
        let state = State {
            p: Particles::from_records(&recs),
            walls: st.walls.clone(),
            nl: NeighborList { skin: st.nl.skin, builds: st.nl.builds, ..Default::default() },
            gear,
            time: st.time,
            step: st.step,
            phase: st.phase,
            phase_start: st.phase_start,
            settle_end: st.settle_end,
            pe0: st.pe0,
            forces_ready: st.forces_ready,
            contacts: st.contacts,
            clumps: st.clumps.clone(),
            analysis: st.analysis.clone(),
        };
        let ck = Checkpoint { case_hash: case_hash(sim), ranks: sim.par.size(), state, history };
        std::fs::File::create(path)
            .map_err(|e| TalusError::io(format!("cannot create {}", path.display()), e))
            .and_then(|f| {
                bincode::serialize_into(std::io::BufWriter::new(f), &ck)
                    .map_err(|e| TalusError::Run(format!("writing checkpoint {}: {e}", path.display())))
            })
    } else {
        Ok(())
    };
    sim.par.collective(result)
}

/// Replace the simulation's state by a checkpoint's (every rank reads the file
/// and keeps its own particles); refuse one written for another case.
pub fn read_checkpoint(sim: &mut Simulation, path: &Path) -> Result<(), TalusError> {
    let f = std::fs::File::open(path).map_err(|e| TalusError::io(format!("cannot open checkpoint {}", path.display()), e))?;
    let ck: Checkpoint = bincode::deserialize_from(std::io::BufReader::new(f))
        .map_err(|e| TalusError::Input(format!("{}: not a talus checkpoint: {e}", path.display())))?;
    if ck.case_hash != case_hash(sim) {
        return Err(TalusError::Input(format!(
            "{}: the checkpoint was written for a different case than {}",
            path.display(),
            sim.case.path.display()
        )));
    }
    if ck.state.p.len() as u64 != sim.particle_count() {
        return Err(TalusError::Input(format!("{}: particle count differs from the case", path.display())));
    }
    let mut st = ck.state;
    let mut hist = ck.history;
    sim.par.refit_all(&st.p.pos);
    sim.par.take_own(&mut st.p, &mut st.gear, &mut hist);
    let hist = sim.par.migrate(&mut st.p, &mut st.gear, hist);
    st.nl.build_with(&st.p, &st.walls, &hist);
    sim.state = st;
    Ok(())
}
