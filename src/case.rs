//! Case files (TOML): the typed, validated description of a run.
//!
//! Unknown keys are refused (`deny_unknown_fields`); every error names the file,
//! the key or line, and the value.

use crate::contact::hertz::HertzDamping;
use crate::contact::hooke::HookeExplicit;
use crate::contact::{Convention, EndOfContact, FrictionCap, ShearKinematics, TangentialHistory};
use crate::dim::Dimension;
use crate::error::TalusError;
use crate::integrate::IntegratorKind;
use crate::material::Material;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Case {
    pub simulation: SimulationSection,
    pub contact: ContactSection,
    #[serde(rename = "material")]
    pub materials: Vec<Material>,
    pub particles: ParticlesSection,
    #[serde(rename = "wall", default)]
    pub walls: Vec<WallSection>,
    #[serde(rename = "phase")]
    pub phases: Vec<PhaseSection>,
    #[serde(default)]
    pub output: OutputSection,
    #[serde(default)]
    pub analysis: Option<AnalysisSection>,
    #[serde(default)]
    pub parallel: ParallelSection,
    /// Tolerances of the comparisons (`python -m compare CASE.toml`, `compare regress`).
    #[serde(default, skip_serializing_if = "CompareSection::is_default")]
    pub compare: CompareSection,
    /// Folder of the case file; relative paths in the case are taken from here.
    #[serde(skip)]
    pub dir: PathBuf,
    /// Path of the case file, for messages.
    #[serde(skip)]
    pub path: PathBuf,
}

/// `[simulation]`. In the file the time step is `timestep` (s) or
/// `timestep_rayleigh_fraction`, exactly one of them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(try_from = "RawSimulation", into = "RawSimulation")]
pub struct SimulationSection {
    pub dimension: Dimension,
    pub timestep: TimeStep,
    /// Accept a step above 30% of the Rayleigh time.
    pub force_timestep: bool,
    pub gravity: [f64; 3],
    pub integrator: IntegratorKind,
    /// Verlet skin (m); default 0.2 of the smallest radius.
    pub skin: Option<f64>,
    /// Box particles must stay in.
    pub domain: DomainSection,
}

/// How a case gives its time step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStep {
    /// `timestep`: seconds.
    Seconds(f64),
    /// `timestep_rayleigh_fraction`: a fraction of the Rayleigh time of the smallest particle.
    RayleighFraction(f64),
}

/// `[simulation]` as written in the file.
#[derive(Clone, Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct RawSimulation {
    #[serde(default)]
    dimension: Dimension,
    timestep: Option<f64>,
    timestep_rayleigh_fraction: Option<f64>,
    #[serde(default)]
    force_timestep: bool,
    #[serde(default)]
    gravity: [f64; 3],
    #[serde(default)]
    integrator: IntegratorKind,
    skin: Option<f64>,
    domain: DomainSection,
}

impl TryFrom<RawSimulation> for SimulationSection {
    type Error = String;
    fn try_from(r: RawSimulation) -> Result<Self, String> {
        let timestep = match (r.timestep, r.timestep_rayleigh_fraction) {
            (Some(dt), None) => TimeStep::Seconds(dt),
            (None, Some(f)) => TimeStep::RayleighFraction(f),
            (a, b) => {
                let given = match (a, b) {
                    (Some(a), Some(b)) => format!("timestep = {a} and timestep_rayleigh_fraction = {b}"),
                    _ => "no time step".to_string(),
                };
                return Err(format!(
                    "simulation: {given}: give exactly one of simulation.timestep and simulation.timestep_rayleigh_fraction"
                ));
            }
        };
        let RawSimulation { dimension, force_timestep, gravity, integrator, skin, domain, .. } = r;
        Ok(SimulationSection { dimension, timestep, force_timestep, gravity, integrator, skin, domain })
    }
}

impl From<SimulationSection> for RawSimulation {
    fn from(s: SimulationSection) -> Self {
        let (timestep, timestep_rayleigh_fraction) = match s.timestep {
            TimeStep::Seconds(dt) => (Some(dt), None),
            TimeStep::RayleighFraction(f) => (None, Some(f)),
        };
        let SimulationSection { dimension, force_timestep, gravity, integrator, skin, domain, .. } = s;
        RawSimulation { dimension, timestep, timestep_rayleigh_fraction, force_timestep, gravity, integrator, skin, domain }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DomainSection {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// Axes along which the domain is periodic (`periodic = ["x", "y"]`): a
    /// particle leaving through hi comes back through lo, and particles near
    /// one face touch those near the other (LIGGGHTS `boundary p`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub periodic: Vec<Axis>,
}

impl DomainSection {
    /// Whether the domain is periodic along axis k (0 = x).
    pub fn is_periodic(&self, k: usize) -> bool {
        self.periodic.iter().any(|a| a.index() == k)
    }

    /// The period along each axis (m; 0 along an axis that is not periodic).
    pub fn period(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| if self.is_periodic(k) { self.hi[k] - self.lo[k] } else { 0.0 })
    }
}

/// A coordinate axis, as a case names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ModelName {
    Hooke,
    Hertz,
    /// Hertz with the Derjaguin-Muller-Toporov adhesion -4 pi gamma R* while
    /// the bodies overlap (LAMMPS `pair_style granular` `dmt`).
    Dmt,
    /// Johnson-Kendall-Roberts: the contact radius from the overlap, the
    /// force pulls until the pull-off separation beyond contact (LAMMPS `jkr`).
    Jkr,
}

impl ModelName {
    /// The model's name in a case file.
    pub fn name(self) -> &'static str {
        match self {
            ModelName::Hooke => "hooke",
            ModelName::Hertz => "hertz",
            ModelName::Dmt => "dmt",
            ModelName::Jkr => "jkr",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ContactSection {
    pub model: ModelName,
    /// The reference code whose conventions fill every option not given.
    #[serde(default)]
    pub convention: Convention,
    /// Hertz damping mapping from e.
    pub damping: Option<HertzDamping>,
    pub end_of_contact: Option<EndOfContact>,
    pub tangential: Option<TangentialHistory>,
    /// Which normal force caps friction: "total" (LIGGGHTS) or "elastic" (talus).
    pub friction_cap: Option<FrictionCap>,
    /// Which velocity drives the shear spring: "contact_point" (LIGGGHTS) or "full_radii" (YADE Mindlin).
    pub shear_kinematics: Option<ShearKinematics>,
    /// Where a wall contact acts: "mid_overlap" (LIGGGHTS) or "surface" (YADE).
    pub wall_contact_point: Option<WallContactPoint>,
    /// hooke: derive kn etc. as LIGGGHTS does at this velocity (m/s).
    pub characteristic_velocity: Option<f64>,
    /// hooke: explicit absolute coefficients.
    pub stiffness: Option<HookeExplicit>,
    /// Rolling resistance, a law of its own beside the normal and tangential
    /// ones: "cdt" (constant directional torque, LIGGGHTS `rolling_friction
    /// cdt`) or "epsd2" (elastic-plastic spring-dashpot, LIGGGHTS
    /// `rolling_friction epsd2`), with each material's `rolling_friction`.
    /// None: no rolling resistance.
    pub rolling: Option<RollingModel>,
    /// Cohesion, added to the law's normal force: `{ model = "sjkr" | "sjkr2",
    /// energy_density = K }` (LIGGGHTS's `cohesion sjkr` / `sjkr2`,
    /// `crate::contact::cohesion`). None: no cohesion.
    pub cohesion: Option<crate::contact::cohesion::Cohesion>,
    /// dmt and jkr: the surface energy gamma (J/m^2, LAMMPS's `cohesion`
    /// coefficient; the work of adhesion is 2 gamma): pull-off 4 pi gamma R*
    /// (DMT), 3 pi gamma R* (JKR).
    pub surface_energy: Option<f64>,
    /// `[[contact.pair]]`: the law of particular pairs of materials (walls'
    /// materials included), each key given replacing the section's for that
    /// pair. None: one law for every pair.
    #[serde(default, rename = "pair", skip_serializing_if = "Vec::is_empty")]
    pub pairs: Vec<ContactPair>,
}

/// `[[contact.pair]]`: one pair of materials with a law of its own (as
/// LAMMPS's `pair_coeff i j`, LIGGGHTS's `peratomtypepair` values, YADE's
/// per-material-pair functors). Each key given replaces the `[contact]`
/// section's for this pair; the conventions (`convention`, `tangential`,
/// `friction_cap`, ...) stay the section's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ContactPair {
    /// The two materials (their names; either order).
    pub materials: [String; 2],
    pub model: Option<ModelName>,
    pub damping: Option<HertzDamping>,
    pub characteristic_velocity: Option<f64>,
    pub stiffness: Option<HookeExplicit>,
    pub surface_energy: Option<f64>,
    pub cohesion: Option<crate::contact::cohesion::Cohesion>,
}

impl ContactSection {
    /// The section as pair `p` sees it: its keys replacing the section's, no pair table.
    pub fn for_pair(&self, p: &ContactPair) -> ContactSection {
        ContactSection {
            model: p.model.unwrap_or(self.model),
            convention: self.convention,
            damping: p.damping.or(self.damping),
            end_of_contact: self.end_of_contact,
            tangential: self.tangential,
            friction_cap: self.friction_cap,
            shear_kinematics: self.shear_kinematics,
            wall_contact_point: self.wall_contact_point,
            characteristic_velocity: if p.model.is_some() || p.stiffness.is_some() { p.characteristic_velocity } else { p.characteristic_velocity.or(self.characteristic_velocity) },
            stiffness: if p.model.is_some() || p.characteristic_velocity.is_some() { p.stiffness } else { p.stiffness.or(self.stiffness) },
            rolling: self.rolling,
            cohesion: p.cohesion.or(self.cohesion),
            surface_energy: if p.model.is_some() { p.surface_energy } else { p.surface_energy.or(self.surface_energy) },
            pairs: Vec::new(),
        }
    }

