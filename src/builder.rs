//! Building a case in code: [`CaseBuilder`] makes a [`Case`] from typed values
//! and validates it with the same checks as a case file, so tests, benches and
//! the drag study need no TOML text.
//!
//! ```
//! use talus::builder::CaseBuilder;
//! use talus::case::{ContactSection, ModelName, ParticleEntry, PhaseSection, TimeStep, WallSection};
//! use talus::dim::Dimension;
//! use talus::material::Material;
//!
//! let steel = Material {
//!     name: "m".into(),
//!     youngs_modulus: 1.0e9,
//!     poisson_ratio: 0.3,
//!     density: 3900.0,
//!     restitution: 0.5,
//!     friction: 0.3,
//!     rolling_friction: 0.0,
//! };
//! let case = CaseBuilder::new(Dimension::Two)
//!     .timestep(TimeStep::Seconds(1e-6))
//!     .gravity([0.0, -9.81, 0.0])
//!     .domain([-0.05, -0.05, -0.001], [0.05, 0.05, 0.001])
//!     .contact(ContactSection::new(ModelName::Hertz))
//!     .material(steel)
//!     .particle_list("m", vec![ParticleEntry::at(1, [0.0, 0.002, 0.0], 0.001)])
//!     .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
//!     .phase(PhaseSection::new("run", 1.0))
//!     .build(std::path::Path::new("drop.toml"))
//!     .unwrap();
//! assert_eq!(case.walls.len(), 1);
//! // the same case as a file
//! let text = case.to_toml().unwrap();
//! assert_eq!(talus::case::Case::parse(&text, &case.path).unwrap(), case);
//! ```

use crate::case::{
    default_overlap_tol, AnalysisSection, BoxSection, Case, ContactSection, DiscSection, DomainSection, EllipseEntry,
    LatticeSection, ModelName, OscillationSection, RotationSection, OutputSection, ParallelSection, ParticleEntry, ParticleSource, ParticlesSection,
    PhaseSection, PlaneSection, SegmentSection, SimulationSection, TimeStep, WallSection, WallShape,
};
use crate::contact::Convention;
use crate::dim::Dimension;
use crate::error::TalusError;
use crate::integrate::IntegratorKind;
use crate::material::Material;
use std::path::Path;

/// A case under construction. Every setter takes typed values; what a file may
/// leave out starts at the file's default (no gravity, Verlet, default skin,
/// `overlap_tolerance` 1e-3, default `[output]` and `[parallel]`). What a file
/// must give (time step, domain, contact, particles, a material, a phase) must
/// be set before [`CaseBuilder::build`].
#[derive(Clone, Debug)]
pub struct CaseBuilder {
    dimension: Dimension,
    timestep: Option<TimeStep>,
    force_timestep: bool,
    gravity: [f64; 3],
    integrator: IntegratorKind,
    skin: Option<f64>,
    domain: Option<DomainSection>,
    contact: Option<ContactSection>,
    materials: Vec<Material>,
    particle_material: Option<String>,
    overlap_tolerance: f64,
    source: Option<ParticleSource>,
    clumps: Vec<[u64; 2]>,
    ellipses: Vec<EllipseEntry>,
    walls: Vec<WallSection>,
    phases: Vec<PhaseSection>,
    output: OutputSection,
    analysis: Option<AnalysisSection>,
    parallel: ParallelSection,
    compare: crate::case::CompareSection,
}

impl CaseBuilder {
    /// An empty case of this dimension, with the file format's defaults.
    pub fn new(dimension: Dimension) -> CaseBuilder {
        CaseBuilder {
            dimension,
            timestep: None,
            force_timestep: false,
            gravity: [0.0; 3],
            integrator: IntegratorKind::default(),
            skin: None,
            domain: None,
            contact: None,
            materials: Vec::new(),
            particle_material: None,
            overlap_tolerance: default_overlap_tol(),
            source: None,
            clumps: Vec::new(),
            ellipses: Vec::new(),
            walls: Vec::new(),
            phases: Vec::new(),
            output: OutputSection::default(),
            analysis: None,
            parallel: ParallelSection::default(),
            compare: Default::default(),
        }
    }

