//! Run outputs: the probe time series (CSV) and HDF5 snapshots with an XDMF
//! index that ParaView opens. Checkpoints are in [`crate::checkpoint`].
//!
//! Both survive a kill and continue on a restart into the same folder: probe
//! rows are flushed at every output interval, and a restart keeps the rows and
//! snapshots up to the checkpoint's step and appends after them.

use crate::durable::{write_atomic, Series};
use crate::dim::Vec3;
use crate::error::TalusError;
use crate::particles::Particles;
use crate::sim::{Simulation, State};
use crate::walls::Shape;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The probe CSV writer. Every rank calls `create` and `write` (the values
/// are sums over ranks); rank 0 writes the file.
pub struct Probes {
    out: Option<Series>,
    mass_below_z: Option<f64>,
    track: Vec<u64>,
}

/// Whether a phase of the run inserts particles.
fn inserting(sim: &Simulation) -> bool {
    sim.case().phases.iter().any(|p| !p.inserts.is_empty())
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
        // a run that inserts particles reports how many it holds
        if inserting(sim) {
            h.push_str(",particles");
        }
        for w in sim.walls() {
            for c in ["x", "y", "z"] {
                h.push_str(&format!(",{}_force_{c}_n", w.name));
            }
            for c in ["x", "y", "z"] {
                h.push_str(&format!(",{}_torque_{c}_n_m", w.name));
            }
            if w.rotation.is_some() {
                h.push_str(&format!(",{}_axis_torque_n_m", w.name));
            }
            if w.servo.is_some() {
                h.push_str(&format!(",{}_travel_m", w.name));
            }
        }
        if o.mass_below_z.is_some() {
            h.push_str(",mass_below_kg");
        }
        if o.momentum {
            h.push_str(",momentum_x_kg_m_s,momentum_y_kg_m_s,momentum_z_kg_m_s");
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
        let count = inserting(sim).then(|| sim.particle_count());
        let momentum = sim.case().output.momentum.then(|| sim.momentum());
        let tracked = if self.track.is_empty() { Vec::new() } else { sim.tracked(&self.track) };
        let Some(out) = self.out.as_mut() else { return Ok(mb) };
        let mut line = format!("{:.9e},{},{},{:.9e},{}", st.time, st.step, phase, ke, contacts);
        if let Some(n) = count {
            line.push_str(&format!(",{n}"));
        }
        for w in &st.walls {
            for v in [w.force, w.torque] {
                for k in 0..3 {
                    line.push_str(&format!(",{:.9e}", v[k]));
                }
            }
            if let Some(t) = w.axis_torque() {
                line.push_str(&format!(",{t:.9e}"));
            }
            if let Some(s) = &w.servo {
                line.push_str(&format!(",{:.9e}", s.travel));
            }
        }
        if let Some(m) = mb {
            line.push_str(&format!(",{m:.9e}"));
        }
        if let Some(q) = momentum {
            for k in 0..3 {
                line.push_str(&format!(",{:.9e}", q[k]));
            }
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
/// A snapshot holds every particle (id, position, velocity, spin, radius) and
/// the geometry of every wall still in the run at that time, in group
/// `walls/<name>`: `vertices` (n x 3) and `cells` (triangles, m x 3; a 2D
/// segment wall: lines, m x 2). Meshes are their triangles where they are;
/// planes the polygon where they cut the domain; a ball a sphere of
/// triangles (2D: a disc of triangles in z = 0). The XDMF shows each snapshot
/// as the particles plus one grid per wall, so ParaView shows the walls move
/// and a removed wall gone.
pub struct Snapshots {
    h5: PathBuf,
    xdmf: PathBuf,
    file: hdf5_metno::File,
    entries: Vec<Entry>,
    lo: Vec3,
    hi: Vec3,
    two_d: bool,
}

/// One snapshot in the XDMF index: group name, time, particle count, and per
/// wall its name, vertex and cell counts and nodes per cell.
struct Entry {
    name: String,
    time: f64,
    n: usize,
    walls: Vec<(String, usize, usize, usize)>,
}

/// A wall's surface as vertices and cells (3 nodes: triangles; 2: lines).
pub fn wall_geometry(shape: &Shape, lo: Vec3, hi: Vec3, two_d: bool) -> (Vec<Vec3>, Vec<Vec<u64>>) {
    match shape {
        Shape::Mesh(m) => (m.vertices.clone(), m.triangles.iter().map(|t| t.iter().map(|&k| k as u64).collect()).collect()),
        Shape::Plane(p) => {
            // the polygon where the plane cuts the domain box: the crossings of its 12 edges
            let c = |i: usize| Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
            let mut pts: Vec<Vec3> = Vec::new();
            let tol = 1e-12 * (hi - lo).norm();
            for a in 0..8usize {
                for bit in [1usize, 2, 4] {
                    let b = a | bit;
                    if b == a {
                        continue;
                    }
                    let (pa, pb) = (c(a), c(b));
                    let (da, db) = ((pa - p.point).dot(&p.normal), (pb - p.point).dot(&p.normal));
                    if (da <= 0.0 && db >= 0.0) || (da >= 0.0 && db <= 0.0) {
                        let x = if da == db { pa } else { pa + (pb - pa) * (da / (da - db)) };
                        if !pts.iter().any(|q| (q - x).norm() <= tol) {
                            pts.push(x);
                        }
                    }
                }
            }
            if pts.len() < 3 {
                return (Vec::new(), Vec::new());
            }
            let centre = pts.iter().fold(Vec3::zeros(), |s, q| s + q) / pts.len() as f64;
            let u = (pts[0] - centre).normalize();
            let v = p.normal.cross(&u);
            pts.sort_by(|a, b| {
                let (x, y) = ((a - centre).dot(&u), (a - centre).dot(&v));
                let (x2, y2) = ((b - centre).dot(&u), (b - centre).dot(&v));
                y.atan2(x).total_cmp(&y2.atan2(x2))
            });
            let cells = (1..pts.len() as u64 - 1).map(|k| vec![0, k, k + 1]).collect();
            (pts, cells)
        }
        Shape::Disc(d) => {
            if two_d {
                let n = 48u64;
                let mut v = vec![d.center];
                for k in 0..n {
                    let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
                    v.push(d.center + Vec3::new(d.radius * a.cos(), d.radius * a.sin(), 0.0));
                }
                (v, (0..n).map(|k| vec![0, 1 + k, 1 + (k + 1) % n]).collect())
            } else {
                let m = crate::walls::mesh::uv_sphere(d.center, d.radius, 12, 24);
                (m.vertices.clone(), m.triangles.iter().map(|t| t.iter().map(|&k| k as u64).collect()).collect())
            }
        }
        Shape::Segments(sg) => {
            let v: Vec<Vec3> = sg.segs.iter().flat_map(|s| [s[0], s[1]]).collect();
            (v, (0..sg.segs.len() as u64).map(|k| vec![2 * k, 2 * k + 1]).collect())
        }
    }
}

impl Snapshots {
    /// Open `snapshots.h5` in `dir`: anew, or, with `resume_step` (a restart),
    /// the existing file with the snapshots after that step removed, so new
    /// ones are appended after the ones kept (the XDMF index is rewritten to
    /// match). A file HDF5 cannot open (a kill in the middle of a write) is
    /// kept aside as `snapshots.h5.damaged` with a warning, and a new one begun.
    pub fn create(dir: &Path, resume_step: Option<u64>, dt: f64, domain: crate::fields::Domain, two_d: bool) -> Result<Snapshots, TalusError> {
        let (lo, hi) = (domain.lo, domain.hi);
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
                        let mut walls = Vec::new();
                        if let Ok(wg) = g.group("walls") {
                            for w in wg.member_names().map_err(err)? {
                                let ww = wg.group(&w).map_err(err)?;
                                let nv = ww.dataset("vertices").map_err(err)?.shape().first().copied().unwrap_or(0);
                                let cs = ww.dataset("cells").map_err(err)?.shape();
                                walls.push((w, nv, cs.first().copied().unwrap_or(0), cs.get(1).copied().unwrap_or(3)));
                            }
                        }
                        entries.push(Entry { name, time: t, n, walls });
                    }
                    file.flush().map_err(err)?;
                    let snaps = Snapshots { h5, xdmf, file, entries, lo, hi, two_d };
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
        // the domain, which `talus fields` reads
        let err = |e: hdf5_metno::Error| TalusError::Run(format!("writing {}: {e}", h5.display()));
        let per = domain.periodic.map(|b| b as u8 as f64);
        for (name, v) in [("domain_lo", [lo.x, lo.y, lo.z]), ("domain_hi", [hi.x, hi.y, hi.z]), ("periodic", per)] {
            file.new_attr::<f64>().shape(3).create(name).map_err(err)?.write_raw(&v).map_err(err)?;
        }
        Ok(Snapshots { h5, xdmf, file, entries: Vec::new(), lo, hi, two_d })
    }

    /// Write every particle (gathered from all ranks, in id order) as one snapshot.
    /// With `contacts`, the snapshot carries them too (group `contacts`).
    pub fn write(&mut self, st: &State, p: &Particles, contacts: Option<&[crate::fields::ContactRecord]>) -> Result<(), TalusError> {
        let name = format!("step_{:09}", st.step);
        let err = |e: hdf5_metno::Error| TalusError::Run(format!("writing {}: {e}", self.h5.display()));
        let g = self.file.create_group(&name).map_err(err)?;
        g.new_attr::<f64>().create("time_s").map_err(err)?.write_scalar(&st.time).map_err(err)?;
        let n = p.len();
        let flat = |v: &[crate::dim::Vec3]| -> Vec<f64> { v.iter().flat_map(|x| [x.x, x.y, x.z]).collect() };
        for (label, data) in [("position", flat(&p.pos)), ("velocity", flat(&p.vel)), ("spin", flat(&p.omega))] {
            g.new_dataset::<f64>().shape((n, 3)).create(label).map_err(err)?.write_raw(&data).map_err(err)?;
        }
        g.new_dataset::<f64>().shape(n).create("radius").map_err(err)?.write_raw(&p.radius).map_err(err)?;
        g.new_dataset::<f64>().shape(n).create("mass").map_err(err)?.write_raw(&p.mass).map_err(err)?;
        if let Some(c) = contacts {
            crate::fields::snapshots::write_contacts(&g, c).map_err(err)?;
        }
        g.new_dataset::<u64>().shape(n).create("id").map_err(err)?.write_raw(&p.id).map_err(err)?;
        let mut walls = Vec::new();
        let wg = g.create_group("walls").map_err(err)?;
        for w in st.walls.iter().filter(|w| w.active) {
            let (v, cells) = wall_geometry(&w.shape, self.lo, self.hi, self.two_d);
            if v.is_empty() {
                continue;
            }
            let per = cells.first().map(|c| c.len()).unwrap_or(3);
            let ww = wg.create_group(&w.name).map_err(err)?;
            let flat: Vec<f64> = v.iter().flat_map(|x| [x.x, x.y, x.z]).collect();
            ww.new_dataset::<f64>().shape((v.len(), 3)).create("vertices").map_err(err)?.write_raw(&flat).map_err(err)?;
            let cflat: Vec<u64> = cells.iter().flatten().copied().collect();
            ww.new_dataset::<u64>().shape((cells.len(), per)).create("cells").map_err(err)?.write_raw(&cflat).map_err(err)?;
            walls.push((w.name.clone(), v.len(), cells.len(), per));
        }
        // in name order, as HDF5 lists the groups when a restart reads them back
        walls.sort_by(|a, b| a.0.cmp(&b.0));
        self.file.flush().map_err(err)?;
        self.entries.push(Entry { name, time: st.time, n, walls });
        self.write_xdmf()
    }

    /// The XDMF index of every snapshot in the file, replaced atomically.
    fn write_xdmf(&self) -> Result<(), TalusError> {
        let h5 = self.h5.file_name().unwrap().to_string_lossy().to_string();
        let mut s = String::from(
            "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n<Domain>\n<Grid Name=\"talus\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
        );
        for e in &self.entries {
            let (g, t, n) = (&e.name, e.time, e.n);
            s.push_str(&format!("<Grid Name=\"{g}\" GridType=\"Collection\" CollectionType=\"Spatial\">\n<Time Value=\"{t:.9e}\"/>\n"));
            s.push_str(&format!("<Grid Name=\"particles\" GridType=\"Uniform\">\n"));
            s.push_str(&format!(
                "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\"/>\n<Geometry GeometryType=\"XYZ\">\n<DataItem Dimensions=\"{n} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{h5}:/{g}/position</DataItem>\n</Geometry>\n"
            ));
            for (a, dims, ty, num) in [("velocity", "3", "Vector", "Float"), ("spin", "3", "Vector", "Float"), ("radius", "", "Scalar", "Float"), ("id", "", "Scalar", "UInt")] {
                let d = if dims.is_empty() { format!("{n}") } else { format!("{n} {dims}") };
                s.push_str(&format!(
                    "<Attribute Name=\"{a}\" AttributeType=\"{ty}\" Center=\"Node\">\n<DataItem Dimensions=\"{d}\" NumberType=\"{num}\" Precision=\"8\" Format=\"HDF\">{h5}:/{g}/{a}</DataItem>\n</Attribute>\n"
                ));
            }
            s.push_str("</Grid>\n");
            for (w, nv, nc, per) in &e.walls {
                let topo = if *per == 2 { format!("TopologyType=\"Polyline\" NodesPerElement=\"2\"") } else { "TopologyType=\"Triangle\"".to_string() };
                s.push_str(&format!(
                    "<Grid Name=\"wall:{w}\" GridType=\"Uniform\">\n<Topology {topo} NumberOfElements=\"{nc}\">\n<DataItem Dimensions=\"{nc} {per}\" NumberType=\"UInt\" Precision=\"8\" Format=\"HDF\">{h5}:/{g}/walls/{w}/cells</DataItem>\n</Topology>\n<Geometry GeometryType=\"XYZ\">\n<DataItem Dimensions=\"{nv} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{h5}:/{g}/walls/{w}/vertices</DataItem>\n</Geometry>\n</Grid>\n"
                ));
            }
            s.push_str("</Grid>\n");
        }
        s.push_str("</Grid>\n</Domain>\n</Xdmf>\n");
        write_atomic(&self.xdmf, |w| w.write_all(s.as_bytes()))
    }
}
