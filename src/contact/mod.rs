//! Contact laws: pure functions from contact geometry, relative motion, mixed pair
//! properties and the law's own history to a force and the torques on both bodies.
//!
//! Three stages (YADE's Ig2 / Ip2 / Law2): the geometry of every contact
//! (sphere-sphere, sphere-wall feature, ellipse-ellipse, ellipse-wall) is one
//! [`ContactGeom`] ([`geometry`]); the mixed material of the pair comes from a
//! dense table (`material`), the pair's R*, m* and the law's own constants are
//! computed once per pair ([`PairInertia`], [`ContactLaw::pair`]); a law
//! ([`ContactLaw`]) turns them into a [`ContactForce`]. Every law works on every
//! geometry, walls included.
//!
//! Sign conventions: `n` is the unit normal pointing from body j (or the wall)
//! to body i; `overlap` > 0 in contact; the relative velocity is that of i's
//! material point at the contact minus j's; the returned force acts on i, and
//! -force on j; `torque_i` and `torque_j` act on i and j.
//!
//! The conventions of the reference codes are resolved in one place,
//! [`conventions::resolve`].

pub mod adhesive;
pub mod cohesion;
pub mod conventions;
pub mod ellipse;
pub mod geometry;
pub mod hertz;
pub mod hooke;
pub mod per_pair;

pub use conventions::ContactOptions;
pub use geometry::{ContactGeom, Lever, Motion, Shapes};

use crate::case::{ContactSection, ModelName, RollingModel};
use crate::dim::Vec3;
use crate::material::PairMaterial;
use serde::{Deserialize, Serialize};

/// The one place a case's model name meets its law type: `user` is run with
/// the law the section's `model` names, monomorphised for it (static dispatch:
/// the force sweep is compiled once per law). A new law adds its arm here.
/// `hooke` with explicit `stiffness` is its own law type
/// ([`hooke::HookeExplicit`]): one set of coefficients for every pair, held by
/// the law, so the sweep reads no per-pair constants and computes no R*, m*.
/// With `contact.cohesion` the law is wrapped in [`cohesion::Cohesive`], so a
/// sweep without cohesion carries no trace of it.
pub fn dispatch<U: LawUser>(c: &ContactSection, user: U) -> U::Out {
    if !c.pairs.is_empty() {
        // laws per pair of materials: one law type holding them all
        return user.with::<per_pair::PerPair>();
    }
    match c.model {
        ModelName::Hooke if c.stiffness.is_some() => with_cohesion::<U, hooke::HookeExplicit>(c, user),
        ModelName::Hooke => with_cohesion::<U, hooke::Hooke>(c, user),
        ModelName::Hertz => with_cohesion::<U, hertz::Hertz>(c, user),
        ModelName::Dmt => with_cohesion::<U, adhesive::Dmt>(c, user),
        ModelName::Jkr => with_cohesion::<U, adhesive::Jkr>(c, user),
    }
}

/// `user` with law L, or with L and the case's cohesion sub-model.
fn with_cohesion<U: LawUser, L: ContactLaw>(c: &ContactSection, user: U) -> U::Out {
    if c.cohesion.is_some() {
        user.with::<cohesion::Cohesive<L>>()
    } else {
        user.with::<L>()
    }
}

/// Something done with the law of a case, generic in the law (see [`dispatch`]).
pub trait LawUser {
    type Out;
    fn with<L: ContactLaw>(self) -> Self::Out;
}

/// What the case's law is, from its type alone: (pulls, reaches beyond touching).
pub fn law_traits(c: &ContactSection) -> (bool, bool) {
    struct Traits;
    impl LawUser for Traits {
        type Out = (bool, bool);
        fn with<L: ContactLaw>(self) -> Self::Out {
            (L::PULLS, L::REACHES)
        }
    }
    dispatch(c, Traits)
}

