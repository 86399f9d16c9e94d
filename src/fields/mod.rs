//! Continuum fields from particles: coarse-grained density, velocity and
//! stress (Goldhirsch 2010; Weinhart et al. 2012, as MercuryDPM's
//! coarse-graining computes them), on a profile along one axis (the fields
//! averaged over the other two) or on a 3D grid, averaged over time.
//!
//! Per sample, at each point r of the profile or grid, with kernel phi:
//! - density rho = sum_i m_i phi(r - r_i);
//! - momentum p = sum_i m_i v_i phi(r - r_i), velocity V = p / rho;
//! - kinetic stress sum_i m_i v'_i v'_i phi with v' = v - V, computed as
//!   sum_i m_i v_i v_i phi - p p / rho;
//! - contact stress sum_c f_c (x) b_c psi_c(r): f_c the force on particle
//!   i, b_c its branch vector (from the partner's centre to i's, or from a
//!   wall's contact point to i's centre), psi_c the kernel's line integral
//!   along the branch, from i's centre back to the partner's (or the wall's
//!   contact point) - so that the momentum balance holds exactly.
//!
//! Stress is compression positive: sigma_ab = (kinetic) + sum f_a b_b psi,
//! whose divergence balances the weight: d sigma_zz / dz = rho g_z in a bed
//! at rest. Over samples (snapshots, or output times of a run) density,
//! momentum, the kinetic flux and the contact stress are averaged, and the
//! velocity and the kinetic stress are made from those averages.

pub mod kernel;
pub mod live;
pub mod snapshots;
pub mod write;

use crate::dim::Vec3;
use kernel::Kernel;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A contact as the stress needs it: the force on particle `a`, its contact
/// point, and the branch vector to a's centre from the partner's centre (a
/// pair) or from the contact point (a wall). Each contact appears once.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactRecord {
    /// The id of the particle the force acts on (a pair's lower id).
    pub a: u64,
    /// The partner's id (a pair), or the wall's index in the case's walls.
    pub partner: u64,
    pub wall: bool,
    /// The force on `a` (N); the partner takes minus it.
    pub force: Vec3,
    /// The contact point (m).
    pub point: Vec3,
    /// a's centre (m), where the branch ends.
    pub centre: Vec3,
    /// From the partner's centre (pair) or the contact point (wall) to a's centre (m).
    pub branch: Vec3,
}

/// The kernel and points of a fields request (the case's `[output.fields]`
/// or `talus fields`' options). Errors are (key, value, why).
pub fn plan(
    kernel: &str,
    width: f64,
    profile: Option<&str>,
    grid: Option<[usize; 3]>,
    points: Option<usize>,
) -> Result<(Kernel, Points), (String, String, String)> {
    let k = match kernel {
        "gauss" | "lucy" => Kernel::new(kernel, width).map_err(|why| ("width".to_string(), width.to_string(), why))?,
        _ => return Err(("kernel".into(), format!("\"{kernel}\""), "must be \"gauss\" or \"lucy\"".into())),
    };
    let points = match (profile, grid) {
        (Some(a), None) => {
            let axis = match a {
                "x" => 0,
                "y" => 1,
                "z" => 2,
                _ => return Err(("profile".into(), format!("\"{a}\""), "must be \"x\", \"y\" or \"z\"".into())),
            };
            let n = points.unwrap_or(100);
            if n == 0 || n > 10_000_000 {
                return Err(("points".into(), n.to_string(), "must be from 1 to 10000000".into()));
            }
            Points::Profile { axis, n }
        }
        (None, Some(n)) => {
            if n.iter().any(|&x| x == 0) || n.iter().map(|&x| x as u128).product::<u128>() > 100_000_000 {
                return Err(("grid".into(), format!("{n:?}"), "must be at least one cell along each axis and at most 1e8 cells".into()));
            }
            if points.is_some() {
                return Err(("points".into(), format!("{}", points.unwrap()), "is for a profile; a grid has its cells".into()));
            }
            Points::Grid { n }
        }
        (Some(_), Some(_)) => return Err(("grid".into(), String::new(), "a profile or a grid, not both".into())),
        (None, None) => return Err(("profile".into(), String::new(), "say profile = \"x\", \"y\" or \"z\", or grid = [nx, ny, nz]".into())),
    };
    Ok((k, points))
}

