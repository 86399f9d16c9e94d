//! `hooke`: linear spring-dashpot, normal and tangential, with a Coulomb slider
//! (the hopper paper's model).
//!
//! F_n = k_n delta - gamma_n v_n,  F_t = -k_t s - gamma_t v_t, |F_t| <= mu |F_n|.
//!
//! Stiffness and damping are either given explicitly (absolute values, N/m and
//! kg/s) or derived from E, nu, e and a characteristic velocity V exactly as
//! LIGGGHTS 3.8 `model hooke` does (`normal_model_hooke.h`):
//!
//! k_n = 16/15 sqrt(R*) Y* (15 m* V^2 / (16 sqrt(R*) Y*))^(1/5),
//! gamma_n = sqrt(4 m* k_n / (1 + (pi / ln e)^2)),  k_t = k_n,  gamma_t = gamma_n.
//!
//! k_n is the linear spring whose peak overlap at impact speed V equals Hertz's.
//! Undamped, a contact lasts pi sqrt(m*/k_n); with the tensile end-of-contact
//! convention the restitution is exactly e.

use super::{ContactLaw, ContactOptions, KeyError, NormalCoeffs, PairInertia};
use crate::case::ContactSection;
use crate::material::PairMaterial;
use serde::{Deserialize, Serialize};

/// Explicit linear spring-dashpot coefficients (absolute).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct HookeExplicit {
    /// Normal stiffness (N/m).
    pub kn: f64,
    /// Tangential stiffness (N/m).
    pub kt: f64,
    /// Normal damping coefficient (kg/s).
    pub gamma_n: f64,
    /// Tangential damping coefficient (kg/s).
    pub gamma_t: f64,
}

/// The linear law, with its coefficients either explicit or derived per pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hooke {
    Explicit(HookeExplicit),
    /// Derived as LIGGGHTS does, at this characteristic velocity (m/s).
    Derived { characteristic_velocity: f64 },
}

/// LIGGGHTS's damping for a linear spring: gamma = sqrt(4 m* k / (1 + (pi/ln e)^2)).
/// This is 2 zeta sqrt(m* k) with zeta = -ln e / sqrt(ln^2 e + pi^2): the
/// dashpot that gives restitution e when the force may go tensile.
#[inline]
pub fn damping_for_restitution(m_eff: f64, k: f64, e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let l = e.ln();
    (4.0 * m_eff * k / (1.0 + (std::f64::consts::PI / l).powi(2))).sqrt()
}

/// LIGGGHTS's `model hooke` stiffness at characteristic velocity `v` (N/m), from
/// Y* (Pa), R* (m), m* (kg) and V (m/s).
///
/// ```
/// // a 2 mm seed-soft sphere (m = 8.378e-5 kg) on a seed-soft wall at 0.5 m/s:
/// // Y* = 1e6 / (2 (1 - 0.3^2)) = 549451 Pa
/// let kn = talus::contact::hooke::liggghts_kn(549_450.549, 0.002, 8.37758e-5, 0.5);
/// assert!((kn - 397.18).abs() < 0.01, "{kn}");
/// // the peak overlap V sqrt(m*/kn) = 0.229 mm is Hertz's at 0.5 m/s
/// ```
#[inline]
pub fn liggghts_kn(y_eff: f64, r_eff: f64, m_eff: f64, v: f64) -> f64 {
    let s = r_eff.sqrt();
    16.0 / 15.0 * s * y_eff * (15.0 * m_eff * v * v / (16.0 * s * y_eff)).powf(0.2)
}

impl Hooke {
    /// The four coefficients for one pair.
    pub fn coefficients(&self, pm: &PairMaterial, pi: PairInertia) -> HookeExplicit {
        match *self {
            Hooke::Explicit(h) => h,
            Hooke::Derived { characteristic_velocity } => {
                let kn = liggghts_kn(pm.y_eff, pi.r_eff, pi.m_eff, characteristic_velocity);
                let g = damping_for_restitution(pi.m_eff, kn, pm.restitution);
                HookeExplicit { kn, kt: kn, gamma_n: g, gamma_t: g }
            }
        }
    }
}

