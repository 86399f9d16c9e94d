//! Reading a run's snapshots (`snapshots.h5`) for `talus fields`: per
//! snapshot the particles' positions, velocities and masses, and the contacts
//! where the run wrote them (`output.contacts = true`).

use super::{ContactRecord, Domain};
use crate::dim::Vec3;
use crate::error::TalusError;
use std::path::{Path, PathBuf};

/// One snapshot, read.
pub struct Snapshot {
    pub time: f64,
    pub pos: Vec<Vec3>,
    pub vel: Vec<Vec3>,
    pub mass: Vec<f64>,
    /// None where the run wrote no contacts.
    pub contacts: Option<Vec<ContactRecord>>,
}

/// A run's snapshot file: its domain and its snapshots' names and times.
pub struct SnapshotFile {
    path: PathBuf,
    file: hdf5_metno::File,
    pub domain: Domain,
    /// (group name, time) in order of time.
    pub index: Vec<(String, f64)>,
}

fn vec3s(flat: Vec<f64>) -> Vec<Vec3> {
    flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect()
}

impl SnapshotFile {
    /// Open `RUN_DIR/snapshots.h5` (or a snapshot file named directly).
    pub fn open(run: &Path) -> Result<SnapshotFile, TalusError> {
        let path = if run.is_dir() { run.join("snapshots.h5") } else { run.to_path_buf() };
        if !path.exists() {
            return Err(TalusError::Input(format!(
                "{}: no snapshots (a run writes them with output.snapshot_interval, and the contacts the stress needs with output.contacts = true)",
                path.display()
            )));
        }
        let file = hdf5_metno::File::open(&path).map_err(|e| TalusError::Input(format!("{}: cannot read as HDF5: {e}", path.display())))?;
        let err = |what: &str, e: hdf5_metno::Error| TalusError::Input(format!("{}: {what}: {e}", path.display()));
        let attr = |name: &str| -> Result<Vec<f64>, TalusError> {
            file.attr(name).and_then(|a| a.read_raw::<f64>()).map_err(|e| {
                TalusError::Input(format!(
                    "{}: no attribute {name} ({e}): written by a talus older than continuum fields; run the case again",
                    path.display()
                ))
            })
        };
        let (lo, hi, per) = (attr("domain_lo")?, attr("domain_hi")?, attr("periodic")?);
        if lo.len() != 3 || hi.len() != 3 || per.len() != 3 {
            return Err(TalusError::Input(format!("{}: the domain attributes are not three numbers each", path.display())));
        }
        let domain = Domain {
            lo: Vec3::new(lo[0], lo[1], lo[2]),
            hi: Vec3::new(hi[0], hi[1], hi[2]),
            periodic: [per[0] != 0.0, per[1] != 0.0, per[2] != 0.0],
        };
        let mut index = Vec::new();
        for name in file.member_names().map_err(|e| err("listing", e))? {
            if !name.starts_with("step_") {
                continue;
            }
            let g = file.group(&name).map_err(|e| err(&name, e))?;
            let t = g.attr("time_s").and_then(|a| a.read_scalar::<f64>()).map_err(|e| err(&name, e))?;
            index.push((name, t));
        }
        index.sort_by(|a, b| a.1.total_cmp(&b.1));
        Ok(SnapshotFile { path, file, domain, index })
    }

    /// Read snapshot `name`.
    pub fn read(&self, name: &str) -> Result<Snapshot, TalusError> {
        let err = |what: &str, e: hdf5_metno::Error| TalusError::Input(format!("{}: {name}/{what}: {e}", self.path.display()));
        let g = self.file.group(name).map_err(|e| err("", e))?;
        let time = g.attr("time_s").and_then(|a| a.read_scalar::<f64>()).map_err(|e| err("time_s", e))?;
        let f64s = |what: &str| g.dataset(what).and_then(|d| d.read_raw::<f64>()).map_err(|e| err(what, e));
        let pos = vec3s(f64s("position")?);
        let vel = vec3s(f64s("velocity")?);
        let mass = g.dataset("mass").and_then(|d| d.read_raw::<f64>()).map_err(|e| {
            TalusError::Input(format!(
                "{}: {name} has no particle masses ({e}): written by a talus older than continuum fields; run the case again",
                self.path.display()
            ))
        })?;
        let contacts = match g.group("contacts") {
            Ok(c) => {
                let ids = c.dataset("ids").and_then(|d| d.read_raw::<u64>()).map_err(|e| err("contacts/ids", e))?;
                let wall = c.dataset("wall").and_then(|d| d.read_raw::<u8>()).map_err(|e| err("contacts/wall", e))?;
                let cf = |what: &str| c.dataset(what).and_then(|d| d.read_raw::<f64>()).map_err(|e| err(&format!("contacts/{what}"), e));
                let (force, point, centre, branch) = (vec3s(cf("force")?), vec3s(cf("point")?), vec3s(cf("centre")?), vec3s(cf("branch")?));
                let n = wall.len();
                if ids.len() != 2 * n || force.len() != n || point.len() != n || centre.len() != n || branch.len() != n {
                    return Err(TalusError::Input(format!("{}: {name}/contacts: the datasets' lengths differ", self.path.display())));
                }
                Some(
                    (0..n)
                        .map(|k| ContactRecord {
                            a: ids[2 * k],
                            partner: ids[2 * k + 1],
                            wall: wall[k] != 0,
                            force: force[k],
                            point: point[k],
                            centre: centre[k],
                            branch: branch[k],
                        })
                        .collect(),
                )
            }
            Err(_) => None,
        };
        if vel.len() != pos.len() || mass.len() != pos.len() {
            return Err(TalusError::Input(format!("{}: {name}: position, velocity and mass differ in length", self.path.display())));
        }
        Ok(Snapshot { time, pos, vel, mass, contacts })
    }
}

/// Write `contacts` as group `contacts` of snapshot group `g`.
pub fn write_contacts(g: &hdf5_metno::Group, contacts: &[ContactRecord]) -> hdf5_metno::Result<()> {
    let c = g.create_group("contacts")?;
    let n = contacts.len();
    let ids: Vec<u64> = contacts.iter().flat_map(|r| [r.a, r.partner]).collect();
    c.new_dataset::<u64>().shape((n, 2)).create("ids")?.write_raw(&ids)?;
    let wall: Vec<u8> = contacts.iter().map(|r| r.wall as u8).collect();
    c.new_dataset::<u8>().shape(n).create("wall")?.write_raw(&wall)?;
    for (what, f) in [
        ("force", (|r: &ContactRecord| r.force) as fn(&ContactRecord) -> Vec3),
        ("point", |r| r.point),
        ("centre", |r| r.centre),
        ("branch", |r| r.branch),
    ] {
        let flat: Vec<f64> = contacts.iter().flat_map(|r| {
            let v = f(r);
            [v.x, v.y, v.z]
        }).collect();
        c.new_dataset::<f64>().shape((n, 3)).create(what)?.write_raw(&flat)?;
    }
    Ok(())
}