    /// Start from an existing case (e.g. one loaded from `cases/*.toml`) to change it.
    pub fn from_case(case: Case) -> CaseBuilder {
        let Case { simulation: s, contact, materials, particles: p, walls, phases, output, analysis, parallel, compare, .. } = case;
        CaseBuilder {
            dimension: s.dimension,
            timestep: Some(s.timestep),
            force_timestep: s.force_timestep,
            gravity: s.gravity,
            integrator: s.integrator,
            skin: s.skin,
            domain: Some(s.domain),
            contact: Some(contact),
            materials,
            particle_material: Some(p.material),
            overlap_tolerance: p.overlap_tolerance,
            source: Some(p.source),
            clumps: p.clumps,
            ellipses: p.ellipses,
            walls,
            phases,
            output,
            analysis,
            parallel,
            compare,
        }
    }

    /// `simulation.dimension`.
    pub fn dimension(mut self, dimension: Dimension) -> Self {
        self.dimension = dimension;
        self
    }

    /// `simulation.timestep` (s) or `simulation.timestep_rayleigh_fraction`.
    pub fn timestep(mut self, timestep: TimeStep) -> Self {
        self.timestep = Some(timestep);
        self
    }

    /// `simulation.force_timestep`: accept a step above 30% of the Rayleigh time.
    pub fn force_timestep(mut self, force: bool) -> Self {
        self.force_timestep = force;
        self
    }

    /// `simulation.gravity` (m/s^2).
    pub fn gravity(mut self, gravity: [f64; 3]) -> Self {
        self.gravity = gravity;
        self
    }

    /// `simulation.integrator`.
    pub fn integrator(mut self, integrator: IntegratorKind) -> Self {
        self.integrator = integrator;
        self
    }

    /// `simulation.skin`: Verlet skin (m).
    pub fn skin(mut self, skin: f64) -> Self {
        self.skin = Some(skin);
        self
    }

    /// `simulation.domain`: the box particles must stay in, corners in m.
    pub fn domain(mut self, lo: [f64; 3], hi: [f64; 3]) -> Self {
        self.domain = Some(DomainSection { lo, hi, periodic: Vec::new() });
        self
    }

    /// `simulation.domain.periodic`: the axes along which the domain is
    /// periodic (after `domain`).
    pub fn periodic(mut self, axes: &[crate::case::Axis]) -> Self {
        if let Some(d) = self.domain.as_mut() {
            d.periodic = axes.to_vec();
        }
        self
    }

    /// `[contact]`.
    pub fn contact(mut self, contact: ContactSection) -> Self {
        self.contact = Some(contact);
        self
    }

    /// A `[[material]]`; one of the same name is replaced in place.
    pub fn material(mut self, material: Material) -> Self {
        match self.materials.iter_mut().find(|m| m.name == material.name) {
            Some(m) => *m = material,
            None => self.materials.push(material),
        }
        self
    }

    /// The whole `[particles]` section.
    pub fn particles(mut self, p: ParticlesSection) -> Self {
        self.particle_material = Some(p.material);
        self.overlap_tolerance = p.overlap_tolerance;
        self.source = Some(p.source);
        self.clumps = p.clumps;
        self.ellipses = p.ellipses;
        self
    }

    /// Particles given one by one (`particles.list`) of the named material.
    pub fn particle_list(self, material: &str, list: Vec<ParticleEntry>) -> Self {
        self.particle_source(material, ParticleSource::List(list))
    }

    /// Particles from a seeded jittered lattice (`particles.lattice`) of the named material.
    pub fn lattice(self, material: &str, lattice: LatticeSection) -> Self {
        self.particle_source(material, ParticleSource::Lattice(lattice))
    }

    /// Where the particles come from, and their material.
    pub fn particle_source(mut self, material: &str, source: ParticleSource) -> Self {
        self.particle_material = Some(material.to_string());
        self.source = Some(source);
        self
    }

    /// `particles.overlap_tolerance`: largest initial overlap, a fraction of the smaller radius.
    pub fn overlap_tolerance(mut self, fraction: f64) -> Self {
        self.overlap_tolerance = fraction;
        self
    }

    /// `particles.ellipses` (2D).
    pub fn ellipses(mut self, ellipses: Vec<EllipseEntry>) -> Self {
        self.ellipses = ellipses;
        self
    }

    /// `particles.clumps`: pairs of particle ids moving as one rigid body (2D).
    pub fn clumps(mut self, clumps: Vec<[u64; 2]>) -> Self {
        self.clumps = clumps;
        self
    }

