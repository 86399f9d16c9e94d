//! Run outputs: the probe time series (CSV), HDF5 snapshots with an XDMF index
//! that ParaView opens, checkpoints (bincode of the whole state), summary.json.

use crate::error::TalusError;
use crate::sim::{Simulation, State};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The probe CSV writer.
pub struct Probes {
    out: std::io::BufWriter<std::fs::File>,
    mass_below_z: Option<f64>,
    track: Vec<(u64, usize)>,
}

impl Probes {
    pub fn create(dir: &Path, sim: &Simulation) -> Result<Probes, TalusError> {
        let path = dir.join("probes.csv");
        let f = std::fs::File::create(&path).map_err(|e| TalusError::io(format!("cannot create {}", path.display()), e))?;
        let mut out = std::io::BufWriter::new(f);
        let o = &sim.case.output;
        let mut track = Vec::new();
        for &id in &o.track {
            let i = sim.state.p.index_of(id).ok_or_else(|| {
                TalusError::Input(format!("{}: output.track: no particle with id {id}", sim.case.path.display()))
            })?;
            track.push((id, i));
        }
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
        for (id, _) in &track {
            for q in [
                "x_m", "y_m", "z_m", "vx_m_s", "vy_m_s", "vz_m_s", "wx_rad_s", "wy_rad_s", "wz_rad_s", "fx_n", "fy_n",
                "fz_n",
            ] {
                h.push_str(&format!(",p{id}_{q}"));
            }
        }
        writeln!(out, "{h}").map_err(|e| TalusError::io("probes.csv", e))?;
        Ok(Probes { out, mass_below_z: o.mass_below_z, track })
    }

    /// Mass of particles with centre below z.
    pub fn mass_below(st: &State, z: f64) -> f64 {
        (0..st.p.len()).filter(|&i| st.p.pos[i].z < z).map(|i| st.p.mass[i]).sum()
    }

    pub fn write(&mut self, sim: &Simulation) -> Result<Option<f64>, TalusError> {
        let st = &sim.state;
        let phase = sim.case.phases.get(st.phase).map(|p| p.name.as_str()).unwrap_or("end");
        let mut line = format!("{:.9e},{},{},{:.9e},{}", st.time, st.step, phase, st.p.kinetic_energy(), st.contacts);
        for w in &st.walls {
            for v in [w.force, w.torque] {
                for k in 0..3 {
                    line.push_str(&format!(",{:.9e}", v[k]));
                }
            }
        }
        let mb = self.mass_below_z.map(|z| Probes::mass_below(st, z));
        if let Some(m) = mb {
            line.push_str(&format!(",{m:.9e}"));
        }
        for &(_, i) in &self.track {
            for v in [st.p.pos[i], st.p.vel[i], st.p.omega[i], st.p.force[i]] {
                for k in 0..3 {
                    line.push_str(&format!(",{:e}", v[k]));
                }
            }
        }
        writeln!(self.out, "{line}").map_err(|e| TalusError::io("probes.csv", e))?;
        Ok(mb)
    }

    pub fn flush(&mut self) -> Result<(), TalusError> {
        self.out.flush().map_err(|e| TalusError::io("probes.csv", e))
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

    pub fn write(&mut self, st: &State) -> Result<(), TalusError> {
        let name = format!("step_{:09}", st.step);
        let err = |e: hdf5_metno::Error| TalusError::Run(format!("writing {}: {e}", self.h5.display()));
        let g = self.file.create_group(&name).map_err(err)?;
        let n = st.p.len();
        let vec3 = |v: &[crate::dim::Vec3]| -> Vec<f64> { v.iter().flat_map(|x| [x.x, x.y, x.z]).collect() };
        for (label, data) in [("position", vec3(&st.p.pos)), ("velocity", vec3(&st.p.vel)), ("spin", vec3(&st.p.omega))] {
            g.new_dataset::<f64>().shape((n, 3)).create(label).map_err(err)?.write_raw(&data).map_err(err)?;
        }
        g.new_dataset::<f64>().shape(n).create("radius").map_err(err)?.write_raw(&st.p.radius).map_err(err)?;
        g.new_dataset::<u64>().shape(n).create("id").map_err(err)?.write_raw(&st.p.id).map_err(err)?;
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

/// A checkpoint: the case text's hash and the whole state.
#[derive(serde::Serialize, serde::Deserialize)]
pub struct Checkpoint {
    pub case_hash: u64,
    pub state: State,
}

pub fn case_hash(sim: &Simulation) -> u64 {
    let text = toml::to_string(&sim.case).unwrap_or_default();
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

pub fn write_checkpoint(sim: &Simulation, path: &Path) -> Result<(), TalusError> {
    let ck = Checkpoint { case_hash: case_hash(sim), state: sim.state.clone() };
    let f = std::fs::File::create(path).map_err(|e| TalusError::io(format!("cannot create {}", path.display()), e))?;
    bincode::serialize_into(std::io::BufWriter::new(f), &ck)
        .map_err(|e| TalusError::Run(format!("writing checkpoint {}: {e}", path.display())))
}

/// Replace the simulation's state by a checkpoint's; refuse one written for another case.
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
    if ck.state.p.len() != sim.state.p.len() {
        return Err(TalusError::Input(format!("{}: particle count differs from the case", path.display())));
    }
    sim.state = ck.state;
    Ok(())
}