/// The longest reach beyond touching (m) of the case's law over every pair
/// of materials, for bodies of radius at most `r_max` (taken as R* = r_max,
/// a wall's, the largest R* there is; JKR's reach grows as R*^(1/3)); 0 for
/// a law whose contacts end at touching, or whose keys are bad (refused
/// elsewhere).
pub fn longest_reach(c: &ContactSection, table: &crate::material::PairTable, r_max: f64) -> f64 {
    struct Reach<'a>(&'a ContactSection, &'a crate::material::PairTable, f64);
    impl LawUser for Reach<'_> {
        type Out = f64;
        fn with<L: ContactLaw>(self) -> f64 {
            let Reach(c, table, r_max) = self;
            let Ok(law) = L::from_case(c, &conventions::resolve(c)) else { return 0.0 };
            if !L::REACHES || !(r_max > 0.0) {
                return 0.0;
            }
            let mut reach: f64 = 0.0;
            for a in 0..table.len() as u16 {
                for b in 0..table.len() as u16 {
                    let pm = table.get(a, b);
                    reach = reach.max(law.reach(&law.pair(pm, PairInertia::wall(r_max, 1.0))));
                }
            }
            reach
        }
    }
    dispatch(c, Reach(c, table, r_max))
}

/// Check that the case's `[contact]` section gives the keys its law needs
/// (and none that belong to another law), by building the law.
pub fn check_law(c: &ContactSection) -> Result<(), KeyError> {
    struct Check<'a>(&'a ContactSection);
    impl LawUser for Check<'_> {
        type Out = Result<(), KeyError>;
        fn with<L: ContactLaw>(self) -> Self::Out {
            L::from_case(self.0, &conventions::resolve(self.0)).map(|_| ())
        }
    }
    dispatch(c, Check(c))
}

/// A bad key of the case's `[contact]` section: which key, its value, and why
/// (the case names its file: "FILE: key = value: why").
#[derive(Clone, Debug, PartialEq)]
pub struct KeyError {
    pub key: String,
    pub value: String,
    pub why: String,
}

impl KeyError {
    pub fn new(key: &str, value: impl std::fmt::Display, why: &str) -> Self {
        KeyError { key: key.to_string(), value: value.to_string(), why: why.to_string() }
    }
}

/// Effective radius and mass of a pair: R* = R_i R_j / (R_i + R_j), m* likewise,
/// and sqrt(m*). A wall has infinite radius and mass: R* = R_i, m* = m_i. Fixed
/// for a pair, so the neighbour list computes it once per pair and per wall
/// candidate at each build (an ellipse's contact replaces R* by its own).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairInertia {
    pub r_eff: f64,
    pub m_eff: f64,
    pub sqrt_m_eff: f64,
}

impl PairInertia {
    #[inline(always)]
    pub fn particles(ri: f64, rj: f64, mi: f64, mj: f64) -> Self {
        let m_eff = mi * mj / (mi + mj);
        PairInertia { r_eff: ri * rj / (ri + rj), m_eff, sqrt_m_eff: m_eff.sqrt() }
    }
    /// What a law that reads neither R* nor m* is handed
    /// ([`ContactLaw::USES_INERTIA`] false): NaN, so that a misuse shows.
    pub const UNUSED: PairInertia = PairInertia { r_eff: f64::NAN, m_eff: f64::NAN, sqrt_m_eff: f64::NAN };
    #[inline(always)]
    pub fn wall(ri: f64, mi: f64) -> Self {
        PairInertia { r_eff: ri, m_eff: mi, sqrt_m_eff: mi.sqrt() }
    }
    /// Against a rigid wall curved with radius rw (a ball or the drag cylinder): R* = ri rw / (ri + rw).
    #[inline(always)]
    pub fn curved_wall(ri: f64, rw: f64, mi: f64) -> Self {
        PairInertia { r_eff: ri * rw / (ri + rw), m_eff: mi, sqrt_m_eff: mi.sqrt() }
    }
}

/// What a law's normal part yields for the current overlap: the elastic normal
/// force and the four coefficients that the shared normal-damping and tangential
/// code needs. Passed by value to the tangential stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalCoeffs {
    /// Elastic normal force (N), >= 0.
    pub f_elastic: f64,
    /// Normal damping coefficient (kg/s).
    pub gamma_n: f64,
    /// Tangential stiffness at this overlap (N/m).
    pub kt: f64,
    /// Tangential damping coefficient (kg/s).
    pub gamma_t: f64,
}