    /// The law of the pair of materials named `a` and `b` (either order): its
    /// `[[contact.pair]]`'s, else the section's.
    pub fn for_materials(&self, a: &str, b: &str) -> ContactSection {
        match self.pairs.iter().find(|p| (p.materials[0] == a && p.materials[1] == b) || (p.materials[0] == b && p.materials[1] == a)) {
            Some(p) => self.for_pair(p),
            None => ContactSection { pairs: Vec::new(), ..self.clone() },
        }
    }

    /// Every law of the case: the section's, then each pair's.
    pub fn laws(&self) -> impl Iterator<Item = ContactSection> + '_ {
        std::iter::once(ContactSection { pairs: Vec::new(), ..self.clone() }).chain(self.pairs.iter().map(|p| self.for_pair(p)))
    }
}

/// The rolling resistance law.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RollingModel {
    /// Constant directional torque: mu_r F_n R against the relative rolling
    /// spin (LIGGGHTS `rolling_model_cdt.h`): R = R* between particles, the
    /// particle's radius on a wall; the twisting part removed.
    Cdt,
    /// Elastic-plastic spring (LIGGGHTS `rolling_model_epsd2.h`, after Iwashita
    /// and Oda): a rolling torque kept per contact, incremented by
    /// k_r w_t dt with k_r = k_t R^2 (k_t the tangential stiffness at this
    /// overlap, w_t the relative spin's rolling part) and capped at
    /// mu_r |F_n| R; no dashpot. Zero again when the contact ends.
    Epsd2,
}

/// Where the force of a wall contact acts on the particle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum WallContactPoint {
    /// At the middle of the overlap: arm r - delta/2 (LIGGGHTS).
    MidOverlap,
    /// On the wall surface: arm r - delta (YADE `Ig2_Wall_Sphere_ScGeom`).
    Surface,
    /// At the particle's undeformed surface: arm r (LAMMPS `fix wall/gran`).
    Radius,
}

impl WallContactPoint {
    /// The option's value in a case file.
    pub fn name(self) -> &'static str {
        match self {
            WallContactPoint::MidOverlap => "mid_overlap",
            WallContactPoint::Surface => "surface",
            WallContactPoint::Radius => "radius",
        }
    }
}

/// `[particles]`. In the file the particles come from exactly one of `csv`,
/// `lattice` and `list`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(try_from = "RawParticles", into = "RawParticles")]
pub struct ParticlesSection {
    pub material: String,
    /// Largest initial overlap accepted, as a fraction of the smaller radius.
    pub overlap_tolerance: f64,
    pub source: ParticleSource,
    /// Rigid pairs (2D dumbbells): each entry names the ids of two particles
    /// that move as one body, joined where they touch.
    pub clumps: Vec<[u64; 2]>,
    /// Ellipses (2D): each entry turns the particle `id` into an ellipse of
    /// aspect ratio a/b with the area of its listed disc (its radius is the
    /// equivalent radius sqrt(a b)), major axis at `angle` (rad) from x.
    pub ellipses: Vec<EllipseEntry>,
}

/// Where the particles come from.
#[derive(Clone, Debug, PartialEq)]
pub enum ParticleSource {
    /// `csv`: a file `id,x,y,z,radius` with optional `vx,vy,vz` (and `wx,wy,wz`).
    Csv(PathBuf),
    /// `lattice`: a seeded jittered-lattice cloud.
    Lattice(LatticeSection),
    /// `list`: particles given one by one.
    List(Vec<ParticleEntry>),
}

/// `[particles]` as written in the file.
#[derive(Clone, Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct RawParticles {
    material: String,
    #[serde(default = "default_overlap_tol")]
    overlap_tolerance: f64,
    csv: Option<PathBuf>,
    lattice: Option<LatticeSection>,
    list: Option<Vec<ParticleEntry>>,
    #[serde(default)]
    clumps: Vec<[u64; 2]>,
    #[serde(default)]
    ellipses: Vec<EllipseEntry>,
}

impl TryFrom<RawParticles> for ParticlesSection {
    type Error = String;
    fn try_from(r: RawParticles) -> Result<Self, String> {
        let source = match (r.csv, r.lattice, r.list) {
            (Some(f), None, None) => ParticleSource::Csv(f),
            (None, Some(l), None) => ParticleSource::Lattice(l),
            (None, None, Some(l)) => ParticleSource::List(l),
            (a, b, c) => {
                let n = a.is_some() as u8 + b.is_some() as u8 + c.is_some() as u8;
                return Err(format!("particles: {n} particle sources: give exactly one of particles.csv, particles.lattice, particles.list"));
            }
        };
        let RawParticles { material, overlap_tolerance, clumps, ellipses, .. } = r;
        Ok(ParticlesSection { material, overlap_tolerance, source, clumps, ellipses })
    }
}

