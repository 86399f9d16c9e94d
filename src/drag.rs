//! The drag paper (D2 of CASES.md): a rigid cylinder pulled upward at constant
//! speed through a confined two-dimensional bed, and the force of the granules
//! on it. `talus drag CASE` runs one drag case over its seeded beds:
//!
//! 1. radii: N granules of size D_g (1 +- spread) (uniform), container W wide and
//!    H = (sum of granule areas / V_f + cylinder area) / W high (paper eq. 18);
//! 2. a loose random state: every granule placed at random, without overlap, at
//!    `growth_from` of its radius (seeded ChaCha8: the same bed on every machine);
//! 3. compaction by growing the radii linearly to full size over `growth_time`
//!    (an isotropic compaction to the target area fraction; with friction on, the
//!    bed jams below the target and the rest of the growth pressurises it), then
//!    `settle_time`;
//! 4. the cylinder moves at `cylinder_speed` along +y for `travel`; every step the
//!    drag (force of the granules on the cylinder against its motion) is recorded.
//!
//! Granules are spheres moving in the plane (2D as LIGGGHTS `dimension 2`),
//! dumbbells (rigid pairs of discs, `clump.rs`) or ellipses of the equivalent
//! area (semi-axes r sqrt(lambda), r / sqrt(lambda), placed at a random angle),
//! Hertz-Mindlin with Coulomb friction in talus's convention.

use crate::builder::CaseBuilder;
use crate::case::{Case, ContactSection, EllipseEntry, ModelName, ParticleEntry, PhaseSection, TimeStep, WallSection};
use crate::contact::Convention;
use crate::contact::ellipse::{contact, Ellipse};
use crate::dim::{Dimension, Vec3};
use crate::error::TalusError;
use crate::material::{Material, Mixing, PairTable};
use crate::observe::{self, Observer};
use crate::sim::{rayleigh_time, Simulation};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GranuleShape {
    Disc,
    Dumbbell,
    Ellipse,
}

fn d_one() -> f64 { 1.0 }
fn d_count() -> usize { 400 }
fn d_vf() -> f64 { 0.84 }
fn d_width() -> f64 { 0.020 }
fn d_spread() -> f64 { 0.2 }
fn d_cyl() -> f64 { 3.175e-3 }
fn d_speed() -> f64 { 2.0 }
fn d_travel() -> f64 { 6.0e-3 }
fn d_window() -> [f64; 2] { [1.0e-3, 5.0e-3] }
fn d_seeds() -> Vec<u64> { vec![1, 2, 3, 4, 5] }
fn d_growth_from() -> f64 { 0.7 }
fn d_growth_time() -> f64 { 0.01 }
fn d_settle_time() -> f64 { 0.005 }
fn d_dt() -> f64 { 0.2 }
fn d_g() -> f64 { 9.81 }

/// `[drag]`: the set-up of one case of the paper's Tables 1 and 2.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DragSection {
    /// Case id (c1, d1, ...).
    pub id: String,
    pub shape: GranuleShape,
    /// Ellipse a/b (dumbbells: 2, discs: 1).
    #[serde(default = "d_one")]
    pub aspect_ratio: f64,
    /// Granule size D_g (m): disc diameter, ellipse sqrt(ab) diameter, dumbbell volume diameter.
    pub granule_size: f64,
    #[serde(default = "d_count")]
    pub count: usize,
    /// Granule area over (container area - cylinder area).
    #[serde(default = "d_vf")]
    pub area_fraction: f64,
    /// Container width W (m).
    #[serde(default = "d_width")]
    pub width: f64,
    /// Sizes uniform within +- this fraction of D_g.
    #[serde(default = "d_spread")]
    pub size_spread: f64,
    #[serde(default = "d_cyl")]
    pub cylinder_diameter: f64,
    #[serde(default = "d_speed")]
    pub cylinder_speed: f64,
    /// How far the cylinder moves (m); it starts at height H/2 - travel/2.
    #[serde(default = "d_travel")]
    pub travel: f64,
    /// Displacements over which the drag is averaged (m).
    #[serde(default = "d_window")]
    pub average_window: [f64; 2],
    #[serde(default = "d_seeds")]
    pub seeds: Vec<u64>,
    #[serde(default = "d_growth_from")]
    pub growth_from: f64,
    #[serde(default = "d_growth_time")]
    pub growth_time: f64,
    /// Friction during the growth (default: the material's, so that the bed
    /// jams below the target fraction and the rest of the growth pressurises it).
    pub growth_friction: Option<f64>,
    #[serde(default = "d_settle_time")]
    pub settle_time: f64,
    #[serde(default = "d_dt")]
    pub timestep_rayleigh_fraction: f64,
    /// Gravity along -y (m/s^2).
    #[serde(default = "d_g")]
    pub gravity: f64,
}

/// A drag case file: `[drag]` and one `[material]` (granules, walls and cylinder).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DragCase {
    pub drag: DragSection,
    pub material: Material,
    #[serde(skip)]
    pub path: PathBuf,
    /// Beds run side by side, one thread each (`talus drag --threads`; default:
    /// the cores available).
    #[serde(skip)]
    pub threads: Option<usize>,
}