/// A contact law. Implemented by zero-sized or small `Copy` types so that the
/// force sweep is monomorphised once per law (static dispatch). A law gives its
/// normal part ([`ContactLaw::normal`]); the shared kernel [`evaluate`] adds the
/// normal dashpot, the end-of-contact convention, the tangential spring, dashpot
/// and Coulomb slider, and the torques r x F. A law with torques of its own
/// (rolling or twisting resistance) overrides [`ContactLaw::contact`].
pub trait ContactLaw: Copy + PartialEq + Send + Sync + 'static {
    /// The law's constants for one pair of bodies, functions of the mixed
    /// material, R* and m* only: computed once per pair (at the first sweep
    /// after each list build, kept in `NeighborList`), and per contact only
    /// where the geometry sets R* (ellipses). `()` for a law without any.
    type Pair: Copy + Send + Sync + 'static;

    /// Whether the law reads R* or m* (`pair`, `normal`). A law that does
    /// not (`false`) lets the pair sweep skip computing them per contact
    /// (two divisions and a square root), unless rolling resistance needs R*;
    /// the [`PairInertia`] it is handed then holds NaN.
    const USES_INERTIA: bool = true;

    /// Whether a contact, once made, goes on beyond zero overlap (JKR): the
    /// sweeps then ask [`ContactLaw::reach`] for pairs that touched at the
    /// last step. A law that does not (`false`) ends each contact at zero
    /// overlap, and its sweeps carry no trace of reach.
    const REACHES: bool = false;

    /// Whether the law's normal force pulls (its [`ContactLaw::pulloff`] is
    /// positive): its force is then never clipped at zero, and friction is
    /// capped by |F_el + 2 F_pulloff| unless the case says otherwise
    /// (`conventions::resolve`).
    const PULLS: bool = false;

    /// How far beyond contact (m, >= 0) a contact that touched at the last
    /// step still acts (JKR's pull-off separation).
    #[inline(always)]
    fn reach(&self, _pair: &Self::Pair) -> f64 {
        0.0
    }

    /// The pull-off force (N, > 0 for a law that pulls): the friction cap
    /// [`FrictionCap::Pulloff`] is mu |F_el + 2 F_pulloff|. 0 for a law
    /// that does not pull (that cap is then the total normal force's).
    #[inline(always)]
    fn pulloff(&self, _pair: &Self::Pair) -> f64 {
        0.0
    }

    /// The law as the case's `[contact]` section and the resolved conventions
    /// give it; a key it needs that is missing, a bad value, or a key of
    /// another law is an error.
    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError>;

    /// The constants of a pair with mixed material `pm` and R*, m* `pi`.
    fn pair(&self, pm: &PairMaterial, pi: PairInertia) -> Self::Pair;

    /// The normal part at this overlap: the elastic normal force and the
    /// damping and tangential coefficients.
    fn normal(&self, pm: &PairMaterial, pi: PairInertia, pair: &Self::Pair, overlap: f64) -> NormalCoeffs;

    /// Force on i and torques on both bodies (the shared kernel unless the law
    /// has its own torques).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn contact(
        &self,
        o: &ContactOptions,
        pm: &PairMaterial,
        pi: PairInertia,
        pair: &Self::Pair,
        g: &ContactGeom,
        m: &Motion,
        hist: &mut Vec3,
        roll: &mut Vec3,
        dt: f64,
    ) -> ContactForce {
        evaluate(*self, o, pm, pi, pair, g, m, hist, roll, dt)
    }
}

/// How the normal force behaves at the end of a contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum EndOfContact {
    /// The damped normal force may go slightly tensile as the bodies separate
    /// (LIGGGHTS `normal_model_hooke.h` / `normal_model_hertz.h` with the default
    /// `limitForce off`). Returns e_out = e_in for the linear dashpot.
    Tensile,
    /// The normal force is clipped at zero (YADE `Law2_ScGeom_ViscElPhys_Basic`,
    /// `Law2_ScGeom_MindlinPhys_Mindlin`). A clipped linear dashpot returns a larger
    /// e_out (Schwager and Poeschel 2007).
    Clip,
}

/// How tangential history is kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum TangentialHistory {
    /// LIGGGHTS `tangential history`: the history is the total shear displacement,
    /// projected onto the current tangent plane each step; the elastic force is the
    /// displacement times the *current* stiffness.
    Total,
    /// YADE: the history is the elastic shear force, rotated onto the current
    /// tangent plane and incremented by -k_t v_t dt with the current stiffness.
    Incremental,
    /// LAMMPS `pair_style granular` (`tangential linear_history` / `mindlin`):
    /// the total shear displacement, projected onto the current tangent plane
    /// and rescaled to its former length (where its normal part is more than
    /// 1e-10 of the cap), then incremented by v_t dt; the force
    /// -k_t s - gamma_t v_t, dashpot included, is capped, and at the cap the
    /// displacement is set back to the one that gives it.
    Rescaled,
}