/// Where the fields are evaluated.
#[derive(Clone, Debug, PartialEq)]
pub enum Points {
    /// `n` points along `axis` (0, 1, 2), at the centres of n equal bins of
    /// the domain's extent: the fields averaged over the other two axes.
    Profile { axis: usize, n: usize },
    /// The centres of an nx x ny x nz grid of equal cells over the domain.
    Grid { n: [usize; 3] },
}

/// The domain the fields cover: its box and which axes are periodic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain {
    pub lo: Vec3,
    pub hi: Vec3,
    pub periodic: [bool; 3],
}

impl Domain {
    fn period(&self, k: usize) -> Option<f64> {
        self.periodic[k].then(|| self.hi[k] - self.lo[k])
    }
}

/// One sample's particles as the fields read them.
pub struct Sample<'a> {
    pub pos: &'a [Vec3],
    pub vel: &'a [Vec3],
    pub mass: &'a [f64],
    pub contacts: &'a [ContactRecord],
}

impl<'a> Sample<'a> {
    /// The particles `p` (all of them: gathered, no ghosts) and `contacts`.
    pub fn of(p: &'a crate::particles::Particles, contacts: &'a [ContactRecord]) -> Sample<'a> {
        Sample { pos: &p.pos, vel: &p.vel, mass: &p.mass, contacts }
    }
}

/// Running sums of the fields over samples.
#[derive(Clone, Debug)]
pub struct Fields {
    pub kernel: Kernel,
    pub points: Points,
    pub domain: Domain,
    pub samples: usize,
    /// Per point, summed over samples.
    acc: Vec<Acc>,
}

/// One point's sums over samples.
#[derive(Clone, Copy, Debug, Default)]
struct Acc {
    /// kg/m^3
    density: f64,
    /// kg/m^2/s
    momentum: [f64; 3],
    /// sum m v_a v_b phi (Pa), row-major 3x3
    flux: [f64; 9],
    /// sum f_a b_b psi (Pa), row-major 3x3
    contact: [f64; 9],
}

impl Acc {
    #[inline]
    fn particle(&mut self, w: f64, v: &Vec3) {
        self.density += w;
        for a in 0..3 {
            let wv = w * v[a];
            self.momentum[a] += wv;
            for b in 0..3 {
                self.flux[3 * a + b] += wv * v[b];
            }
        }
    }

    #[inline]
    fn contact(&mut self, fb: &[f64; 9], w: f64) {
        for q in 0..9 {
            self.contact[q] += fb[q] * w;
        }
    }
}

/// Points a thread takes at once: each point's sums take the samples'
/// particles and contacts in their order, whichever thread computes it, so
/// the fields are the same bits on any thread count.
const CHUNK: usize = 8;

/// The time-averaged fields at each point.
#[derive(Clone, Debug, Default)]
pub struct Averaged {
    /// The points' coordinates (m).
    pub at: Vec<Vec3>,
    pub density: Vec<f64>,
    pub velocity: Vec<Vec3>,
    /// Kinetic stress, row-major 3x3 (Pa, compression positive).
    pub kinetic: Vec<[f64; 9]>,
    /// Contact stress, row-major 3x3 (Pa, compression positive).
    pub contact: Vec<[f64; 9]>,
}

impl Averaged {
    /// Kinetic plus contact stress, component (a, b).
    pub fn stress(&self, i: usize, a: usize, b: usize) -> f64 {
        self.kinetic[i][3 * a + b] + self.contact[i][3 * a + b]
    }
}

impl Fields {
    /// Fields on `points` of `domain` with `kernel`. Refuses empty or
    /// inverted domains and zero point counts.
    pub fn new(kernel: Kernel, points: Points, domain: Domain) -> Result<Fields, String> {
        for k in 0..3 {
            if !(domain.hi[k] > domain.lo[k]) {
                return Err(format!("the domain is empty along axis {k}: lo {} hi {}", domain.lo[k], domain.hi[k]));
            }
        }
        let count = match &points {
            Points::Profile { axis, n } => {
                if *axis > 2 {
                    return Err(format!("no axis {axis}"));
                }
                *n
            }
            Points::Grid { n } => n.iter().product(),
        };
        if count == 0 {
            return Err("the fields need at least one point along each axis".into());
        }
        Ok(Fields {
            kernel,
            points,
            domain,
            samples: 0,
            acc: vec![Acc::default(); count],
        })
    }