impl DragCase {
    pub fn load(path: &Path) -> Result<DragCase, TalusError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| TalusError::io(format!("cannot read drag case {}", path.display()), e))?;
        let mut c: DragCase = toml::from_str(&text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start].matches('\n').count() + 1);
            let at = line.map(|l| format!(", line {l}")).unwrap_or_default();
            TalusError::Input(format!("{}{at}: {}", path.display(), e.message()))
        })?;
        c.path = path.to_path_buf();
        c.validate()?;
        Ok(c)
    }

    fn err(&self, key: &str, v: impl std::fmt::Display, why: &str) -> TalusError {
        TalusError::Input(format!("{}: drag.{key} = {v}: {why}", self.path.display()))
    }

    fn validate(&self) -> Result<(), TalusError> {
        self.material.validate(&self.path.display().to_string())?;
        let d = &self.drag;
        if d.shape == GranuleShape::Ellipse && !(d.aspect_ratio >= 1.0 && d.aspect_ratio <= 10.0) {
            return Err(self.err("aspect_ratio", d.aspect_ratio, "an ellipse's a/b must be in [1, 10]"));
        }
        for (k, v) in [
            ("granule_size", d.granule_size),
            ("width", d.width),
            ("cylinder_diameter", d.cylinder_diameter),
            ("cylinder_speed", d.cylinder_speed),
            ("travel", d.travel),
            ("growth_time", d.growth_time),
            ("settle_time", d.settle_time),
            ("timestep_rayleigh_fraction", d.timestep_rayleigh_fraction),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(self.err(k, v, "must be a positive number"));
            }
        }
        if !(d.area_fraction > 0.0 && d.area_fraction < 0.91) {
            return Err(self.err("area_fraction", d.area_fraction, "must be in (0, 0.91)"));
        }
        if !(d.size_spread >= 0.0 && d.size_spread < 1.0) {
            return Err(self.err("size_spread", d.size_spread, "must be in [0, 1)"));
        }
        if !(d.growth_from > 0.0 && d.growth_from <= 1.0) {
            return Err(self.err("growth_from", d.growth_from, "must be in (0, 1]"));
        }
        if d.count == 0 || d.seeds.is_empty() {
            return Err(self.err("count", d.count, "need at least one granule and one seed"));
        }
        // before any bed is made: every bed running at once holds its granules (a
        // dumbbell two discs) in a simulation of its own
        let beds = d.seeds.len().min(self.threads.unwrap_or(usize::MAX)).min(std::thread::available_parallelism().map_or(1, |n| n.get()));
        let bodies = if d.shape == GranuleShape::Dumbbell { 2.0 } else { 1.0 };
        let need = d.count as f64 * bodies * beds as f64 * crate::checks::BYTES_PER_PARTICLE;
        if let Some((avail, source)) = crate::checks::available_memory() {
            if need > avail {
                return Err(self.err(
                    "count",
                    d.count,
                    &format!(
                        "{beds} bed(s) side by side of {} granules need about {need:.3e} bytes of memory ({} bytes per particle, a generous estimate), more than the {avail:.3e} bytes available ({source})",
                        d.count,
                        crate::checks::BYTES_PER_PARTICLE
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Container height (m) and the full radii of a bed.
    pub fn bed_radii(&self, seed: u64) -> (f64, Vec<f64>) {
        let d = &self.drag;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let radii: Vec<f64> =
            (0..d.count).map(|_| 0.5 * d.granule_size * (1.0 + d.size_spread * (2.0 * rng.random::<f64>() - 1.0))).collect();
        let area: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
        let rc = 0.5 * d.cylinder_diameter;
        let h = (area / d.area_fraction + std::f64::consts::PI * rc * rc) / d.width;
        (h, radii)
    }

    /// The talus case of one bed: granules at `growth_from` of their size placed at
    /// random without overlap (a dumbbell: two discs of diameter sqrt(2) D / 2
    /// touching at its centre, at a random angle), the four container walls, the
    /// cylinder at rest. Returns the case and every particle's full radius (id order).
    pub fn bed_case(&self, seed: u64) -> Result<(Case, Vec<f64>), TalusError> {
        let (h, granules) = self.bed_radii(seed);
        let bed = self.place_granules(seed, h, &granules)?;
        let case = self.assemble_bed(seed, h, &bed)?;
        Ok((case, bed.full))
    }

    /// Place every granule at random at `growth_from` of its size, without overlap
    /// with the others, the container (W x `h`, m) and the cylinder.
    fn place_granules(&self, seed: u64, h: f64, granules: &[f64]) -> Result<Bed, TalusError> {
        let d = &self.drag;
        let w = d.width;
        let rc = 0.5 * d.cylinder_diameter;
        let (cx, cy) = (0.5 * w, 0.5 * h - 0.5 * d.travel);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_0000_0000);
        let s0 = d.growth_from;
        let dumbbell = d.shape == GranuleShape::Dumbbell;
        let ellipse = d.shape == GranuleShape::Ellipse;
        let mut bed = Bed {
            placed: Vec::with_capacity(2 * d.count),
            full: Vec::with_capacity(2 * d.count),
            clumps: Vec::new(),
            bodies: Vec::with_capacity(d.count),
        };
        let mut angle_rng = ChaCha8Rng::seed_from_u64(seed ^ 0xa9_1e00_0000);
        let mut tries = 0u64;
        let free = |placed: &[(f64, f64, f64)], x: f64, y: f64, r: f64| {
            x > r
                && x < w - r
                && y > r
                && y < h - r
                && (x - cx).powi(2) + (y - cy).powi(2) > (r + rc).powi(2)
                && placed.iter().all(|&(a, b, q)| (x - a).powi(2) + (y - b).powi(2) > (r + q).powi(2))
        };
        let cyl = Ellipse::new(Vec3::new(cx, cy, 0.0), rc, rc, 0.0);
        let free_ellipse = |bodies: &[Ellipse], e: &Ellipse| {
            let (c, hx, hy) = (e.c, e.support(1.0, 0.0), e.support(0.0, 1.0));
            c.x > hx
                && c.x < w - hx
                && c.y > hy
                && c.y < h - hy
                && contact(&cyl, e).is_none()
                && bodies.iter().all(|o| (o.c - c).norm() >= o.a + e.a || contact(o, e).is_none())
        };
        for &rg in granules {
            loop {
                tries += 1;
                if tries > 5_000_000 {
                    return Err(TalusError::Input(format!(
                        "{}: cannot place {} granules at {s0} of their size without overlap (seed {seed}); lower drag.growth_from",
                        self.path.display(),
                        d.count
                    )));
                }
                let x = w * rng.random::<f64>();
                let y = h * rng.random::<f64>();
                if dumbbell {
                    let rs = std::f64::consts::FRAC_1_SQRT_2 * rg;
                    let th = std::f64::consts::TAU * rng.random::<f64>();
                    let (ex, ey) = (s0 * rs * th.cos(), s0 * rs * th.sin());
                    let (a, b) = ((x + ex, y + ey), (x - ex, y - ey));
                    if free(&bed.placed, a.0, a.1, s0 * rs) && free(&bed.placed, b.0, b.1, s0 * rs) {
                        let n = bed.placed.len() as u64;
                        bed.placed.push((a.0, a.1, s0 * rs));
                        bed.placed.push((b.0, b.1, s0 * rs));
                        bed.full.extend([rs, rs]);
                        bed.clumps.push([n + 1, n + 2]);
                        break;
                    }
                } else if ellipse {
                    let l = d.aspect_ratio.sqrt();
                    // angles from their own stream: at aspect ratio 1 the bed is the disc bed
                    let th = std::f64::consts::PI * angle_rng.random::<f64>();
                    let e = Ellipse::new(Vec3::new(x, y, 0.0), s0 * rg * l, s0 * rg / l, th);
                    if free_ellipse(&bed.bodies, &e) {
                        bed.bodies.push(e);
                        bed.placed.push((x, y, s0 * rg));
                        bed.full.push(rg);
                        break;
                    }
                } else if free(&bed.placed, x, y, s0 * rg) {
                    bed.placed.push((x, y, s0 * rg));
                    bed.full.push(rg);
                    break;
                }
            }
        }
        Ok(bed)
    }

    /// The case of a placed bed of height `h` (m): the granules, the four
    /// container walls, the cylinder at rest, one phase as long as growth,
    /// settling and drag together; validated as a case file named
    /// `ID-bedSEED.toml` next to the drag case.
    fn assemble_bed(&self, seed: u64, h: f64, bed: &Bed) -> Result<Case, TalusError> {
        let d = &self.drag;
        let m = &self.material;
        let w = d.width;
        let rc = 0.5 * d.cylinder_diameter;
        let (cx, cy) = (0.5 * w, 0.5 * h - 0.5 * d.travel);
        let rmin = bed.full.iter().cloned().fold(f64::INFINITY, f64::min);
        let dt = d.timestep_rayleigh_fraction * rayleigh_time(rmin, m.density, m.shear_modulus(), m.poisson_ratio);
        let total = d.growth_time + d.settle_time + d.travel / d.cylinder_speed;
        let list = bed.placed.iter().enumerate().map(|(k, &(x, y, r0))| ParticleEntry::at(k as u64 + 1, [x, y, 0.0], r0)).collect();
        let ellipses = match d.shape {
            GranuleShape::Ellipse => bed
                .bodies
                .iter()
                .enumerate()
                .map(|(k, e)| EllipseEntry { id: k as u64 + 1, aspect_ratio: d.aspect_ratio, angle: e.theta })
                .collect(),
            _ => Vec::new(),
        };
        let mut b = CaseBuilder::new(Dimension::Two)
            .timestep(TimeStep::Seconds(dt))
            .force_timestep(true)
            .gravity([0.0, -d.gravity, 0.0])
            .skin(0.1 * d.granule_size)
            .domain([-0.5 * w, -0.5 * h, -1.0], [1.5 * w, 1.5 * h, 1.0])
            .contact(ContactSection { convention: Convention::Talus, ..ContactSection::new(ModelName::Hertz) })
            .material(m.clone())
            .particle_list(&m.name, list)
            .ellipses(ellipses)
            .clumps(bed.clumps.clone());
        for (name, point, normal) in [
            ("floor", [0.0, 0.0], [0.0, 1.0]),
            ("lid", [0.0, h], [0.0, -1.0]),
            ("left", [0.0, 0.0], [1.0, 0.0]),
            ("right", [w, 0.0], [-1.0, 0.0]),
        ] {
            b = b.wall(WallSection::plane(name, &m.name, [point[0], point[1], 0.0], [normal[0], normal[1], 0.0]));
        }
        b.wall(WallSection::disc("cylinder", &m.name, [cx, cy, 0.0], rc))
            .phase(PhaseSection::new("drag", total))
            .build(&self.path.with_file_name(format!("{}-bed{seed}.toml", d.id)))
    }
}

/// A bed placed at the start of the growth: (x, y, radius at `growth_from`) of
/// every particle (m), its full radius (m), the dumbbells' id pairs, and for
/// ellipses the body of every granule at `growth_from` (its angle is the case's).
struct Bed {
    placed: Vec<(f64, f64, f64)>,
    full: Vec<f64>,
    clumps: Vec<[u64; 2]>,
    bodies: Vec<Ellipse>,
}

/// One bed's drag series: (displacement m, drag N) every step.
#[derive(Serialize, Deserialize)]
pub struct BedResult {
    pub seed: u64,
    pub series: Vec<(f64, f64)>,
    pub mean_drag: f64,
    pub steps: u64,
    /// The bed's final `state_hash` (every particle's id, position, velocity, spin).
    pub state_hash: String,
    /// Snapshots (displacement, per granule: id, x, y, radius (a), minor semi-axis b, angle) at the start, middle and end of the drag.
    pub snapshots: Vec<(f64, Vec<(u64, f64, f64, f64, f64, f64)>)>,
}

/// The drag series of one bed, observed after every step of the drag: the
/// force of the granules on the cylinder against its motion, and the granules
/// at the start, middle and end.
struct DragSeries {
    cylinder: usize,
    speed: f64,
    n_drag: u64,
    start_step: u64,
    series: Vec<(f64, f64)>,
    snapshots: Vec<(f64, Vec<(u64, f64, f64, f64, f64, f64)>)>,
}

impl DragSeries {
    fn new(sim: &Simulation, cylinder: usize, speed: f64, n_drag: u64) -> DragSeries {
        let mut s = DragSeries {
            cylinder,
            speed,
            n_drag,
            start_step: sim.step_count(),
            series: Vec::with_capacity(n_drag as usize),
            snapshots: Vec::new(),
        };
        s.snapshot(sim, 0.0);
        s
    }

    fn snapshot(&mut self, sim: &Simulation, s: f64) {
        let p = sim.particles();
        self.snapshots.push((s, (0..p.len()).map(|i| (p.id[i], p.pos[i].x, p.pos[i].y, p.radius[i], p.minor[i], p.angle[i])).collect()));
    }
}

impl Observer for DragSeries {
    fn after_step(&mut self, sim: &mut Simulation, _: f64) -> Result<(), TalusError> {
        let k = sim.step_count() - self.start_step;
        let s = self.speed * sim.dt() * k as f64;
        if k == self.n_drag / 2 || k == self.n_drag {
            self.snapshot(sim, s);
        }
        // force of the granules on the cylinder, against its motion
        let f = sim.walls()[self.cylinder].force;
        self.series.push((s, -f.dot(&Vec3::new(0.0, self.speed, 0.0)) / self.speed));
        Ok(())
    }
}

/// Prepare one bed: the granules grow to their full size, then settle. Returns
/// the simulation at the start of the drag and the bed's case. `threads`, where
/// given, is the simulation's thread count (not written into the case).
fn prepare_bed(dc: &DragCase, seed: u64, threads: Option<usize>) -> Result<(Simulation, Case), TalusError> {
    let d = &dc.drag;
    let (case, radii) = dc.bed_case(seed)?;
    let mut run_case = case.clone();
    if threads.is_some() {
        run_case.parallel.threads = threads;
    }
    let mut sim = Simulation::new(run_case)?;
    let dt = sim.dt();
    // growth (friction as set)
    let mut grow_mat = dc.material.clone();
    grow_mat.friction = d.growth_friction.unwrap_or(dc.material.friction);
    let table = sim.replace_pair_table(PairTable::new(&[grow_mat], Mixing::Liggghts));
    let n_grow = (d.growth_time / dt).ceil() as u64;
    for k in 1..=n_grow {
        let s = d.growth_from + (1.0 - d.growth_from) * k as f64 / n_grow as f64;
        // particle id k + 1 has full radius radii[k]
        sim.set_radii(|id| radii[(id - 1) as usize] * s);
        sim.step()?;
    }
    sim.replace_pair_table(table);
    for _ in 0..(d.settle_time / dt).ceil() as u64 {
        sim.step()?;
    }
    Ok((sim, case))
}

/// Prepare one bed and drag the cylinder through it (on the threads the case
/// gives, by default the cores).
pub fn run_bed(dc: &DragCase, seed: u64) -> Result<BedResult, TalusError> {
    run_bed_on(dc, seed, None)
}

/// `run_bed` on `threads` threads where given.
fn run_bed_on(dc: &DragCase, seed: u64, threads: Option<usize>) -> Result<BedResult, TalusError> {
    let d = &dc.drag;
    let (mut sim, _) = prepare_bed(dc, seed, threads)?;
    let dt = sim.dt();
    let cyl = sim.wall_index("cylinder").expect("made by bed_case");
    // drag: the series is an observer of the steps
    let v = Vec3::new(0.0, d.cylinder_speed, 0.0);
    sim.set_wall_velocity(cyl, v);
    let n_drag = (d.travel / d.cylinder_speed / dt).ceil() as u64;
    let mut drag = DragSeries::new(&sim, cyl, d.cylinder_speed, n_drag);
    for _ in 0..n_drag {
        observe::step(&mut sim, &mut [&mut drag])?;
    }
    let DragSeries { series, snapshots, .. } = drag;
    let [a, b] = d.average_window;
    let win: Vec<f64> = series.iter().filter(|(s, _)| *s >= a && *s <= b).map(|x| x.1).collect();
    let mean_drag = win.iter().sum::<f64>() / win.len().max(1) as f64;
    Ok(BedResult { seed, series, mean_drag, steps: sim.step_count(), state_hash: sim.state_hash(), snapshots })
}

/// Bed `seed` of a drag case as an ordinary case, for `talus run` and `talus
/// export`: the granules as prepared (grown and settled) in `<id>-bed<seed>.csv`,
/// and `<id>-bed<seed>.toml` with the container, the cylinder moving at the
/// drag speed, and one phase, the drag (the cylinder's travel at its speed).
/// The probes (every 1/300 of the drag) give the drag as the cylinder's force.
/// Dumbbells keep their clumps; ellipses are refused (their angles are not in
/// a particle file). Returns the case file written.
pub fn write_bed_case(dc: &DragCase, seed: u64, out: &Path) -> Result<PathBuf, TalusError> {
    let d = &dc.drag;
    if d.shape == GranuleShape::Ellipse {
        return Err(TalusError::Input(format!(
            "{}: drag.shape = \"ellipse\": a bed of ellipses cannot be written as a particle file (their angles), so it is not written as a case",
            dc.path.display()
        )));
    }
    let (sim, mut case) = prepare_bed(dc, seed, None)?;
    std::fs::create_dir_all(out).map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))?;
    let stem = format!("{}-bed{seed}", d.id);
    let csv = out.join(format!("{stem}.csv"));
    let p = sim.particles();
    let mut idx: Vec<usize> = (0..p.owned()).collect();
    idx.sort_unstable_by_key(|&i| p.id[i]);
    let mut text = String::from("id,x,y,z,radius,vx,vy,vz,wx,wy,wz\n");
    for &i in &idx {
        let (x, v, w) = (p.pos[i], p.vel[i], p.omega[i]);
        text.push_str(&format!(
            "{},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}\n",
            p.id[i], x.x, x.y, x.z, p.radius[i], v.x, v.y, v.z, w.x, w.y, w.z
        ));
    }
    crate::durable::write_atomic(&csv, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    case.particles.source = crate::case::ParticleSource::Csv(PathBuf::from(format!("{stem}.csv")));
    // a compacted bed: granules press on each other
    case.particles.overlap_tolerance = 0.5;
    let cyl = case.walls.iter().position(|w| w.name == "cylinder").expect("made by bed_case");
    case.walls[cyl].velocity = [0.0, d.cylinder_speed, 0.0];
    let drag_time = d.travel / d.cylinder_speed;
    case.phases = vec![PhaseSection::new("drag", drag_time)];
    case.output.interval = drag_time / 300.0;
    case.analysis = Some(crate::case::AnalysisSection::Drag { wall: "cylinder".into(), window: d.average_window });
    let toml = out.join(format!("{stem}.toml"));
    let head = format!(
        "# Bed {seed} of drag case {} ({}), grown and settled by talus: the granules in {stem}.csv,\n\
         # the cylinder pulled {} m at {} m/s. Written by `talus drag {} --bed-case {seed}`; run it with\n\
         # `talus run`, export it with `talus export`. The drag is -cylinder_force_y_n.\n\n",
        d.id,
        dc.path.display(),
        d.travel,
        d.cylinder_speed,
        dc.path.display()
    );
    let body = case.to_toml()?
        + &format!(
            "\n[compare]\n\
             replicas = 1             # single runs with the hand-set tolerances below (the ensemble comparison is not yet set up for it)\n\
             # one bed is one realisation of a dense granular flow: the engines agree on the mean\n\
             # drag (within 5%) and on the loads in the mean over the drag window (within 10% of\n\
             # each range), not force chain by force chain: instantaneous loads are held only\n\
             # against gross errors (within 1.5 times their range). Tangential loads and torques on the\n\
             # container, and the peak drag, fluctuate: compared in the plots, not checked.\n\
             figure_rel = 0.05\n\
             series_range = 1.5\n\
             windows = [[{}, {}]]\n\
             window_mean = 0.1\n\
             ignore = [\"peak_drag_n\", \"kinetic_energy_j\", \"floor_force_x_n\", \"lid_force_x_n\", \"left_force_y_n\", \"right_force_y_n\",\n\
             \"cylinder_force_x_n\", \"floor_torque_z_n_m\", \"lid_torque_z_n_m\", \"left_torque_z_n_m\", \"right_torque_z_n_m\", \"cylinder_torque_z_n_m\"]\n",
            d.average_window[0] / d.cylinder_speed,
            d.average_window[1] / d.cylinder_speed
        );
    crate::durable::write_atomic(&toml, |w| std::io::Write::write_all(w, (head + &body).as_bytes()))?;
    Ok(toml)
}

/// Every bed of a drag case, in the order of its seeds. The beds are
/// independent, so they run side by side, one thread each, on as many threads
/// as `threads` (`talus drag --threads`; by default the cores) and no more than
/// there are beds: a bed of a few hundred granules gains little from threads of
/// its own, and one simulation's results are the same bits on any thread count,
/// so each bed's state hash is the same as when the beds ran one after another.
/// On an error the study stops: the beds already running finish, no other
/// starts, and the error returned is `between`'s, else that of the first
/// failing bed in seed order (as when they ran one after another).
fn run_beds(dc: &DragCase, mut between: impl FnMut() -> Result<(), TalusError>) -> Result<Vec<BedResult>, TalusError> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let seeds = &dc.drag.seeds;
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let workers = dc.threads.unwrap_or(cores).clamp(1, seeds.len().max(1));
    let (next, stop) = (AtomicUsize::new(0), AtomicBool::new(false));
    let mut slots: Vec<Option<BedResult>> = seeds.iter().map(|_| None).collect();
    let mut failed: Option<(usize, TalusError)> = None;
    let mut interrupted = None;
    std::thread::scope(|s| {
        let (tx, rx) = std::sync::mpsc::channel();
        for _ in 0..workers {
            let (tx, next, stop) = (tx.clone(), &next, &stop);
            s.spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    if k >= seeds.len() {
                        break;
                    }
                    let r = run_bed_on(dc, seeds[k], Some(1));
                    let bad = r.is_err();
                    if tx.send((k, r)).is_err() || bad {
                        break;
                    }
                }
            });
        }
        drop(tx);
        // the results as they come: ends when every worker has stopped
        for (k, r) in rx {
            match r {
                Ok(b) => {
                    slots[k] = Some(b);
                    if interrupted.is_none() {
                        if let Err(e) = between() {
                            interrupted = Some(e);
                            stop.store(true, Ordering::Relaxed);
                        }
                    }
                }
                Err(e) => {
                    stop.store(true, Ordering::Relaxed);
                    if failed.as_ref().is_none_or(|(j, _)| k < *j) {
                        failed = Some((k, e));
                    }
                }
            }
        }
    });
    if let Some(e) = interrupted {
        return Err(e);
    }
    if let Some((_, e)) = failed {
        return Err(e);
    }
    Ok(slots.into_iter().map(|b| b.expect("every bed ran")).collect())
}