/// Which normal force sets the Coulomb cap mu F.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum FrictionCap {
    /// mu |F_n| with F_n the total (elastic plus viscous) normal force (LIGGGHTS
    /// `tangential_model_history.h`). A tensile tail at the end of a contact adds
    /// friction, so in gross sliding the tangential impulse exceeds mu times the
    /// normal impulse.
    Total,
    /// mu F_el with F_el the elastic normal force (talus's own choice). The
    /// viscous normal force integrates to zero over a contact (gamma(delta)
    /// d delta/dt is an exact differential), so in gross sliding the tangential
    /// impulse is exactly mu times the normal impulse: Coulomb's law for the impact.
    Elastic,
    /// For a law that pulls (dmt, jkr), mu |F_el + 2 F_pulloff|, F_el the
    /// elastic normal force with its adhesion, F_pulloff the law's pull-off
    /// force (Thornton and Yin 1991; LAMMPS `pair_style granular` for jkr and
    /// dmt); for any other law as `total`.
    Pulloff,
}

/// Which relative velocity drives the shear spring.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ShearKinematics {
    /// The relative velocity of the two material points at the contact, spin arms
    /// r - delta/2 (LIGGGHTS `surface_model_default.h`).
    ContactPoint,
    /// YADE's shear increment (`ScGeom::getIncidentVel` with
    /// `avoidGranularRatcheting`): spin arms are the full radii and the
    /// translational part is scaled by alpha = (r_i + r_j) / (r_i + r_j - delta)
    /// (1 at a wall).
    FullRadii,
    /// The relative velocity at the contact with the bodies' full radii as
    /// spin arms and no other factor (LAMMPS `pair_style granular` and `fix
    /// wall/gran granular`).
    Radii,
}

impl TangentialHistory {
    /// The option's value in a case file.
    pub fn name(self) -> &'static str {
        match self {
            TangentialHistory::Total => "total",
            TangentialHistory::Incremental => "incremental",
            TangentialHistory::Rescaled => "rescaled",
        }
    }
}

impl FrictionCap {
    /// The option's value in a case file.
    pub fn name(self) -> &'static str {
        match self {
            FrictionCap::Total => "total",
            FrictionCap::Elastic => "elastic",
            FrictionCap::Pulloff => "pulloff",
        }
    }
}

impl ShearKinematics {
    /// The option's value in a case file.
    pub fn name(self) -> &'static str {
        match self {
            ShearKinematics::ContactPoint => "contact_point",
            ShearKinematics::FullRadii => "full_radii",
            ShearKinematics::Radii => "radii",
        }
    }
}

/// Options of the tangential stage, shared by every law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TangentialOptions {
    pub history: TangentialHistory,
    pub cap: FrictionCap,
    pub kinematics: ShearKinematics,
}

/// Result of one contact evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactForce {
    /// Total force on i (N); -force acts on j.
    pub force: Vec3,
    /// Torque on i about its centre (N m).
    pub torque_i: Vec3,
    /// Torque on j about its centre, or for a wall about the contact point (N m).
    pub torque_j: Vec3,
    /// Signed normal force on i along n (N); negative only with `EndOfContact::Tensile`.
    pub normal: f64,
}