    /// The coordinates of every point (profile: along its axis, the other
    /// coordinates at the domain's centre; grid: x fastest, then y, then z).
    pub fn coordinates(&self) -> Vec<Vec3> {
        let d = &self.domain;
        let centre = (d.lo + d.hi) * 0.5;
        match &self.points {
            Points::Profile { axis, n } => (0..*n)
                .map(|i| {
                    let mut x = centre;
                    x[*axis] = bin_centre(d.lo[*axis], d.hi[*axis], *n, i);
                    x
                })
                .collect(),
            Points::Grid { n } => {
                let mut v = Vec::with_capacity(n.iter().product());
                for iz in 0..n[2] {
                    for iy in 0..n[1] {
                        for ix in 0..n[0] {
                            v.push(Vec3::new(
                                bin_centre(d.lo.x, d.hi.x, n[0], ix),
                                bin_centre(d.lo.y, d.hi.y, n[1], iy),
                                bin_centre(d.lo.z, d.hi.z, n[2], iz),
                            ));
                        }
                    }
                }
                v
            }
        }
    }

    /// Add one sample (every particle and every contact of one time).
    pub fn add(&mut self, s: &Sample) {
        match self.points.clone() {
            Points::Profile { axis, n } => self.add_profile(s, axis, n),
            Points::Grid { n } => self.add_grid(s, n),
        }
        self.samples += 1;
    }

    fn add_profile(&mut self, s: &Sample, axis: usize, n: usize) {
        let d = self.domain;
        let (lo, hi) = (d.lo[axis], d.hi[axis]);
        let h = (hi - lo) / n as f64;
        let area: f64 = (0..3).filter(|&k| k != axis).map(|k| d.hi[k] - d.lo[k]).product();
        let period = d.period(axis);
        let k = self.kernel;
        let cut = k.cutoff();
        // calls f(point, its coordinate as seen from [x0, x1]) for the points
        // of first..end within reach of [x0, x1] (and of its images across a periodic axis)
        let reach = |x0: f64, x1: f64, first: usize, end: usize, f: &mut dyn FnMut(usize, f64)| {
            let shifts: &[f64] = match period {
                Some(l) => &[-l, 0.0, l],
                None => &[0.0],
            };
            for &sh in shifts {
                let (a, b) = (x0.min(x1) + sh - cut, x0.max(x1) + sh + cut);
                let i0 = (((a - lo) / h - 0.5).floor().max(first as f64)) as usize;
                let i1 = (((b - lo) / h - 0.5).ceil()).min(end as f64 - 1.0);
                if i1 < 0.0 {
                    continue;
                }
                for i in i0..=(i1 as usize) {
                    f(i, bin_centre(lo, hi, n, i) - sh);
                }
            }
        };
        self.acc.par_chunks_mut(CHUNK).enumerate().for_each(|(c, acc)| {
            let (first, end) = (c * CHUNK, c * CHUNK + acc.len());
            for i in 0..s.pos.len() {
                let (m, v, z) = (s.mass[i], &s.vel[i], s.pos[i][axis]);
                reach(z, z, first, end, &mut |p, zp| {
                    let w = m * k.phi1(zp - z) / area;
                    if w != 0.0 {
                        acc[p - first].particle(w, v);
                    }
                });
            }
            for c in s.contacts {
                // from a's centre back along the branch to the partner (or the wall's point)
                let z0 = c.centre[axis];
                let z1 = z0 - c.branch[axis];
                let fb = outer(&c.force, &c.branch);
                reach(z0, z1, first, end, &mut |p, zp| {
                    let psi = k.mean1(zp - z1, zp - z0) / area;
                    if psi != 0.0 {
                        acc[p - first].contact(&fb, psi);
                    }
                });
            }
        });
    }