    /// A `[[wall]]`; one of the same name is replaced in place.
    pub fn wall(mut self, wall: WallSection) -> Self {
        match self.walls.iter_mut().find(|w| w.name == wall.name) {
            Some(w) => *w = wall,
            None => self.walls.push(wall),
        }
        self
    }

    /// A `[[phase]]`, run after those already given; one of the same name is replaced in place.
    pub fn phase(mut self, phase: PhaseSection) -> Self {
        match self.phases.iter_mut().find(|p| p.name == phase.name) {
            Some(p) => *p = phase,
            None => self.phases.push(phase),
        }
        self
    }

    /// `[output]`.
    pub fn output(mut self, output: OutputSection) -> Self {
        self.output = output;
        self
    }

    /// `[compare]`: the comparisons' tolerances.
    pub fn compare(mut self, compare: crate::case::CompareSection) -> Self {
        self.compare = compare;
        self
    }

    /// `[analysis]`; `None` removes it.
    pub fn analysis(mut self, analysis: Option<AnalysisSection>) -> Self {
        self.analysis = analysis;
        self
    }

    /// `[parallel]`.
    pub fn parallel(mut self, parallel: ParallelSection) -> Self {
        self.parallel = parallel;
        self
    }

    /// The case, as if read from the file `path` (it names the case in messages
    /// and anchors relative paths), checked exactly as a case file is.
    pub fn build(self, path: &Path) -> Result<Case, TalusError> {
        let missing = |key: &str, setter: &str| {
            TalusError::Input(format!("{}: {key}: not given (CaseBuilder::{setter})", path.display()))
        };
        let timestep = self.timestep.ok_or_else(|| missing("simulation.timestep", "timestep"))?;
        let domain = self.domain.ok_or_else(|| missing("simulation.domain", "domain"))?;
        let contact = self.contact.ok_or_else(|| missing("contact", "contact"))?;
        let material = self.particle_material.ok_or_else(|| missing("particles", "particle_list"))?;
        let source = self.source.ok_or_else(|| missing("particles", "particle_list"))?;
        let case = Case {
            simulation: SimulationSection {
                dimension: self.dimension,
                timestep,
                force_timestep: self.force_timestep,
                gravity: self.gravity,
                integrator: self.integrator,
                skin: self.skin,
                domain,
            },
            contact,
            materials: self.materials,
            particles: ParticlesSection {
                material,
                overlap_tolerance: self.overlap_tolerance,
                source,
                clumps: self.clumps,
                ellipses: self.ellipses,
            },
            walls: self.walls,
            phases: self.phases,
            output: self.output,
            analysis: self.analysis,
            parallel: self.parallel,
            compare: self.compare,
            dir: Default::default(),
            path: Default::default(),
        };
        case.validated(path)
    }
}

impl ContactSection {
    /// `[contact]` with only the model given: every option from talus's convention.
    pub fn new(model: ModelName) -> ContactSection {
        ContactSection {
            model,
            convention: Convention::default(),
            damping: None,
            end_of_contact: None,
            tangential: None,
            friction_cap: None,
            shear_kinematics: None,
            wall_contact_point: None,
            characteristic_velocity: None,
            stiffness: None,
            rolling: None,
            cohesion: None,
            surface_energy: None,
            pairs: Vec::new(),
        }
    }
}

impl ParticleEntry {
    /// A particle at rest: id, position (m), radius (m).
    pub fn at(id: u64, position: [f64; 3], radius: f64) -> ParticleEntry {
        ParticleEntry { id, position, velocity: [0.0; 3], spin: [0.0; 3], radius }
    }

    /// The same particle moving at `velocity` (m/s).
    pub fn moving(self, velocity: [f64; 3]) -> ParticleEntry {
        ParticleEntry { velocity, ..self }
    }

    /// The same particle spinning at `spin` (rad/s).
    pub fn spinning(self, spin: [f64; 3]) -> ParticleEntry {
        ParticleEntry { spin, ..self }
    }
}

impl WallSection {
    /// A wall at rest, never removed.
    pub fn new(name: &str, material: &str, shape: WallShape) -> WallSection {
        WallSection {
            name: name.to_string(),
            material: material.to_string(),
            shape,
            velocity: [0.0; 3],
            rotation: None,
            oscillation: None,
            servo: None,
            remove_at: None,
        }
    }