/// The shared kernel: the law's normal part gives coefficients, this adds the
/// normal damping, the end-of-contact convention, the tangential spring,
/// dashpot and Coulomb slider, and the torques r x F. The relative velocity
/// at the contact point (its normal part drives the normal dashpot) and the
/// velocity that drives the shear spring (the same, or YADE's variant, see
/// [`ShearKinematics`]) come from the geometry and the bodies' motion. `hist`
/// is the law's history (m for `Total`, N for `Incremental`), zero at first
/// touch; `roll` the rolling spring's torque (N m) where the case's rolling
/// law keeps one (`epsd2`; untouched otherwise). `dt` is the time step (s).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn evaluate<L: ContactLaw>(
    law: L,
    o: &ContactOptions,
    pm: &PairMaterial,
    pi: PairInertia,
    pair: &L::Pair,
    g: &ContactGeom,
    m: &Motion,
    hist: &mut Vec3,
    roll: &mut Vec3,
    dt: f64,
) -> ContactForce {
    let (v_rel, v_shear) = g.velocities(o.tang.kinematics, m);
    let c = law.normal(pm, pi, pair, g.overlap);
    let vn = v_rel.dot(&g.n); // > 0 separating
    let mut f_n = c.f_elastic - c.gamma_n * vn;
    if o.end == EndOfContact::Clip && f_n < 0.0 {
        f_n = 0.0;
    }
    let v_t = v_shear - g.n * v_shear.dot(&g.n);
    // the normal force that caps friction (and the rolling spring's torque)
    let f_cap = match o.tang.cap {
        FrictionCap::Total => f_n.abs(),
        FrictionCap::Elastic => c.f_elastic,
        FrictionCap::Pulloff => match law.pulloff(pair) {
            p if p > 0.0 => (c.f_elastic + 2.0 * p).abs(),
            _ => f_n.abs(),
        },
    };
    let f_t = tangential(c, o.tang.history, pm.friction * f_cap, g.n, v_t, hist, dt);
    let force = g.n * f_n + f_t;
    let (mut torque_i, mut torque_j) = g.torques(force);
    if let Some(model) = o.rolling {
        if pm.rolling_friction > 0.0 {
            let t = match model {
                RollingModel::Cdt => rolling_torque(pm.rolling_friction, c.f_elastic, pi, g, m),
                RollingModel::Epsd2 => rolling_spring(pm.rolling_friction, c.kt, f_cap, o.rolling_wall_spin_scaled, pi, g, m, roll, dt),
            };
            torque_i -= t;
            torque_j += t;
        }
    }
    ContactForce { force, torque_i, torque_j, normal: f_n }
}

/// The rolling lever: the particle's radius against a wall (LIGGGHTS 3.8.0's
/// arm for both of its rolling laws), R* between two bodies.
#[inline(always)]
fn rolling_arm(pi: PairInertia, g: &ContactGeom) -> f64 {
    match g.lever {
        geometry::Lever::AlongNormal { radius_i, radius_j, .. } if radius_j == 0.0 => radius_i,
        _ => pi.r_eff,
    }
}

/// Elastic-plastic rolling spring (`contact.rolling = "epsd2"`, LIGGGHTS
/// `rolling_model_epsd2.h`): the stored torque `roll` plus k_r w_t dt, with
/// k_r = k_t R^2 (k_t the tangential stiffness at this overlap, R the rolling
/// arm) and w_t the relative spin w_i - w_j without its twisting part, capped
/// in magnitude at mu_r F R (F the normal force that caps friction: |F_n| in
/// LIGGGHTS's convention); the stored torque is not turned with the contact
/// (as in LIGGGHTS). No dashpot. Returned as the torque taken from i. Against
/// a wall, LIGGGHTS's convention scales the spin by arm / (r - delta)
/// (`wall_spin_scaled`, see [`ContactOptions`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn rolling_spring(
    mu_r: f64,
    kt: f64,
    f_cap: f64,
    wall_spin_scaled: bool,
    pi: PairInertia,
    g: &ContactGeom,
    m: &Motion,
    roll: &mut Vec3,
    dt: f64,
) -> Vec3 {
    let arm = rolling_arm(pi, g);
    let w = match g.lever {
        geometry::Lever::AlongNormal { arm_i, radius_i, radius_j, .. } if radius_j == 0.0 && wall_spin_scaled => {
            (m.w_i * arm_i) * (1.0 / (radius_i - g.overlap)) - m.w_j
        }
        _ => m.w_i - m.w_j,
    };
    let w_t = w - g.n * w.dot(&g.n);
    let mut t = *roll + w_t * (kt * arm * arm * dt);
    let cap = f_cap * arm * mu_r;
    let tm = t.norm();
    if tm > cap {
        t *= cap / tm;
    }
    *roll = t;
    t
}