impl ContactLaw for Hooke {
    /// k_n, k_t, gamma_n, gamma_t of the pair: derived once per pair (the
    /// powf and log are not taken per contact and step).
    type Pair = HookeExplicit;

    /// `model = "hooke"` takes exactly one of `stiffness` (explicit) and
    /// `characteristic_velocity` (derived).
    fn from_case(c: &ContactSection, _o: &ContactOptions) -> Result<Self, KeyError> {
        if let Some(g) = c.surface_energy {
            return Err(KeyError::new("contact.surface_energy", g, "the hooke law does not pull: a surface energy belongs to the dmt and jkr models"));
        }
        if let Some(d) = c.damping {
            return Err(KeyError::new(
                "contact.damping",
                format!("\"{}\"", d.name()),
                "the hooke law's damping comes from restitution (or contact.stiffness's gamma_n, gamma_t), not from a hertz damping mapping",
            ));
        }
        match (c.stiffness, c.characteristic_velocity) {
            (Some(h), None) => {
                for (k, v) in [("kn", h.kn), ("kt", h.kt), ("gamma_n", h.gamma_n), ("gamma_t", h.gamma_t)] {
                    if !(v.is_finite() && v >= 0.0) || (k == "kn" && v == 0.0) {
                        return Err(KeyError::new(&format!("contact.stiffness.{k}"), v, "must be a finite positive number"));
                    }
                }
                Ok(Hooke::Explicit(h))
            }
            (None, Some(v)) if v > 0.0 && v.is_finite() => Ok(Hooke::Derived { characteristic_velocity: v }),
            (None, Some(v)) => Err(KeyError::new("contact.characteristic_velocity", v, "must be a positive speed (m/s)")),
            _ => Err(KeyError::new(
                "contact.model",
                "\"hooke\"",
                "give exactly one of contact.stiffness (kn, kt, gamma_n, gamma_t) and contact.characteristic_velocity",
            )),
        }
    }

    #[inline(always)]
    fn pair(&self, pm: &PairMaterial, pi: PairInertia) -> HookeExplicit {
        self.coefficients(pm, pi)
    }

    #[inline(always)]
    fn normal(&self, _pm: &PairMaterial, _pi: PairInertia, h: &HookeExplicit, overlap: f64) -> NormalCoeffs {
        NormalCoeffs { f_elastic: h.kn * overlap, gamma_n: h.gamma_n, kt: h.kt, gamma_t: h.gamma_t }
    }
}

/// `hooke` with explicit `stiffness`: the same law as [`Hooke::Explicit`],
/// with its one set of coefficients held by the law instead of copied to
/// every pair. The sweep then reads no per-pair constants (32 bytes a pair
/// and step) and computes no R*, m* per contact; the arithmetic, and so every
/// result, is that of `Hooke::Explicit` to the bit.
impl ContactLaw for HookeExplicit {
    type Pair = ();

    const USES_INERTIA: bool = false;

    /// The keys `Hooke` takes; only its explicit form is this law.
    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError> {
        match Hooke::from_case(c, o)? {
            Hooke::Explicit(h) => Ok(h),
            Hooke::Derived { characteristic_velocity } => Err(KeyError::new(
                "contact.characteristic_velocity",
                characteristic_velocity,
                "the explicit hooke law takes contact.stiffness, not a characteristic velocity",
            )),
        }
    }

    #[inline(always)]
    fn pair(&self, _pm: &PairMaterial, _pi: PairInertia) {}

    #[inline(always)]
    fn normal(&self, _pm: &PairMaterial, _pi: PairInertia, _pair: &(), overlap: f64) -> NormalCoeffs {
        NormalCoeffs { f_elastic: self.kn * overlap, gamma_n: self.gamma_n, kt: self.kt, gamma_t: self.gamma_t }
    }
}