    fn add_grid(&mut self, s: &Sample, n: [usize; 3]) {
        let d = self.domain;
        let k = self.kernel;
        let cut = k.cutoff();
        let h = Vec3::new((d.hi.x - d.lo.x) / n[0] as f64, (d.hi.y - d.lo.y) / n[1] as f64, (d.hi.z - d.lo.z) / n[2] as f64);
        let slab = n[0] * n[1];
        // calls f(point - first, kernel value) for every grid point of the
        // slabs z0..z1 within the cutoff of x
        let around = |x: Vec3, z0: usize, z1: usize, f: &mut dyn FnMut(usize, f64)| {
            let mut range = [(0i64, 0i64); 3];
            for a in 0..3 {
                let i0 = ((x[a] - cut - d.lo[a]) / h[a] - 0.5).floor() as i64;
                let i1 = ((x[a] + cut - d.lo[a]) / h[a] - 0.5).ceil() as i64;
                range[a] = if d.periodic[a] { (i0, i1.min(i0 + n[a] as i64 - 1)) } else { (i0.max(0), i1.min(n[a] as i64 - 1)) };
            }
            for iz in range[2].0..=range[2].1 {
                let cz = iz.rem_euclid(n[2] as i64) as usize;
                if cz < z0 || cz >= z1 {
                    continue;
                }
                let dz = d.lo.z + (iz as f64 + 0.5) * h.z - x.z;
                for iy in range[1].0..=range[1].1 {
                    let cy = iy.rem_euclid(n[1] as i64) as usize;
                    let dy = d.lo.y + (iy as f64 + 0.5) * h.y - x.y;
                    for ix in range[0].0..=range[0].1 {
                        // an index past a periodic face is the point on the other side, seen from x
                        let cx = ix.rem_euclid(n[0] as i64) as usize;
                        let dx = d.lo.x + (ix as f64 + 0.5) * h.x - x.x;
                        let w = k.phi3(dx * dx + dy * dy + dz * dz);
                        if w != 0.0 {
                            f(cx + n[0] * (cy + n[1] * (cz - z0)), w);
                        }
                    }
                }
            }
        };
        // whether [za, zb] (widened by the cutoff) reaches the slabs z0..z1
        let near = |za: f64, zb: f64, z0: usize, z1: usize| {
            d.periodic[2] || (za.max(zb) + cut >= d.lo.z + z0 as f64 * h.z && za.min(zb) - cut <= d.lo.z + z1 as f64 * h.z)
        };
        // the line integral along each branch: Gauss-Legendre, three points
        // on each piece no longer than a fifth of the kernel's width
        const GL: [(f64, f64); 3] = [(-0.774_596_669_241_483_4, 5.0 / 18.0), (0.0, 8.0 / 18.0), (0.774_596_669_241_483_4, 5.0 / 18.0)];
        self.acc.par_chunks_mut(slab).enumerate().for_each(|(z0, acc)| {
            let z1 = z0 + 1;
            for i in 0..s.pos.len() {
                if !near(s.pos[i].z, s.pos[i].z, z0, z1) {
                    continue;
                }
                let (m, v) = (s.mass[i], &s.vel[i]);
                around(s.pos[i], z0, z1, &mut |p, phi| acc[p].particle(m * phi, v));
            }
            for c in s.contacts {
                let x0 = c.centre;
                if !near(x0.z, x0.z - c.branch.z, z0, z1) {
                    continue;
                }
                let fb = outer(&c.force, &c.branch);
                let pieces = ((c.branch.norm() / (0.2 * k.width())).ceil() as usize).max(1);
                for piece in 0..pieces {
                    for &(t, wt) in &GL {
                        let u = (piece as f64 + 0.5 + 0.5 * t) / pieces as f64;
                        let x = x0 - c.branch * u;
                        let weight = wt / pieces as f64;
                        around(x, z0, z1, &mut |p, phi| acc[p].contact(&fb, phi * weight));
                    }
                }
            }
        });
    }

    /// The fields averaged over the samples so far.
    pub fn averaged(&self) -> Averaged {
        let m = self.samples.max(1) as f64;
        let mut out = Averaged { at: self.coordinates(), ..Default::default() };
        for a in &self.acc {
            let rho = a.density / m;
            let p = Vec3::new(a.momentum[0], a.momentum[1], a.momentum[2]) / m;
            let v = if rho > 0.0 { p / rho } else { Vec3::zeros() };
            let mut kin = [0.0; 9];
            for i in 0..3 {
                for j in 0..3 {
                    kin[3 * i + j] = a.flux[3 * i + j] / m - if rho > 0.0 { p[i] * p[j] / rho } else { 0.0 };
                }
            }
            out.density.push(rho);
            out.velocity.push(v);
            out.kinetic.push(kin);
            out.contact.push(a.contact.map(|x| x / m));
        }
        out
    }
}