/// Constant directional torque (`contact.rolling = "cdt"`, LIGGGHTS
/// `rolling_model_cdt.h`): magnitude mu_r F_el R against the relative spin
/// w_i - w_j, its twisting part (along n) removed; R = R* between two bodies,
/// the particle's radius against a wall (LIGGGHTS 3.8.0's arm: measured
/// against its deck, `cases/SC-rolling.toml`). F_el is the elastic normal
/// force. Returned as the torque taken from i (and given to j).
#[inline(always)]
fn rolling_torque(mu_r: f64, f_el: f64, pi: PairInertia, g: &ContactGeom, m: &Motion) -> Vec3 {
    let w = m.w_i - m.w_j;
    let wm = w.norm();
    if wm == 0.0 || f_el <= 0.0 {
        return Vec3::zeros();
    }
    let arm = rolling_arm(pi, g);
    let t = w * (mu_r * f_el * arm / wm);
    t - g.n * t.dot(&g.n)
}

/// Tangential spring-dashpot with a Coulomb slider. `cap` bounds the elastic
/// part; while sliding the dashpot is off, so the tangential force never exceeds
/// the cap (LIGGGHTS `tangential_model_history.h`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn tangential(
    c: NormalCoeffs,
    mode: TangentialHistory,
    cap: f64,
    n: Vec3,
    v_t: Vec3,
    hist: &mut Vec3,
    dt: f64,
) -> Vec3 {
    // project the stored history onto the current tangent plane (LIGGGHTS:
    // projection only, no rescaling; YADE rotates, which differs at second order)
    let h_t = *hist - n * n.dot(hist);
    match mode {
        TangentialHistory::Total => {
            let s = h_t + v_t * dt;
            let f_el = -c.kt * s;
            let fe2 = f_el.norm_squared();
            if fe2 > cap * cap {
                let fe = fe2.sqrt();
                if fe > 0.0 {
                    let f = f_el * (cap / fe);
                    *hist = if c.kt > 0.0 { -f / c.kt } else { Vec3::zeros() };
                    f
                } else {
                    *hist = Vec3::zeros();
                    Vec3::zeros()
                }
            } else {
                *hist = s;
                f_el - c.gamma_t * v_t
            }
        }
        TangentialHistory::Rescaled => {
            // LAMMPS: the stored displacement is turned into the tangent plane
            // (projected, then rescaled to its length) only where its normal
            // part would matter: |s.n| k_t > 1e-10 mu F
            let mut s = *hist;
            let sn = n.dot(&s);
            if sn.abs() * c.kt > 1e-10 * cap {
                let m = s.norm();
                s -= n * sn;
                let p = s.norm();
                s *= if p > 0.0 { m / p } else { 0.0 };
            }
            s += v_t * dt;
            // the cap on the whole force, dashpot included; at the cap the
            // displacement is the one that gives it
            let f = -c.kt * s - c.gamma_t * v_t;
            let f2 = f.norm_squared();
            if f2 > cap * cap {
                if s != Vec3::zeros() {
                    let f = f * (cap / f2.sqrt());
                    *hist = -(f + c.gamma_t * v_t) / c.kt;
                    f
                } else {
                    *hist = s;
                    Vec3::zeros()
                }
            } else {
                *hist = s;
                f
            }
        }
        TangentialHistory::Incremental => {
            let f_el = h_t - c.kt * dt * v_t;
            let fe2 = f_el.norm_squared();
            if fe2 > cap * cap {
                let fe = fe2.sqrt();
                let f = if fe > 0.0 { f_el * (cap / fe) } else { Vec3::zeros() };
                *hist = f;
                f
            } else {
                *hist = f_el;
                f_el - c.gamma_t * v_t
            }
        }
    }
}

/// YADE's shear-driving velocity: alpha (v_i - v_j) - (r_i w_i + r_j w_j) x n with
/// full radii; `r_j` = 0 and alpha = 1 for a wall.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn yade_shear_velocity(n: Vec3, overlap: f64, r_i: f64, r_j: f64, v_i: Vec3, v_j: Vec3, w_i: Vec3, w_j: Vec3) -> Vec3 {
    let alpha = if r_j > 0.0 { (r_i + r_j) / (r_i + r_j - overlap) } else { 1.0 };
    (v_i - v_j) * alpha - (w_i * r_i + w_j * r_j).cross(&n)
}

/// The convention used to fill unspecified options: one reference code's as a
/// whole, or talus's own (LIGGGHTS's, but with the Coulomb cap on the elastic
/// normal force, see [`FrictionCap`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Convention {
    #[default]
    Talus,
    Liggghts,
    Yade,
    Lammps,
}

#[cfg(test)]
mod tests;