impl From<ParticlesSection> for RawParticles {
    fn from(p: ParticlesSection) -> Self {
        let (mut csv, mut lattice, mut list) = (None, None, None);
        match p.source {
            ParticleSource::Csv(f) => csv = Some(f),
            ParticleSource::Lattice(l) => lattice = Some(l),
            ParticleSource::List(l) => list = Some(l),
        }
        let ParticlesSection { material, overlap_tolerance, clumps, ellipses, .. } = p;
        RawParticles { material, overlap_tolerance, csv, lattice, list, clumps, ellipses }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EllipseEntry {
    pub id: u64,
    pub aspect_ratio: f64,
    #[serde(default)]
    pub angle: f64,
}

/// `particles.overlap_tolerance` when the case does not give it.
pub(crate) fn default_overlap_tol() -> f64 {
    1e-3
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LatticeSection {
    pub count: usize,
    pub radius_min: f64,
    pub radius_max: f64,
    /// Lower corner (x, y, z) of the cloud.
    pub lo: [f64; 3],
    /// Upper x and y of the cloud (it grows upward in z).
    pub hi_xy: [f64; 2],
    /// Lattice spacing in units of radius_max.
    #[serde(default = "default_spacing")]
    pub spacing: f64,
    pub seed: u64,
}

fn default_spacing() -> f64 {
    2.2
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ParticleEntry {
    pub id: u64,
    pub position: [f64; 3],
    #[serde(default)]
    pub velocity: [f64; 3],
    #[serde(default)]
    pub spin: [f64; 3],
    pub radius: f64,
}

/// `[[wall]]`. In the file its shape is exactly one of `plane`, `stl`,
/// `disc`, `segment` and `box`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(try_from = "RawWall", into = "RawWall")]
pub struct WallSection {
    pub name: String,
    pub material: String,
    pub shape: WallShape,
    /// Translation at a constant velocity (m/s).
    pub velocity: [f64; 3],
    /// Turning about an axis (the axis moves with the wall's translation and oscillation).
    pub rotation: Option<RotationSection>,
    /// A sinusoidal displacement on top of the translation.
    pub oscillation: Option<OscillationSection>,
    /// Moved along a direction so that the particles' load on it follows a target.
    pub servo: Option<ServoSection>,
    /// Remove the wall at this simulated time (s).
    pub remove_at: Option<f64>,
}

/// `servo = { force | pressure + area, gain, max_speed, direction }`: the wall
/// moves along `direction` (default: a plane's normal, towards the particles)
/// at speed gain x (target - R), limited to +-max_speed, R the particles' push
/// against that direction (N) at the last step and the target `force`, or
/// `pressure` x `area`; a proportional controller (the wall's position
/// integrates the error, so it comes to rest where R = target). The probes
/// gain `<name>_travel_m`, how far it has moved along the direction.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ServoSection {
    pub force: Option<f64>,
    pub pressure: Option<f64>,
    pub area: Option<f64>,
    /// m/s per N of error.
    pub gain: f64,
    /// m/s.
    pub max_speed: f64,
    pub direction: Option<[f64; 3]>,
}

impl ServoSection {
    /// The load to hold (N).
    pub fn target(&self) -> f64 {
        self.force.unwrap_or_else(|| self.pressure.unwrap_or(0.0) * self.area.unwrap_or(0.0))
    }
}
/// `rotation = { axis, point, angular_velocity }`: the wall turns at
/// `angular_velocity` (rad/s, right-handed about `axis`) about the axis through
/// `point`; the point moves with the wall's translation and oscillation (the
/// wall is a rigid body). The contact velocity includes the rotation, and the
/// wall's probes gain `<name>_axis_torque_n_m`, the particles' torque on it about
/// this axis (a drum's drive torque is its negative).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RotationSection {
    pub axis: [f64; 3],
    pub point: [f64; 3],
    pub angular_velocity: f64,
}

/// `oscillation = { amplitude, frequency }`: the wall is displaced by
/// `amplitude sin(2 pi frequency (t - t0))` (m, Hz), t0 the time the motion
/// starts (0, or the start of the phase that sets it); LIGGGHTS's `wiggle`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OscillationSection {
    pub amplitude: [f64; 3],
    pub frequency: f64,
}

/// `[[phase.move]]`: from the start of the phase, wall `wall` moves as given
/// here instead of as before (a part left out is absent: `{ wall = "lid" }`
/// stops the lid).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct MoveSection {
    pub wall: String,
    #[serde(default)]
    pub velocity: [f64; 3],
    pub rotation: Option<RotationSection>,
    pub oscillation: Option<OscillationSection>,
}

/// A wall's shape as the case gives it.
#[derive(Clone, Debug, PartialEq)]
pub enum WallShape {
    /// A one-sided plane.
    Plane(PlaneSection),
    /// A triangle mesh from an STL file (two-sided).
    Stl(PathBuf),
    /// A rigid ball (2D: a disc, the cross-section of a cylinder), touched from outside.
    Disc(DiscSection),
    /// 2D: a straight segment `{ from, to }`, touched from either side.
    Segment(SegmentSection),
    /// 2D: a closed box of four segments `{ lo, hi }` (x-y corners), one wall.
    Box(BoxSection),
}

impl WallShape {
    /// The key that gives this shape in a case file.
    pub fn key(&self) -> &'static str {
        match self {
            WallShape::Plane(_) => "plane",
            WallShape::Stl(_) => "stl",
            WallShape::Disc(_) => "disc",
            WallShape::Segment(_) => "segment",
            WallShape::Box(_) => "box",
        }
    }
}

/// `[[wall]]` as written in the file.
#[derive(Clone, Debug, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct RawWall {
    name: String,
    material: String,
    plane: Option<PlaneSection>,
    stl: Option<PathBuf>,
    disc: Option<DiscSection>,
    segment: Option<SegmentSection>,
    #[serde(rename = "box")]
    boxed: Option<BoxSection>,
    #[serde(default)]
    velocity: [f64; 3],
    rotation: Option<RotationSection>,
    oscillation: Option<OscillationSection>,
    servo: Option<ServoSection>,
    remove_at: Option<f64>,
}

impl TryFrom<RawWall> for WallSection {
    type Error = String;
    fn try_from(r: RawWall) -> Result<Self, String> {
        let mut shapes: Vec<WallShape> = Vec::new();
        shapes.extend(r.plane.map(WallShape::Plane));
        shapes.extend(r.stl.map(WallShape::Stl));
        shapes.extend(r.disc.map(WallShape::Disc));
        shapes.extend(r.segment.map(WallShape::Segment));
        shapes.extend(r.boxed.map(WallShape::Box));
        if shapes.len() != 1 {
            let given: Vec<&str> = shapes.iter().map(WallShape::key).collect();
            return Err(format!(
                "wall.{}: shapes given: [{}]: give exactly one of plane, stl, disc, segment and box",
                r.name,
                given.join(", ")
            ));
        }
        let shape = shapes.pop().expect("one shape, checked above");
        Ok(WallSection {
            name: r.name,
            material: r.material,
            shape,
            velocity: r.velocity,
            rotation: r.rotation,
            oscillation: r.oscillation,
            servo: r.servo,
            remove_at: r.remove_at,
        })
    }
}