    /// A one-sided plane through `point` (m), facing along `normal`.
    pub fn plane(name: &str, material: &str, point: [f64; 3], normal: [f64; 3]) -> WallSection {
        WallSection::new(name, material, WallShape::Plane(PlaneSection { point, normal }))
    }

    /// A rigid disc (2D) or ball (3D): centre and radius in m.
    pub fn disc(name: &str, material: &str, center: [f64; 3], radius: f64) -> WallSection {
        WallSection::new(name, material, WallShape::Disc(DiscSection { center, radius }))
    }

    /// A straight segment (2D) between two points (m) in z = 0.
    pub fn segment(name: &str, material: &str, from: [f64; 3], to: [f64; 3]) -> WallSection {
        WallSection::new(name, material, WallShape::Segment(SegmentSection { from, to }))
    }

    /// A closed box (2D) of four segments, corners in m in z = 0.
    pub fn boxed(name: &str, material: &str, lo: [f64; 3], hi: [f64; 3]) -> WallSection {
        WallSection::new(name, material, WallShape::Box(BoxSection { lo, hi }))
    }

    /// The same wall moving at `velocity` (m/s).
    pub fn moving(self, velocity: [f64; 3]) -> WallSection {
        WallSection { velocity, ..self }
    }

    /// The same wall turning at `angular_velocity` (rad/s) about the axis through `point`.
    pub fn turning(self, axis: [f64; 3], point: [f64; 3], angular_velocity: f64) -> WallSection {
        WallSection { rotation: Some(RotationSection { axis, point, angular_velocity }), ..self }
    }

    /// The same wall oscillating: displaced by `amplitude sin(2 pi frequency t)` (m, Hz).
    pub fn oscillating(self, amplitude: [f64; 3], frequency: f64) -> WallSection {
        WallSection { oscillation: Some(OscillationSection { amplitude, frequency }), ..self }
    }
}

impl PhaseSection {
    /// A phase that runs for `duration` (s), with no early end and no walls removed.
    pub fn new(name: &str, duration: f64) -> PhaseSection {
        PhaseSection {
            name: name.to_string(),
            duration,
            kinetic_energy_fraction: None,
            settle_extra: 0.0,
            remove_walls_at_end: Vec::new(),
            moves: Vec::new(),
            inserts: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn material() -> Material {
        Material {
            name: "m".into(),
            youngs_modulus: 1.0e9,
            poisson_ratio: 0.3,
            density: 3900.0,
            restitution: 0.5,
            friction: 0.3,
            rolling_friction: 0.0,
        }
    }

    /// A 2D case with every kind of 2D wall, an ellipse and a dumbbell.
    fn two_d() -> CaseBuilder {
        CaseBuilder::new(Dimension::Two)
            .timestep(TimeStep::Seconds(1e-6))
            .gravity([0.0, -9.81, 0.0])
            .skin(1.0e-4)
            .domain([-0.05, -0.05, -0.001], [0.05, 0.05, 0.001])
            .contact(ContactSection::new(ModelName::Hertz))
            .material(material())
            .particle_list(
                "m",
                vec![
                    ParticleEntry::at(1, [0.001, 0.01, 0.0], 0.001).moving([0.1, 0.0, 0.0]),
                    ParticleEntry::at(2, [-0.001, 0.01, 0.0], 0.001).spinning([0.0, 0.0, 3.0]),
                    ParticleEntry::at(3, [0.01, 0.02, 0.0], 1.2e-3 / 3.0),
                ],
            )
            .clumps(vec![[1, 2]])
            .ellipses(vec![EllipseEntry { id: 3, aspect_ratio: 1.5, angle: 0.1 }])
            .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
            .wall(WallSection::disc("cylinder", "m", [0.0, 0.03, 0.0], 0.0015875).moving([0.0, 0.5, 0.0]))
            .wall(WallSection::segment("s", "m", [-0.02, 0.04, 0.0], [0.02, 0.04, 0.0]))
            .wall(WallSection::boxed("b", "m", [-0.04, -0.04, 0.0], [0.04, 0.045, 0.0]))
            .phase(PhaseSection { kinetic_energy_fraction: Some(0.01), ..PhaseSection::new("fill", 0.5) })
            .phase(PhaseSection::new("run", 1.0))
    }

    fn err(b: CaseBuilder) -> String {
        b.build(Path::new("t.toml")).err().expect("refused").to_string()
    }

    #[test]
    fn a_built_case_has_the_values_given_and_the_file_defaults() {
        let c = two_d().build(Path::new("dir/t.toml")).unwrap();
        assert_eq!(c.path, PathBuf::from("dir/t.toml"));
        assert_eq!(c.dir, PathBuf::from("dir"));
        assert_eq!(c.particles.overlap_tolerance, 1e-3);
        assert_eq!(c.simulation.integrator, IntegratorKind::Verlet);
        assert_eq!(c.output, OutputSection::default());
        assert_eq!(c.parallel, ParallelSection::default());
        assert_eq!(c.walls[1].velocity, [0.0, 0.5, 0.0]);
        assert_eq!(c.phases.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["fill", "run"]);
    }

    #[test]
    fn a_built_case_written_as_toml_reads_back_to_the_same_values() {
        let c = two_d().build(Path::new("t.toml")).unwrap();
        let text = c.to_toml().unwrap();
        assert_eq!(Case::parse(&text, Path::new("t.toml")).unwrap(), c, "{text}");
    }

    #[test]
    fn every_case_file_round_trips_through_to_toml() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).unwrap() {
            let path = e.unwrap().path();
            if path.extension().is_some_and(|x| x == "toml") {
                let c = Case::load(&path).unwrap();
                let text = c.to_toml().unwrap();
                assert_eq!(Case::parse(&text, &path).unwrap(), c, "{}", path.display());
                // and through the builder unchanged
                assert_eq!(CaseBuilder::from_case(c.clone()).build(&path).unwrap(), c, "{}", path.display());
                n += 1;
            }
        }
        assert!(n >= 5, "{n} case files");
    }