impl Fields {
    /// The file the fields go to in `dir`: `profile_<axis>.csv` or `fields.xdmf`.
    pub fn file_name(&self) -> String {
        match &self.points {
            Points::Profile { axis, .. } => format!("profile_{}.csv", ["x", "y", "z"][*axis]),
            Points::Grid { .. } => "fields.xdmf".into(),
        }
    }

    /// Write the averages so far into `dir` (replaced atomically); returns the file.
    pub fn write_to(&self, dir: &std::path::Path) -> Result<std::path::PathBuf, crate::error::TalusError> {
        let avg = self.averaged();
        match &self.points {
            Points::Profile { axis, .. } => write::profile_csv(&dir.join(self.file_name()), *axis, &avg)?,
            Points::Grid { n } => {
                let d = &self.domain;
                let h = [0, 1, 2].map(|k| (d.hi[k] - d.lo[k]) / n[k] as f64);
                let origin = [0, 1, 2].map(|k| d.lo[k] + 0.5 * h[k]);
                write::grid_hdf5(dir, *n, origin, h, &avg)?
            }
        }
        Ok(dir.join(self.file_name()))
    }
}

/// What [`from_snapshots`] made.
pub struct FromSnapshots {
    pub fields: Fields,
    /// Times of the first and last snapshot used (s).
    pub first: f64,
    pub last: f64,
    /// Contacts in the last snapshot used.
    pub contacts: usize,
    pub warnings: Vec<String>,
}

/// The fields of a run's snapshots (`RUN_DIR/snapshots.h5`) from `from` to
/// `to` (s, inclusive), averaged over them.
pub fn from_snapshots(run: &std::path::Path, kernel: Kernel, points: Points, from: Option<f64>, to: Option<f64>) -> Result<FromSnapshots, crate::error::TalusError> {
    use crate::error::TalusError;
    let file = snapshots::SnapshotFile::open(run)?;
    let mut fields = Fields::new(kernel, points, file.domain).map_err(TalusError::Input)?;
    let (t0, t1) = (from.unwrap_or(f64::NEG_INFINITY), to.unwrap_or(f64::INFINITY));
    let chosen: Vec<_> = file.index.iter().filter(|(_, t)| *t >= t0 && *t <= t1).collect();
    if chosen.is_empty() {
        let times = file.index.iter().map(|(_, t)| format!("{t:.4e}")).collect::<Vec<_>>();
        return Err(TalusError::Input(format!(
            "{}: no snapshot from t = {} to {} s (the file holds {} snapshots{})",
            run.display(),
            from.map_or("the start".to_string(), |t| t.to_string()),
            to.map_or("the end".to_string(), |t| t.to_string()),
            times.len(),
            if times.is_empty() { String::new() } else { format!(", at {} ... {} s", times[0], times[times.len() - 1]) }
        )));
    }
    let mut warnings = Vec::new();
    let (mut first, mut last, mut contacts) = (f64::NAN, f64::NAN, 0);
    let mut missing = 0;
    for (name, t) in &chosen {
        let s = file.read(name)?;
        let c = s.contacts.unwrap_or_else(|| {
            missing += 1;
            Vec::new()
        });
        fields.add(&Sample { pos: &s.pos, vel: &s.vel, mass: &s.mass, contacts: &c });
        if first.is_nan() {
            first = *t;
        }
        last = *t;
        contacts = c.len();
    }
    if missing > 0 {
        warnings.push(format!(
            "{missing} of {} snapshots carry no contacts (the run had output.contacts = false): their contact stress is zero",
            chosen.len()
        ));
    }
    Ok(FromSnapshots { fields, first, last, contacts, warnings })
}

/// The centre of bin i of n equal bins of [lo, hi].
fn bin_centre(lo: f64, hi: f64, n: usize, i: usize) -> f64 {
    lo + (i as f64 + 0.5) * (hi - lo) / n as f64
}

fn outer(f: &Vec3, b: &Vec3) -> [f64; 9] {
    let mut o = [0.0; 9];
    for a in 0..3 {
        for c in 0..3 {
            o[3 * a + c] = f[a] * b[c];
        }
    }
    o
}