impl From<WallSection> for RawWall {
    fn from(w: WallSection) -> Self {
        let mut r = RawWall {
            name: w.name,
            material: w.material,
            plane: None,
            stl: None,
            disc: None,
            segment: None,
            boxed: None,
            velocity: w.velocity,
            rotation: w.rotation,
            oscillation: w.oscillation,
            servo: w.servo,
            remove_at: w.remove_at,
        };
        match w.shape {
            WallShape::Plane(p) => r.plane = Some(p),
            WallShape::Stl(f) => r.stl = Some(f),
            WallShape::Disc(d) => r.disc = Some(d),
            WallShape::Segment(s) => r.segment = Some(s),
            WallShape::Box(b) => r.boxed = Some(b),
        }
        r
    }
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SegmentSection {
    pub from: [f64; 3],
    pub to: [f64; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BoxSection {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DiscSection {
    pub center: [f64; 3],
    pub radius: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlaneSection {
    pub point: [f64; 3],
    pub normal: [f64; 3],
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PhaseSection {
    pub name: String,
    /// Longest the phase runs (s).
    pub duration: f64,
    /// End early once the kinetic energy is below this fraction of the potential
    /// energy given up since the start of the run, plus `settle_extra` seconds.
    pub kinetic_energy_fraction: Option<f64>,
    #[serde(default)]
    pub settle_extra: f64,
    /// Walls removed when the phase ends.
    #[serde(default)]
    pub remove_walls_at_end: Vec<String>,
    /// Walls whose motion changes when the phase starts (`[[phase.move]]`).
    #[serde(default, rename = "move", skip_serializing_if = "Vec::is_empty")]
    pub moves: Vec<MoveSection>,
    /// Particles poured in during the phase (`[[phase.insert]]`).
    #[serde(default, rename = "insert", skip_serializing_if = "Vec::is_empty")]
    pub inserts: Vec<InsertSection>,
}

/// `[[phase.insert]]`: particles poured into a region during the phase, as
/// LIGGGHTS's `fix insert/rate/region` does: every `interval` seconds from the
/// phase's start a batch brings the number (or mass) inserted up to
/// `rate` (or `mass_rate`) times the time since the start, until `count` (or
/// `mass`) are in. Each particle is placed at a seeded random point of the
/// region, wholly inside it and overlapping neither a particle already there
/// nor one of its batch; a batch that cannot be placed stops the run with an
/// error. Radii uniform in `radius = { min, max }` or drawn from
/// `radius = { values = [...], weights = [...] }` (weights by number).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct InsertSection {
    pub material: String,
    pub region: RegionSection,
    /// How many particles in all (or `mass`, kg).
    pub count: Option<u64>,
    pub mass: Option<f64>,
    /// Particles per second (or `mass_rate`, kg/s).
    pub rate: Option<f64>,
    pub mass_rate: Option<f64>,
    pub radius: RadiusSection,
    /// Initial velocity (m/s).
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Seconds between batches (default 0.01 s).
    pub interval: Option<f64>,
    pub seed: u64,
}

/// Where particles are inserted.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum RegionSection {
    /// An axis-aligned box.
    Box { lo: [f64; 3], hi: [f64; 3] },
    /// A cylinder along z: centre (x, y) of its axis, radius, from z = lo to hi.
    Cylinder { center: [f64; 2], radius: f64, lo: f64, hi: f64 },
}

/// Radii of inserted particles.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields, untagged)]
pub enum RadiusSection {
    Uniform { min: f64, max: f64 },
    Discrete { values: Vec<f64>, weights: Vec<f64> },
}

/// `[parallel]`: how the domain is cut among MPI ranks and kept balanced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ParallelSection {
    /// Boxes along x, y, z (their product must be the number of ranks);
    /// default: the grid with the least cut area for the domain's shape.
    pub grid: Option<[usize; 3]>,
    /// `off`, `count`, `time` (the paper's measured load) or `contacts`.
    #[serde(default)]
    pub balance: crate::parallel::BalanceMode,
    /// Rebalance when a subdomain's estimated load departs from the mean by more than this (%).
    #[serde(default = "default_imbalance_percent")]
    pub imbalance_percent: f64,
    /// Steps between load checks.
    #[serde(default = "default_balance_interval")]
    pub balance_interval: u64,
    /// How owned particles are kept in storage: `cells` (by cell of the
    /// neighbour grid, x fastest), `hilbert` (along a Hilbert curve), `id`, or
    /// `shuffled` (a random order, to check). Speed only: results are the same
    /// bit for bit.
    #[serde(default)]
    pub order: crate::order::StorageOrder,
    /// Steps between remakes of the storage order, at the next list rebuild
    /// (0: at every rebuild).
    #[serde(default = "default_reorder_interval")]
    pub reorder_interval: u64,
    /// Threads per rank for the force sweep (`talus run --threads N`); default:
    /// the cores available to the process, shared among the ranks. Results
    /// are the same bit for bit for any count.
    #[serde(default)]
    pub threads: Option<usize>,
}

/// 200 steps: H1-paper's discharge (2,000 steps from the end of the fill, one
/// thread) ran at 2.52 million particle-steps/s reordering every 1,000 steps
/// and 2.67 every 100 or 300 (a flowing pile leaves its storage order within a
/// few hundred steps; a reorder costs less than one step's forces).
fn default_reorder_interval() -> u64 {
    200
}

fn default_imbalance_percent() -> f64 {
    5.0
}
fn default_balance_interval() -> u64 {
    200
}

impl Default for ParallelSection {
    fn default() -> Self {
        ParallelSection {
            grid: None,
            balance: Default::default(),
            imbalance_percent: default_imbalance_percent(),
            balance_interval: default_balance_interval(),
            order: Default::default(),
            reorder_interval: default_reorder_interval(),
            threads: None,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OutputSection {
    /// Probe interval (s).
    #[serde(default = "default_interval")]
    pub interval: f64,
    /// Report the mass of particles whose centre is below this z (m).
    pub mass_below_z: Option<f64>,
    /// Particle ids whose velocity and spin are recorded.
    #[serde(default)]
    pub track: Vec<u64>,
    /// HDF5 snapshot interval (s); none if absent.
    pub snapshot_interval: Option<f64>,
    /// Checkpoint interval (s); a checkpoint is always written at the end.
    pub checkpoint_interval: Option<f64>,
    /// Write `final.csv` (id, x, y, z, vx, vy, vz, radius of every particle, in
    /// id order) at the end of the run; the exported decks and scripts write
    /// the same file, so figures of the final state (a pile's angle of repose)
    /// are measured alike in every engine.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub final_state: bool,
    /// Report the particles' total momentum (`momentum_x_kg_m_s`, ...; an
    /// exact sum): a chute's flow rate per unit width is its x component over
    /// the domain's length.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub momentum: bool,
    /// Snapshots carry every contact (pair or wall, force, contact point,
    /// branch vector), which `talus fields` needs for the contact stress.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub contacts: bool,
    /// Continuum fields computed while the run goes (`[output.fields]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fields: Option<FieldsSection>,
}

/// `[output.fields]`: coarse-grained density, velocity and stress, averaged
/// over the output times from `from` to `to`, written to the output folder
/// as `profile_<axis>.csv` or `fields.h5` + `fields.xdmf` (what `talus fields`
/// writes from snapshots).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FieldsSection {
    /// "gauss" (width: standard deviation, cut off at 3 widths) or "lucy" (width: radius).
    #[serde(default = "default_kernel")]
    pub kernel: String,
    /// The kernel's width (m).
    pub width: f64,
    /// A profile along "x", "y" or "z" (the fields averaged over the other two axes)...
    pub profile: Option<String>,
    /// ...or a grid of nx, ny, nz cells over the domain.
    pub grid: Option<[usize; 3]>,
    /// Points of a profile (default 100).
    pub points: Option<usize>,
    /// How often the fields are sampled (s).
    pub interval: f64,
    /// Sample from this time on (s; default the start).
    pub from: Option<f64>,
    /// Sample up to this time (s; default the end).
    pub to: Option<f64>,
}

fn default_kernel() -> String {
    "gauss".into()
}

impl Default for OutputSection {
    fn default() -> Self {
        OutputSection {
            interval: default_interval(),
            mass_below_z: None,
            track: vec![],
            snapshot_interval: None,
            final_state: false,
            momentum: false,
            checkpoint_interval: None,
            contacts: false,
            fields: None,
        }
    }
}

fn default_interval() -> f64 {
    0.01
}

/// `[compare]`: tolerances of `python -m compare CASE.toml` (talus against the
/// reference codes) and of `python -m compare regress` (talus against its
/// golden file). The engine does not read them. Every tolerance is relative:
/// a figure's to its reference value, a probe column's to the column's range
/// over the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CompareSection {
    /// Every summary figure (default 0.02).
    #[serde(default = "default_figure_rel")]
    pub figure_rel: f64,
    /// Per figure, in place of `figure_rel` (`{ discharge_rate_kg_s = 0.1 }`).
    #[serde(default)]
    pub figures: std::collections::BTreeMap<String, f64>,
    /// Largest deviation of a probe column over the run, as a fraction of the
    /// column's range (default 0.05).
    #[serde(default = "default_series_range")]
    pub series_range: f64,
    /// Per probe column, in place of `series_range`.
    #[serde(default)]
    pub series: std::collections::BTreeMap<String, f64>,
    /// Windows `[t0, t1]` (s) over which each probe column's mean is compared.
    #[serde(default)]
    pub windows: Vec<[f64; 2]>,
    /// Difference of a column's means over a window, as a fraction of its range (default 0.02).
    #[serde(default = "default_window_mean")]
    pub window_mean: f64,
    /// Per probe column, in place of `window_mean`.
    #[serde(default)]
    pub window_means: std::collections::BTreeMap<String, f64>,
    /// Figures and probe columns left out of the comparison.
    #[serde(default)]
    pub ignore: Vec<String>,
    /// Steps of a `compare regress` run (default: the whole case).
    pub regress_steps: Option<u64>,
    /// Replicas per engine in `python3 -m compare CASE.toml` (default 4): runs
    /// that differ at round-off, compared as ensembles (compare/ensemble.py);
    /// 1 compares single runs step by step (the deterministic SC set-ups).
    pub replicas: Option<u32>,
}

fn default_figure_rel() -> f64 {
    0.02
}
fn default_series_range() -> f64 {
    0.05
}
fn default_window_mean() -> f64 {
    0.02
}

impl Default for CompareSection {
    fn default() -> Self {
        CompareSection {
            figure_rel: default_figure_rel(),
            figures: Default::default(),
            series_range: default_series_range(),
            series: Default::default(),
            windows: Vec::new(),
            window_mean: default_window_mean(),
            window_means: Default::default(),
            ignore: Vec::new(),
            regress_steps: None,
            replicas: None,
        }
    }
}

impl CompareSection {
    pub fn is_default(&self) -> bool {
        *self == CompareSection::default()
    }
}

/// What figures the run computes for `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "lowercase")]
pub enum AnalysisSection {
    /// A single collision of `particle` with the wall `wall` or the particle `partner`.
    Collision {
        particle: u64,
        wall: Option<String>,
        partner: Option<u64>,
    },
    /// Hopper fill and discharge.
    Hopper {
        hopper_walls: Vec<String>,
        gate: String,
        fill_phase: String,
        discharge_phase: String,
        /// Averaging window at the end of the fill (s).
        #[serde(default = "default_window")]
        fill_window: f64,
    },
    /// The drag on a moving wall (the drag paper's cylinder): the granules'
    /// force against the wall's motion, averaged over the wall's displacement
    /// from `window[0]` to `window[1]` (m), measured from the probes by `python
    /// -m compare` (compare/case.py `drag_figures`).
    Drag {
        wall: String,
        window: [f64; 2],
    },
    /// A pile on a floor: its angle of repose and height, measured from the
    /// final state (`output.final_state`, `final.csv`) by `python -m compare`
    /// alike for every engine (compare/case.py `pile_figures`).
    Pile {
        /// How the free surface is profiled: "radial" (a conical pile: height
        /// against the distance from `center`) or "x" (a pile against a wall:
        /// height against x - center.x).
        #[serde(default = "default_profile")]
        profile: String,
        /// The pile's axis, (x, y) (m).
        center: [f64; 2],
        /// Height of the floor (m).
        #[serde(default)]
        floor_z: f64,
    },
    /// A rotating drum: its dynamic angle of repose (the angle of the bed's
    /// long axis in the plane normal to the drum's axis, from `final.csv`) and
    /// the mean drive torque about its axis over `window` (s), measured by
    /// `python -m compare` alike for every engine (compare/case.py `drum_figures`).
    Drum {
        /// The turning wall.
        wall: String,
        window: [f64; 2],
    },
}

fn default_profile() -> String {
    "radial".into()
}

fn default_window() -> f64 {
    0.1
}

/// A TOML error with the file and line.
fn syntax_error(text: &str, path: &Path, e: toml::de::Error) -> TalusError {
    let line = e.span().map(|s| text[..s.start].matches('\n').count() + 1);
    let at = line.map(|l| format!(", line {l}")).unwrap_or_default();
    TalusError::Input(format!("{}{at}: {}", path.display(), e.message()))
}

impl Case {
    /// Read and parse a case file. Syntax errors and unknown keys name the file and line.
    pub fn load(path: &Path) -> Result<Case, TalusError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| TalusError::Input(format!("cannot read case file {}: {e}", path.display())))?;
        Case::parse(&text, path)
    }

    /// Read a case file and change values in it (`--set KEY=VALUE`, see
    /// [`crate::overrides`]) before it is validated.
    pub fn load_with(path: &Path, sets: &[String]) -> Result<Case, TalusError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| TalusError::io(format!("cannot read case file {}", path.display()), e))?;
        Case::parse_with(&text, path, sets)
    }