    #[test]
    fn a_bad_value_through_the_builder_gets_the_error_of_the_file() {
        let good = two_d().build(Path::new("t.toml")).unwrap();
        for (b, edit) in [
            (two_d().timestep(TimeStep::Seconds(-1e-6)), ("timestep = 0.000001", "timestep = -0.000001")),
            (two_d().gravity([0.0, -9.81, 1.0]), ("gravity = [0.0, -9.81, 0.0]", "gravity = [0.0, -9.81, 1.0]")),
            (two_d().skin(0.0), ("skin = 0.0001", "skin = 0.0")),
        ] {
            let text = good.to_toml().unwrap();
            assert!(text.contains(edit.0), "{text}");
            let from_file = Case::parse(&text.replacen(edit.0, edit.1, 1), Path::new("t.toml")).err().unwrap().to_string();
            assert_eq!(err(b), from_file);
        }
        // and the checks of the sections: a wall of an unknown material, a duplicate phase name
        let e = err(two_d().wall(WallSection::plane("lid", "steel", [0.0; 3], [0.0, -1.0, 0.0])));
        assert!(e.contains("wall.lid.material") && e.contains("no material of that name"), "{e}");
        let e = err(two_d().material(Material { poisson_ratio: 0.7, ..material() }));
        assert!(e.contains("materials.m.poisson_ratio = 0.7"), "{e}");
    }

    #[test]
    fn a_case_without_a_required_section_is_refused_by_name() {
        let e = err(CaseBuilder::new(Dimension::Three));
        assert!(e.contains("simulation.timestep: not given"), "{e}");
        let e = err(two_d().phase(PhaseSection::new("run", 1.0)).dimension(Dimension::Three));
        assert!(e.contains("wall.s.segment"), "{e}");
    }

    #[test]
    fn from_case_replaces_walls_materials_and_phases_by_name() {
        let c = two_d().build(Path::new("t.toml")).unwrap();
        let d = CaseBuilder::from_case(c.clone())
            .material(Material { restitution: 0.9, ..material() })
            .wall(WallSection::plane("floor", "m", [0.0, -0.01, 0.0], [0.0, 1.0, 0.0]))
            .phase(PhaseSection::new("run", 2.0))
            .build(Path::new("t.toml"))
            .unwrap();
        assert_eq!(d.materials.len(), 1);
        assert_eq!(d.materials[0].restitution, 0.9);
        assert_eq!(d.walls.len(), c.walls.len());
        assert_eq!(d.walls[0].shape, WallShape::Plane(PlaneSection { point: [0.0, -0.01, 0.0], normal: [0.0, 1.0, 0.0] }));
        assert_eq!(d.phases[1].duration, 2.0);
    }
}