/// Run a drag case over its beds; writes `summary.json` (`mean_drag_n`,
/// `std_drag_n`, `beds`), `drag_vs_displacement.csv` (mean and standard deviation
/// over the beds at each displacement) and `beds.csv` (each bed's mean drag).
pub fn run(dc: &DragCase, out: &Path) -> Result<Map<String, Value>, TalusError> {
    run_with(dc, out, || Ok(()))
}

/// `run`, calling `between` (on the calling thread) after each bed: an error
/// from it stops the study there (the Python module checks for Ctrl-C so).
pub fn run_with(dc: &DragCase, out: &Path, between: impl FnMut() -> Result<(), TalusError>) -> Result<Map<String, Value>, TalusError> {
    std::fs::create_dir_all(out).map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))?;
    let start = std::time::Instant::now();
    let beds = run_beds(dc, between)?;
    write_study(dc, out, &beds, start.elapsed().as_secs_f64(), true)
}

/// `run` on the ranks of an MPI job (`mpirun -n P talus drag`): the beds are
/// dealt to the ranks in turn (bed k to rank k mod P), each rank runs its own
/// side by side on its share of the cores, and rank 0 writes the study. Each
/// bed's result does not depend on where it ran, so the outputs are those of
/// a run without mpirun. Every rank returns the summary; an error on any rank
/// is an error on every rank.
pub fn run_on(dc: &DragCase, out: &Path, comm: &crate::parallel::comm::Comm) -> Result<Map<String, Value>, TalusError> {
    let (rank, size) = (comm.rank(), comm.size());
    if size == 1 {
        return run(dc, out);
    }
    let start = std::time::Instant::now();
    let made = if rank == 0 {
        std::fs::create_dir_all(out).map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))
    } else {
        Ok(())
    };
    let mine: Vec<usize> = (0..dc.drag.seeds.len()).filter(|k| k % size == rank).collect();
    let mut share = dc.clone();
    share.drag.seeds = mine.iter().map(|&k| dc.drag.seeds[k]).collect();
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    share.threads = Some(dc.threads.unwrap_or((cores / size).max(1)));
    let result: Result<Vec<BedResult>, String> = match made {
        Err(e) => Err(e.to_string()),
        Ok(()) if share.drag.seeds.is_empty() => Ok(Vec::new()),
        Ok(()) => run_beds(&share, || Ok(())).map_err(|e| e.to_string()),
    };
    let mut slots: Vec<Option<BedResult>> = dc.drag.seeds.iter().map(|_| None).collect();
    let mut errors = Vec::new();
    for (r, got) in comm.all_gather_values(result).into_iter().enumerate() {
        match got {
            Ok(beds) => {
                let ks = (0..dc.drag.seeds.len()).filter(|k| k % size == r);
                for (k, b) in ks.zip(beds) {
                    slots[k] = Some(b);
                }
            }
            Err(e) => errors.push(format!("rank {r} of {size}: {e}")),
        }
    }
    if !errors.is_empty() {
        return Err(TalusError::Run(errors.join("; ")));
    }
    let beds: Vec<BedResult> = slots.into_iter().map(|b| b.expect("every bed ran on one rank")).collect();
    // rank 0 writes: its failure is every rank's
    crate::parallel::agreed(comm, write_study(dc, out, &beds, start.elapsed().as_secs_f64(), rank == 0))
}