    /// Parse case text with `--set` changes applied.
    pub fn parse_with(text: &str, path: &Path, sets: &[String]) -> Result<Case, TalusError> {
        if sets.is_empty() {
            return Case::parse(text, path);
        }
        let mut table: toml::Table = toml::from_str(text).map_err(|e| syntax_error(text, path, e))?;
        for s in sets {
            let (key, value) = crate::overrides::parse(s)?;
            crate::overrides::apply(&mut table, &key, value, s)?;
        }
        let case: Case = toml::Value::Table(table).try_into().map_err(|e: toml::de::Error| {
            TalusError::Input(format!("{} with --set {}: {}", path.display(), sets.join(" --set "), e.message()))
        })?;
        case.validated(path)
    }

    /// The case as TOML text in the file's layout; `Case::parse` reads it back
    /// to the same values (every number is written to round trip).
    pub fn to_toml(&self) -> Result<String, TalusError> {
        toml::to_string(self).map_err(|e| TalusError::Input(format!("{}: cannot write the case as TOML: {e}", self.path.display())))
    }

    /// Parse case text; `path` names it in errors and anchors relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Case, TalusError> {
        let case: Case = toml::from_str(text).map_err(|e| syntax_error(text, path, e))?;
        case.validated(path)
    }

    /// The case with its file's path (for messages and relative paths), validated:
    /// the checks every case file passes. A case built in code
    /// ([`crate::builder::CaseBuilder`]) ends here too.
    pub fn validated(self, path: &Path) -> Result<Case, TalusError> {
        let mut case = self;
        case.path = path.to_path_buf();
        case.dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        case.validate()?;
        Ok(case)
    }

    fn err(&self, key: &str, value: impl std::fmt::Display, why: &str) -> TalusError {
        let value = value.to_string();
        if value.is_empty() {
            TalusError::Input(format!("{}: {key}: {why}", self.path.display()))
        } else {
            TalusError::Input(format!("{}: {key} = {value}: {why}", self.path.display()))
        }
    }

    /// Resolve a path given in the case relative to the case file.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() { p.to_path_buf() } else { self.dir.join(p) }
    }

    pub fn material_index(&self, name: &str, key: &str) -> Result<u16, TalusError> {
        self.materials
            .iter()
            .position(|m| m.name == name)
            .map(|i| i as u16)
            .ok_or_else(|| self.err(key, format!("\"{name}\""), "no material of that name"))
    }

    fn validate(&self) -> Result<(), TalusError> {
        self.validate_materials()?;
        self.validate_simulation()?;
        self.validate_parallel()?;
        self.validate_contact()?;
        if self.contact.rolling.is_none() {
            if let Some(m) = self.materials.iter().find(|m| m.rolling_friction > 0.0) {
                return Err(self.err(
                    &format!("materials.{}.rolling_friction", m.name),
                    m.rolling_friction,
                    "a rolling friction coefficient needs a rolling resistance law: set contact.rolling = \"cdt\" or \"epsd2\"",
                ));
            }
        }
        self.validate_particles()?;
        let mut names = std::collections::HashSet::new();
        for (i, w) in self.walls.iter().enumerate() {
            self.check_name(&format!("wall[{i}].name"), &w.name)?;
            if !names.insert(w.name.clone()) {
                return Err(self.err(&format!("wall[{i}].name"), format!("\"{}\"", w.name), "wall names must be unique"));
            }
            self.validate_wall(w)?;
        }
        self.validate_phases()?;
        self.validate_output()?;
        self.validate_compare()
    }

    fn validate_compare(&self) -> Result<(), TalusError> {
        let c = &self.compare;
        let tol = |key: &str, v: f64| {
            if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(self.err(key, v, "a tolerance must be a finite number, 0 or more")) }
        };
        tol("compare.figure_rel", c.figure_rel)?;
        tol("compare.series_range", c.series_range)?;
        tol("compare.window_mean", c.window_mean)?;
        for (k, v) in &c.figures {
            tol(&format!("compare.figures.{k}"), *v)?;
        }
        for (k, v) in &c.series {
            tol(&format!("compare.series.{k}"), *v)?;
        }
        for (i, w) in c.windows.iter().enumerate() {
            if !(w[0].is_finite() && w[1].is_finite() && w[0] >= 0.0 && w[0] < w[1]) {
                return Err(self.err(&format!("compare.windows[{i}]"), format!("[{}, {}]", w[0], w[1]), "a window is [t0, t1] (s) with 0 <= t0 < t1"));
            }
        }
        if c.replicas == Some(0) {
            return Err(self.err("compare.replicas", 0, "must be 1 or more (1: single runs compared step by step)"));
        }
        if c.regress_steps == Some(0) {
            return Err(self.err("compare.regress_steps", 0, "must be 1 or more (leave it out for the whole case)"));
        }
        Ok(())
    }

    /// A name that becomes part of a file name or a CSV column (walls, phases).
    fn check_name(&self, key: &str, name: &str) -> Result<(), TalusError> {
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            return Err(self.err(
                key,
                format!("\"{name}\""),
                "a name must be non-empty and hold only letters A-Z a-z, digits 0-9, `_` and `-` (it names files and CSV columns)",
            ));
        }
        Ok(())
    }

    fn validate_materials(&self) -> Result<(), TalusError> {
        let ctx = self.path.display().to_string();
        if self.materials.is_empty() {
            return Err(self.err("material", "[]", "at least one [[material]] is needed"));
        }
        let mut names = std::collections::HashSet::new();
        for (i, m) in self.materials.iter().enumerate() {
            if !names.insert(m.name.as_str()) {
                return Err(self.err(&format!("material[{i}].name"), format!("\"{}\"", m.name), "material names must be unique"));
            }
            m.validate(&ctx)?;
        }
        Ok(())
    }

    fn validate_simulation(&self) -> Result<(), TalusError> {
        let s = &self.simulation;
        match s.timestep {
            TimeStep::Seconds(dt) if !(dt.is_finite() && dt > 0.0) => {
                return Err(self.err("simulation.timestep", dt, "the time step must be a positive number of seconds"));
            }
            TimeStep::RayleighFraction(f) if !(f.is_finite() && f > 0.0) => {
                return Err(self.err("simulation.timestep_rayleigh_fraction", f, "must be positive"));
            }
            _ => {}
        }
        if let Some(sk) = s.skin {
            if !(sk.is_finite() && sk > 0.0) {
                return Err(self.err("simulation.skin", sk, "the skin must be a positive length"));
            }
        }
        if s.gravity.iter().any(|g| !g.is_finite()) {
            return Err(self.err("simulation.gravity", format!("{:?}", s.gravity), "every component must be a finite number (m/s^2)"));
        }
        if s.dimension == Dimension::Two && s.gravity[2] != 0.0 {
            return Err(self.err(
                "simulation.gravity",
                format!("{:?}", s.gravity),
                "in 2D (simulation.dimension = \"2\") gravity lies in the x-y plane (z component 0)",
            ));
        }
        let (lo, hi) = (s.domain.lo, s.domain.hi);
        if lo.iter().chain(&hi).any(|x| !x.is_finite()) {
            return Err(self.err("simulation.domain", format!("lo {lo:?} hi {hi:?}"), "every corner coordinate must be a finite number (m)"));
        }
        for k in 0..3 {
            if !(lo[k] < hi[k]) {
                return Err(self.err("simulation.domain", format!("lo {lo:?} hi {hi:?}"), "every lo must be below its hi"));
            }
        }
        self.validate_periodic()
    }

    /// Periodic axes: each named once, none out of a 2D run's plane; no shape
    /// the periodic images cannot carry (clumps, ellipses); every plane wall
    /// parallel to each periodic axis (a plane across one would cut the period).
    fn validate_periodic(&self) -> Result<(), TalusError> {
        let s = &self.simulation;
        let per = &s.domain.periodic;
        if per.is_empty() {
            return Ok(());
        }
        let at = "simulation.domain.periodic";
        for (k, a) in per.iter().enumerate() {
            if per[..k].contains(a) {
                return Err(self.err(at, format!("{per:?}"), "names an axis twice"));
            }
        }
        if s.dimension == Dimension::Two && per.contains(&Axis::Z) {
            return Err(self.err(at, format!("{per:?}"), "a 2D run lies in the x-y plane: only x and y can be periodic"));
        }
        let pp = &self.particles;
        if !pp.clumps.is_empty() || !pp.ellipses.is_empty() {
            return Err(self.err(
                at,
                format!("{per:?}"),
                "clumps and ellipses are not supported in a periodic domain (spheres and discs only): leave out particles.clumps and particles.ellipses",
            ));
        }
        for w in &self.walls {
            if let WallShape::Plane(PlaneSection { normal, .. }) = &w.shape {
                let len = normal.iter().map(|c| c * c).sum::<f64>().sqrt();
                for a in per {
                    if (normal[a.index()] / len).abs() > 1e-12 {
                        return Err(self.err(
                            &format!("wall.{}.normal", w.name),
                            format!("{normal:?}"),
                            &format!("a plane wall in a domain periodic along {a:?} must be parallel to that axis (normal component 0 along it)"),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    fn validate_parallel(&self) -> Result<(), TalusError> {
        let par = &self.parallel;
        if !(par.imbalance_percent.is_finite() && par.imbalance_percent > 0.0) {
            return Err(self.err("parallel.imbalance_percent", par.imbalance_percent, "must be a positive percentage"));
        }
        if par.balance_interval == 0 {
            return Err(self.err("parallel.balance_interval", 0, "must be at least 1 step"));
        }
        if let Some(t) = par.threads {
            if !(1..=4096).contains(&t) {
                return Err(self.err("parallel.threads", t, "must be from 1 to 4096 threads per rank"));
            }
        }
        if let Some(g) = par.grid {
            if g.iter().any(|&n| n == 0) {
                return Err(self.err("parallel.grid", format!("{g:?}"), "every count must be at least 1"));
            }
            if g.iter().try_fold(1usize, |a, &n| a.checked_mul(n)).is_none() {
                return Err(self.err(
                    "parallel.grid",
                    format!("{g:?}"),
                    "the product of the counts overflows; it must equal the number of MPI ranks",
                ));
            }
        }
        Ok(())
    }

    fn validate_contact(&self) -> Result<(), TalusError> {
        // each pair of materials named once, by materials the case has
        let mut seen: Vec<[u16; 2]> = Vec::new();
        for (k, pr) in self.contact.pairs.iter().enumerate() {
            let key = format!("contact.pair[{k}].materials");
            let a = self.material_index(&pr.materials[0], &key)?;
            let b = self.material_index(&pr.materials[1], &key)?;
            let ab = [a.min(b), a.max(b)];
            if seen.contains(&ab) {
                return Err(self.err(&key, format!("{:?}", pr.materials), "this pair of materials has a law already (an earlier [[contact.pair]])"));
            }
            seen.push(ab);
        }
        // the law checks its own keys (every law of a pair table, each pair's
        // named as contact.pair[k].KEY; cohesion's with the law)
        crate::contact::check_law(&self.contact).map_err(|e| self.err(&e.key, e.value, &e.why))?;
        let p = &self.particles;
        let spheres = !(self.simulation.dimension == Dimension::Two || !p.clumps.is_empty() || !p.ellipses.is_empty());
        for (k, law) in self.contact.laws().enumerate() {
            let at = if k == 0 { "contact".to_string() } else { format!("contact.pair[{}]", k - 1) };
            let model = law.model;
            if matches!(model, ModelName::Dmt | ModelName::Jkr) && !spheres {
                return Err(self.err(
                    &format!("{at}.model"),
                    format!("\"{}\"", model.name()),
                    "the dmt and jkr laws act between spheres (3D, no clumps, no ellipses): their contact radius is that of two spheres",
                ));
            }
            if model == ModelName::Jkr && self.contact.rolling == Some(RollingModel::Epsd2) {
                return Err(self.err(
                    "contact.rolling",
                    "\"epsd2\"",
                    "the jkr law keeps its contact's state in the slot the epsd2 rolling spring would use; use cdt rolling resistance with jkr",
                ));
            }
            if let (Some(c), false) = (&law.cohesion, spheres) {
                return Err(self.err(
                    &format!("{at}.cohesion.model"),
                    format!("\"{}\"", c.model.name()),
                    "cohesion acts between spheres (3D, no clumps, no ellipses): its contact area is that of two overlapping spheres",
                ));
            }
        }
        Ok(())
    }

    fn validate_particles(&self) -> Result<(), TalusError> {
        let ps = &self.particles;
        self.material_index(&ps.material, "particles.material")?;
        if ps.overlap_tolerance.is_nan() || ps.overlap_tolerance < 0.0 {
            return Err(self.err("particles.overlap_tolerance", ps.overlap_tolerance, "must be a fraction >= 0 of the radius"));
        }
        match &ps.source {
            // a run may start empty when a phase pours its particles in
            ParticleSource::List(l) if l.is_empty() && !self.phases.iter().any(|p| !p.inserts.is_empty()) => {
                return Err(self.err("particles.list", "[]", "no particles; give at least one (or insert them in a phase)"));
            }
            ParticleSource::Lattice(l) => self.validate_lattice(l)?,
            _ => {}
        }
        Ok(())
    }

    fn validate_lattice(&self, l: &LatticeSection) -> Result<(), TalusError> {
        if l.count == 0 {
            return Err(self.err("particles.lattice.count", 0, "no particles; give at least one"));
        }
        if !(l.radius_min > 0.0 && l.radius_max >= l.radius_min && l.radius_max.is_finite()) {
            return Err(self.err(
                "particles.lattice.radius_min",
                l.radius_min,
                "radii must be positive with radius_min <= radius_max",
            ));
        }
        if !(l.spacing >= 2.0 && l.spacing.is_finite()) {
            return Err(self.err("particles.lattice.spacing", l.spacing, "spacing below 2 radius_max would overlap"));
        }
        if l.lo.iter().chain(&l.hi_xy).any(|x| !x.is_finite()) {
            return Err(self.err(
                "particles.lattice",
                format!("lo {:?} hi_xy {:?}", l.lo, l.hi_xy),
                "every corner coordinate must be a finite number (m)",
            ));
        }
        if !(l.hi_xy[0] > l.lo[0] && l.hi_xy[1] > l.lo[1]) {
            return Err(self.err(
                "particles.lattice.hi_xy",
                format!("{:?}", l.hi_xy),
                &format!("must lie above lo = {:?} in x and in y", l.lo),
            ));
        }
        // the lattice grows upward in z from lo, nx x ny per layer (as generate::lattice_cloud)
        let s = l.spacing * l.radius_max;
        let nx = ((l.hi_xy[0] - l.lo[0]) / s).floor().max(1.0);
        let ny = ((l.hi_xy[1] - l.lo[1]) / s).floor().max(1.0);
        let layers = (l.count as f64 / (nx * ny)).ceil();
        let top = l.lo[2] + layers * s;
        let hi_z = self.simulation.domain.hi[2];
        if top > hi_z {
            let fit = ((hi_z - l.lo[2]) / s).floor().max(0.0) * nx * ny;
            return Err(self.err(
                "particles.lattice.count",
                l.count,
                &format!(
                    "{nx} x {ny} particles per layer at spacing {s:.4e} m need {layers} layers, up to z = {top:.4e} m, above the top of the domain (simulation.domain.hi z = {hi_z}); at most {fit} fit"
                ),
            ));
        }
        Ok(())
    }

    fn validate_wall(&self, w: &WallSection) -> Result<(), TalusError> {
        let name = &w.name;
        self.material_index(&w.material, &format!("wall.{name}.material"))?;
        let two_d = self.simulation.dimension == Dimension::Two;
        let key = |k: &str| format!("wall.{name}.{}{k}", w.shape.key());
        match &w.shape {
            WallShape::Segment(_) | WallShape::Box(_) if !two_d => {
                return Err(self.err(&key(""), "", "segments and boxes are 2D walls (simulation.dimension = \"2\"); in 3D use planes and STL meshes"));
            }
            WallShape::Segment(s) => {
                if s.from[2] != 0.0 || s.to[2] != 0.0 || s.from == s.to || s.from.iter().chain(&s.to).any(|x| !x.is_finite()) {
                    return Err(self.err(&key(""), format!("from {:?} to {:?}", s.from, s.to), "needs two distinct finite end points in z = 0"));
                }
            }
            WallShape::Box(b) => {
                if b.lo[2] != 0.0 || b.hi[2] != 0.0 || !(b.lo[0] < b.hi[0] && b.lo[1] < b.hi[1]) || b.lo.iter().chain(&b.hi).any(|x| !x.is_finite()) {
                    return Err(self.err(&key(""), format!("lo {:?} hi {:?}", b.lo, b.hi), "needs finite corners in z = 0 with lo < hi in x and y"));
                }
            }
            WallShape::Disc(d) => {
                if !(d.radius.is_finite() && d.radius > 0.0) {
                    return Err(self.err(&key(".radius"), d.radius, "must be a positive length (m)"));
                }
                if d.center.iter().any(|x| !x.is_finite()) {
                    return Err(self.err(&key(".center"), format!("{:?}", d.center), "every component must be a finite number (m)"));
                }
            }
            WallShape::Plane(p) => {
                let n = (p.normal[0].powi(2) + p.normal[1].powi(2) + p.normal[2].powi(2)).sqrt();
                if !(n > 0.0 && n.is_finite()) {
                    return Err(self.err(&key(".normal"), format!("{:?}", p.normal), "the normal must be a non-zero vector"));
                }
                if p.point.iter().any(|x| !x.is_finite()) {
                    return Err(self.err(&key(".point"), format!("{:?}", p.point), "every component must be a finite number (m)"));
                }
                if two_d && p.normal[2] != 0.0 {
                    return Err(self.err(&key(".normal"), format!("{:?}", p.normal), "in 2D a wall's normal lies in the x-y plane (z component 0)"));
                }
            }
            WallShape::Stl(_) if two_d => {
                return Err(self.err(&key(""), "", "STL meshes are 3D walls; in 2D use planes (lines) and discs"));
            }
            WallShape::Stl(_) => {}
        }
        self.validate_motion(&format!("wall.{name}"), &w.velocity, &w.rotation, &w.oscillation)?;
        if let Some(sv) = &w.servo {
            self.validate_servo(w, sv)?;
        }
        if let Some(t) = w.remove_at {
            if !(t.is_finite() && t >= 0.0) {
                return Err(self.err(&format!("wall.{name}.remove_at"), t, "must be a time >= 0 (s)"));
            }
        }
        Ok(())
    }

    /// A servo wall: one target, positive gain and speed, a direction; no other motion.
    fn validate_servo(&self, w: &WallSection, sv: &ServoSection) -> Result<(), TalusError> {
        let at = format!("wall.{}.servo", w.name);
        let pos = |k: &str, v: f64, unit: &str| -> Result<(), TalusError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.err(&format!("{at}.{k}"), v, &format!("must be a positive number ({unit})")))
            }
        };
        match (sv.force, sv.pressure, sv.area) {
            (Some(f), None, None) => pos("force", f, "N")?,
            (None, Some(p), Some(a)) => {
                pos("pressure", p, "Pa")?;
                pos("area", a, "m^2")?;
            }
            (f, p, a) => {
                let given = format!("force {f:?}, pressure {p:?}, area {a:?}");
                return Err(self.err(&at, given, "give the load to hold as `force` (N), or as `pressure` (Pa) and `area` (m^2)"));
            }
        }
        pos("gain", sv.gain, "m/s per N")?;
        pos("max_speed", sv.max_speed, "m/s")?;
        match (&w.shape, sv.direction) {
            (_, Some(d)) => {
                let n = d.iter().map(|x| x * x).sum::<f64>().sqrt();
                if !(n > 0.0 && n.is_finite()) || (self.simulation.dimension == Dimension::Two && d[2] != 0.0) {
                    return Err(self.err(&format!("{at}.direction"), format!("{d:?}"), "must be a non-zero vector (in 2D in the x-y plane)"));
                }
            }
            (WallShape::Plane(_), None) => {}
            (_, None) => return Err(self.err(&format!("{at}.direction"), "", "a servo wall that is not a plane needs the direction it moves to press on the particles")),
        }
        if w.velocity != [0.0; 3] || w.rotation.is_some() || w.oscillation.is_some() {
            let given = format!("velocity {:?}, rotation {:?}, oscillation {:?}", w.velocity, w.rotation, w.oscillation);
            return Err(self.err(&at, given, "a servo wall moves only as its servo says: leave out its velocity, rotation and oscillation"));
        }
        if let Some(ph) = self.phases.iter().find(|p| p.moves.iter().any(|m| m.wall == w.name)) {
            return Err(self.err(&format!("phase.{}.move", ph.name), format!("\"{}\"", w.name), "a servo wall moves only as its servo says"));
        }
        Ok(())
    }

    /// A wall's motion (its own, or a phase's `move`), keys under `at`.
    fn validate_motion(
        &self,
        at: &str,
        velocity: &[f64; 3],
        rotation: &Option<RotationSection>,
        oscillation: &Option<OscillationSection>,
    ) -> Result<(), TalusError> {
        let two_d = self.simulation.dimension == Dimension::Two;
        let finite = |v: &[f64; 3]| v.iter().all(|x| x.is_finite());
        if !finite(velocity) {
            return Err(self.err(&format!("{at}.velocity"), format!("{velocity:?}"), "every component must be a finite number (m/s)"));
        }
        if two_d && velocity[2] != 0.0 {
            return Err(self.err(&format!("{at}.velocity"), format!("{velocity:?}"), "in 2D a wall moves in the x-y plane (z component 0)"));
        }
        if let Some(r) = rotation {
            let n = r.axis.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(finite(&r.axis) && n > 0.0 && n.is_finite()) {
                return Err(self.err(&format!("{at}.rotation.axis"), format!("{:?}", r.axis), "must be a non-zero vector"));
            }
            if two_d && (r.axis[0] != 0.0 || r.axis[1] != 0.0) {
                return Err(self.err(&format!("{at}.rotation.axis"), format!("{:?}", r.axis), "in 2D a wall turns about z: the axis is [0, 0, 1] or [0, 0, -1]"));
            }
            if !finite(&r.point) || (two_d && r.point[2] != 0.0) {
                return Err(self.err(&format!("{at}.rotation.point"), format!("{:?}", r.point), "every component must be a finite number (m); in 2D z = 0"));
            }
            if !r.angular_velocity.is_finite() {
                return Err(self.err(&format!("{at}.rotation.angular_velocity"), r.angular_velocity, "must be a finite number (rad/s)"));
            }
        }
        if let Some(o) = oscillation {
            if !finite(&o.amplitude) || (two_d && o.amplitude[2] != 0.0) {
                return Err(self.err(&format!("{at}.oscillation.amplitude"), format!("{:?}", o.amplitude), "every component must be a finite number (m); in 2D z = 0"));
            }
            if !(o.frequency.is_finite() && o.frequency > 0.0) {
                return Err(self.err(&format!("{at}.oscillation.frequency"), o.frequency, "must be a positive frequency (Hz)"));
            }
        }
        Ok(())
    }

    fn validate_phases(&self) -> Result<(), TalusError> {
        if self.phases.is_empty() {
            return Err(self.err("phase", "[]", "at least one [[phase]] is needed"));
        }
        let mut names = std::collections::HashSet::new();
        for (i, ph) in self.phases.iter().enumerate() {
            self.check_name(&format!("phase[{i}].name"), &ph.name)?;
            if !names.insert(ph.name.as_str()) {
                return Err(self.err(&format!("phase[{i}].name"), format!("\"{}\"", ph.name), "phase names must be unique"));
            }
            if !(ph.duration.is_finite() && ph.duration > 0.0) {
                return Err(self.err(&format!("phase.{}.duration", ph.name), ph.duration, "must be a positive time (s)"));
            }
            if let Some(f) = ph.kinetic_energy_fraction {
                if !(f.is_finite() && f >= 0.0) {
                    return Err(self.err(&format!("phase.{}.kinetic_energy_fraction", ph.name), f, "must be a fraction >= 0"));
                }
            }
            if !(ph.settle_extra.is_finite() && ph.settle_extra >= 0.0) {
                return Err(self.err(&format!("phase.{}.settle_extra", ph.name), ph.settle_extra, "must be a time >= 0 (s)"));
            }
            for w in &ph.remove_walls_at_end {
                if !self.walls.iter().any(|x| &x.name == w) {
                    return Err(self.err(&format!("phase.{}.remove_walls_at_end", ph.name), format!("\"{w}\""), "no wall of that name"));
                }
            }
            let mut moved = std::collections::HashSet::new();
            for (k, m) in ph.moves.iter().enumerate() {
                let at = format!("phase.{}.move[{k}]", ph.name);
                if !self.walls.iter().any(|x| x.name == m.wall) {
                    return Err(self.err(&format!("{at}.wall"), format!("\"{}\"", m.wall), "no wall of that name"));
                }
                if !moved.insert(m.wall.as_str()) {
                    return Err(self.err(&format!("{at}.wall"), format!("\"{}\"", m.wall), "a phase moves a wall once"));
                }
                self.validate_motion(&at, &m.velocity, &m.rotation, &m.oscillation)?;
            }
            for (k, ins) in ph.inserts.iter().enumerate() {
                self.validate_insert(&format!("phase.{}.insert[{k}]", ph.name), ins)?;
            }
        }
        Ok(())
    }

    /// An insertion: a known material, a region inside the domain, one total
    /// (count or mass) and its rate, radii that fit the region, a positive interval.
    fn validate_insert(&self, at: &str, ins: &InsertSection) -> Result<(), TalusError> {
        self.material_index(&ins.material, &format!("{at}.material"))?;
        let pos = |key: &str, v: f64| -> Result<(), TalusError> {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(self.err(&format!("{at}.{key}"), v, "must be positive")) }
        };
        match (ins.count, ins.mass, ins.rate, ins.mass_rate) {
            (Some(n), None, Some(r), None) => {
                if n == 0 {
                    return Err(self.err(&format!("{at}.count"), n, "must be at least 1"));
                }
                pos("rate", r)?;
            }
            (None, Some(m), None, Some(r)) => {
                pos("mass", m)?;
                pos("mass_rate", r)?;
            }
            _ => {
                return Err(self.err(at, "", "give count and rate (particles, per second) or mass and mass_rate (kg, kg/s)"));
            }
        }
        if let Some(i) = ins.interval {
            pos("interval", i)?;
        }
        let rmax = match &ins.radius {
            RadiusSection::Uniform { min, max } => {
                pos("radius.min", *min)?;
                if !(max.is_finite() && max >= min) {
                    return Err(self.err(&format!("{at}.radius.max"), max, "must be at least radius.min"));
                }
                *max
            }
            RadiusSection::Discrete { values, weights } => {
                if values.is_empty() || values.len() != weights.len() {
                    return Err(self.err(&format!("{at}.radius.weights"), format!("{weights:?}"), "needs one weight for each of radius.values"));
                }
                for &v in values {
                    pos("radius.values", v)?;
                }
                if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) || weights.iter().sum::<f64>() <= 0.0 {
                    return Err(self.err(&format!("{at}.radius.weights"), format!("{weights:?}"), "must be >= 0 and not all 0"));
                }
                crate::insert::max_radius(&ins.radius)
            }
        };
        let v = ins.velocity;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(self.err(&format!("{at}.velocity"), format!("{v:?}"), "must be finite"));
        }
        let (lo, hi) = match ins.region {
            RegionSection::Box { lo, hi } => {
                if (0..3).any(|k| !(lo[k].is_finite() && hi[k].is_finite() && hi[k] - lo[k] > 2.0 * rmax)) {
                    return Err(self.err(&format!("{at}.region.box"), format!("lo {lo:?}, hi {hi:?}"), "must be wider than the largest particle along every axis"));
                }
                (lo, hi)
            }
            RegionSection::Cylinder { center, radius, lo, hi } => {
                if !(radius.is_finite() && radius > rmax && hi - lo > 2.0 * rmax && center.iter().all(|c| c.is_finite())) {
                    return Err(self.err(&format!("{at}.region.cylinder"), format!("center {center:?}, radius {radius}, lo {lo}, hi {hi}"), "must be wider and taller than the largest particle"));
                }
                ([center[0] - radius, center[1] - radius, lo], [center[0] + radius, center[1] + radius, hi])
            }
        };
        let d = &self.simulation.domain;
        if (0..3).any(|k| lo[k] < d.lo[k] || hi[k] > d.hi[k]) {
            return Err(self.err(&format!("{at}.region"), format!("lo {lo:?}, hi {hi:?}"), "must lie inside the simulation domain"));
        }
        if self.simulation.dimension == crate::dim::Dimension::Two {
            return Err(self.err(at, "", "insertion is 3D only (2D discs are placed by the drag bed generator)"));
        }
        if self.simulation.integrator != IntegratorKind::Verlet {
            return Err(self.err("simulation.integrator", "\"gear\"", &format!("{at}: inserted particles need integrator = \"verlet\" (Gear's derivatives have no start for them)")));
        }
        Ok(())
    }

    fn validate_output(&self) -> Result<(), TalusError> {
        let o = &self.output;
        for (key, v) in [
            ("output.interval", Some(o.interval)),
            ("output.snapshot_interval", o.snapshot_interval),
            ("output.checkpoint_interval", o.checkpoint_interval),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(self.err(key, v, "must be a positive time (s)"));
                }
            }
        }
        if let Some(z) = o.mass_below_z {
            if !z.is_finite() {
                return Err(self.err("output.mass_below_z", z, "must be a finite height (m)"));
            }
        }
        if let Some(f) = &o.fields {
            if self.simulation.dimension == crate::dim::Dimension::Two {
                return Err(self.err("output.fields", "", "continuum fields are 3D only"));
            }
            if !(f.interval.is_finite() && f.interval > 0.0) {
                return Err(self.err("output.fields.interval", f.interval, "must be a positive time (s)"));
            }
            for (key, v) in [("output.fields.from", f.from), ("output.fields.to", f.to)] {
                if let Some(v) = v.filter(|v| !v.is_finite() || *v < 0.0) {
                    return Err(self.err(key, v, "must be a time (s) from 0 on"));
                }
            }
            crate::fields::plan(&f.kernel, f.width, f.profile.as_deref(), f.grid, f.points).map_err(|(key, v, why)| self.err(&format!("output.fields.{key}"), v, &why))?;
        }
        Ok(())
    }
}

/// The JSON Schema (draft 7) of a case file, as talus reads it: every
/// section, key, type and default, with the keys' documentation. `talus
/// schema` prints it; editors that check TOML against a JSON Schema (taplo)
/// check case files with it as one types.
pub fn schema() -> serde_json::Value {
    let generator = schemars::generate::SchemaSettings::draft07().for_deserialize().into_generator();
    let mut s = generator.into_root_schema_for::<Case>();
    s.insert("title".into(), "talus case file".into());
    s.insert(
        "description".into(),
        "A talus case (TOML). Made by `talus schema` from the types talus reads a case into; checks beyond the types (ranges, cross-references between sections) are made when the case is loaded.".into(),
    );
    s.to_value()
}