/// The study's outputs from its beds (drag_vs_displacement.csv, snapshots.csv,
/// beds.csv, summary.json), written where `write`; returns the summary.
fn write_study(dc: &DragCase, out: &Path, beds: &[BedResult], wall: f64, write: bool) -> Result<Map<String, Value>, TalusError> {
    let n = beds.len() as f64;
    let means: Vec<f64> = beds.iter().map(|b| b.mean_drag).collect();
    let mean = means.iter().sum::<f64>() / n;
    let std = if beds.len() > 1 { (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 };
    let mut s = Map::new();
    s.insert("case".into(), json!(dc.drag.id));
    s.insert("shape".into(), json!(dc.drag.shape));
    s.insert("mean_drag_n".into(), json!(mean));
    s.insert("std_drag_n".into(), json!(std));
    s.insert("beds".into(), json!(beds.len()));
    s.insert("bed_mean_drag_n".into(), json!(means));
    s.insert("average_window_m".into(), json!(dc.drag.average_window));
    s.insert("wall_clock_s".into(), json!(wall));
    if write {
        write_files(dc, out, beds, &s)?;
    }
    Ok(s)
}

/// The study's files (see `write_study`).
fn write_files(dc: &DragCase, out: &Path, beds: &[BedResult], s: &Map<String, Value>) -> Result<(), TalusError> {
    let n = beds.len() as f64;
    let io = |e| TalusError::io(format!("writing into {}", out.display()), e);
    let mut f = std::io::BufWriter::new(std::fs::File::create(out.join("drag_vs_displacement.csv")).map_err(io)?);
    writeln!(f, "displacement_m,mean_drag_n,std_drag_n").map_err(io)?;
    let len = beds.iter().map(|b| b.series.len()).min().unwrap_or(0);
    for k in 0..len {
        let vals: Vec<f64> = beds.iter().map(|b| b.series[k].1).collect();
        let m = vals.iter().sum::<f64>() / n;
        let s = if beds.len() > 1 { (vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 };
        writeln!(f, "{:.6e},{m:.6e},{s:.6e}", beds[0].series[k].0).map_err(io)?;
    }
    f.flush().map_err(io)?;
    // the first bed's granules at the start, middle and end of the drag, with the
    // layer each started in (10 horizontal bands) and whether it belongs to the
    // tracked cluster (within one cylinder diameter above the cylinder at the start)
    let mut f = std::io::BufWriter::new(std::fs::File::create(out.join("snapshots.csv")).map_err(io)?);
    writeln!(f, "seed,displacement_m,id,x_m,y_m,radius_m,minor_m,angle_rad,layer,cluster,cylinder_x_m,cylinder_y_m,cylinder_radius_m").map_err(io)?;
    if let Some(b0) = beds.first() {
        let (h, _) = dc.bed_radii(b0.seed);
        let d = &dc.drag;
        let (cx, cy0, rc) = (0.5 * d.width, 0.5 * h - 0.5 * d.travel, 0.5 * d.cylinder_diameter);
        let start = &b0.snapshots[0].1;
        let tag: std::collections::HashMap<u64, (usize, bool)> = start
            .iter()
            .map(|&(id, x, y, _, _, _)| {
                let layer = ((y / h * 10.0).floor().max(0.0) as usize).min(9);
                let cluster = (x - cx).abs() < rc + 0.5 * d.granule_size && y > cy0 && y < cy0 + rc + d.cylinder_diameter;
                (id, (layer, cluster))
            })
            .collect();
        for (s, g) in &b0.snapshots {
            for &(id, x, y, r, rb, th) in g {
                let (layer, cluster) = tag[&id];
                writeln!(f, "{},{s:.6e},{id},{x:.6e},{y:.6e},{r:.6e},{rb:.6e},{th:.6e},{layer},{},{cx:.6e},{:.6e},{rc:.6e}", b0.seed, cluster as u8, cy0 + s)
                    .map_err(io)?;
            }
        }
    }
    f.flush().map_err(io)?;
    let mut b = std::fs::File::create(out.join("beds.csv")).map_err(io)?;
    writeln!(b, "seed,mean_drag_n,steps,state_hash").map_err(io)?;
    for bed in beds {
        writeln!(b, "{},{:.6e},{},{}", bed.seed, bed.mean_drag, bed.steps, bed.state_hash).map_err(io)?;
    }
    std::fs::write(out.join("summary.json"), serde_json::to_string_pretty(s).unwrap() + "\n").map_err(io)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// c1 cut short: 150 granules, three beds, a millimetre of travel.
    fn short(threads: usize) -> DragCase {
        let mut dc = DragCase::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/drag/c1.toml")).unwrap();
        let d = &mut dc.drag;
        (d.count, d.growth_time, d.settle_time, d.travel, d.average_window) = (150, 0.002, 0.001, 0.001, [0.0002, 0.0008]);
        d.seeds = vec![3, 1, 2];
        dc.threads = Some(threads);
        dc
    }

    #[test]
    fn beds_side_by_side_give_the_bits_of_beds_one_after_another() {
        let one = run_beds(&short(1), || Ok(())).unwrap();
        let three = run_beds(&short(3), || Ok(())).unwrap();
        // and each bed alone, its simulation on the default threads
        let alone: Vec<BedResult> = [3, 1, 2].iter().map(|&s| run_bed(&short(1), s).unwrap()).collect();
        for beds in [&three, &alone] {
            assert_eq!(beds.iter().map(|b| b.seed).collect::<Vec<_>>(), vec![3, 1, 2]);
            for (a, b) in one.iter().zip(beds.iter()) {
                assert_eq!((a.seed, a.steps, &a.state_hash), (b.seed, b.steps, &b.state_hash));
                assert_eq!(a.series, b.series, "bed {}", a.seed);
                assert!(a.mean_drag > 0.0, "bed {}: {}", a.seed, a.mean_drag);
            }
        }
        // the beds differ from each other
        assert_ne!(one[0].state_hash, one[1].state_hash);
    }

    #[test]
    fn growing_radii_keeps_the_list_and_the_bits_of_a_new_list_each_step() {
        // discs, dumbbells (clumps) and ellipses: the growth of prepare_bed,
        // once keeping the list (set_radii), once with a new list every step
        for id in ["c1", "d1", "e1"] {
            let mut dc = DragCase::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("cases/drag/{id}.toml"))).unwrap();
            dc.drag.count = 150;
            let (case, radii) = dc.bed_case(2).unwrap();
            const N: u64 = 400;
            let grow = |rebuild: bool| {
                let mut sim = Simulation::new(case.clone()).unwrap();
                let builds = sim.state().nl.builds;
                // fast, so that the growth, not the motion, uses up the skin
                for k in 1..=N {
                    let s = 0.7 + 0.3 * k as f64 / N as f64;
                    sim.set_radii(|id| radii[(id - 1) as usize] * s);
                    if rebuild {
                        sim.rebuild_list();
                    }
                    sim.step().unwrap();
                }
                (sim.state_hash(), sim.state().nl.builds - builds, sim.contacts())
            };
            let (kept, anew) = (grow(false), grow(true));
            assert_eq!(kept.0, anew.0, "{id}: state hash, list kept against a new list each step");
            assert!(kept.2 > 100, "{id}: {} contacts at the end (the bed is compacted)", kept.2);
            assert!(anew.1 >= N && kept.1 < N / 4, "{id}: {} builds kept, {} anew", kept.1, anew.1);
        }
    }

    #[test]
    fn spheres_at_rest_grown_into_contact_are_found_with_the_list_kept() {
        // two spheres at rest 3 skins apart and one 1.5 skins above the floor,
        // no gravity: only the growth (2 skins each over 200 steps) brings
        // them into contact, so the list kept must be rebuilt for the growth
        use crate::builder::CaseBuilder;
        let (r, skin) = (1e-3, 1e-4);
        let m = Material { name: "m".into(), youngs_modulus: 1e7, poisson_ratio: 0.3, density: 2500.0, restitution: 0.5, friction: 0.3, rolling_friction: 0.0 };
        let pair = vec![ParticleEntry::at(1, [0.0, 0.0, 0.0], r), ParticleEntry::at(2, [2.0 * r + 3.0 * skin, 0.0, 0.0], r)];
        let on_floor = ParticleEntry::at(3, [-0.004, 0.0, r + 1.5 * skin - 0.005], r);
        // the three together, and the one on the floor alone (no pair: only the walls' test)
        for list in [[pair, vec![on_floor.clone()]].concat(), vec![on_floor]] {
            let n = list.len();
            let case = CaseBuilder::new(Dimension::Three)
                .timestep(crate::case::TimeStep::Seconds(1e-6))
                .gravity([0.0; 3])
                .skin(skin)
                .domain([-0.01; 3], [0.01; 3])
                .contact(ContactSection::new(ModelName::Hertz))
                .material(m.clone())
                .particle_list("m", list)
                .wall(WallSection::plane("floor", "m", [0.0, 0.0, -0.005], [0.0, 0.0, 1.0]))
                .phase(PhaseSection::new("run", 1.0))
                .build(Path::new("grow.toml"))
                .unwrap();
            let grow = |rebuild: bool| {
                let mut sim = Simulation::new(case.clone()).unwrap();
                let builds = sim.state().nl.builds;
                for k in 1..=200 {
                    let s = 1.0 + 2.0 * skin / r * k as f64 / 200.0;
                    sim.set_radii(|_| r * s);
                    if rebuild {
                        sim.rebuild_list();
                    }
                    sim.step().unwrap();
                }
                let v: Vec<f64> = sim.particles().vel[..n].iter().map(|v| v.norm()).collect();
                (sim.state_hash(), sim.state().nl.builds - builds, v)
            };
            let (kept, anew) = (grow(false), grow(true));
            assert_eq!(kept.0, anew.0, "{n} spheres: state hash, list kept against a new list each step");
            // every sphere touched: pushed apart and off the floor
            assert!(kept.2.iter().all(|&v| v > 0.0), "{n} spheres: speeds {:?}", kept.2);
            assert!(kept.1 < 20 && anew.1 >= 200, "{n} spheres: {} builds kept, {} anew", kept.1, anew.1);
        }
    }

    #[test]
    fn an_error_between_beds_stops_the_study() {
        for threads in [1, 2] {
            let mut calls = 0;
            let r = run_beds(&short(threads), || {
                calls += 1;
                Err(TalusError::Run("interrupted".into()))
            });
            assert!(matches!(&r, Err(TalusError::Run(m)) if m == "interrupted"), "{threads} threads");
            // called once: after the first bed to finish (the others running then finish, no more start)
            assert_eq!(calls, 1, "{threads} threads");
        }
    }
}
