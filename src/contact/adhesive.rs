//! `dmt` and `jkr`: normal laws that pull, as LAMMPS 29Sep2021's `pair_style
//! granular` computes them (its `dmt` and `jkr` normal models; the formulas
//! and what the binary does are in docs/cohesion-in-the-reference-codes.md).
//! gamma is the surface energy (J/m^2, LAMMPS's `cohesion`; the work of
//! adhesion is w = 2 gamma), E* and R* the pair's effective modulus and radius.
//!
//! - **DMT** (Derjaguin, Muller and Toporov 1975): Hertz's force less a
//!   constant adhesion while the bodies overlap,
//!   F = 4/3 E* sqrt(R*) delta^(3/2) - 4 pi gamma R*.
//!   The pull-off force is 4 pi gamma R*, reached as the overlap goes to zero,
//!   where the contact ends.
//! - **JKR** (Johnson, Kendall and Roberts 1971): the contact radius a follows
//!   from the overlap by delta = a^2 / R* - 2 sqrt(pi gamma a / E*), and
//!   F = 4/3 E* a^3 / R* - sqrt(16 pi gamma E* a^3).
//!   A contact starts when the bodies touch (delta = 0, where a is already
//!   finite: the force jumps to a pull) and goes on pulling beyond contact
//!   until delta reaches delta_c = a_c^2 / R* - 2 sqrt(pi gamma a_c / E*) < 0,
//!   a_c^3 = 9 pi gamma R*^2 / (4 E*), where the force is the least,
//!   -3 pi gamma R*: the pull-off force. There the contact ends (as in
//!   LAMMPS; the displacement-controlled JKR branch beyond it is not followed).
//!
//! Both give the friction cap mu |F_el + 2 F_pulloff| where the convention
//! caps friction that way ([`super::FrictionCap::Pulloff`], Thornton's and
//! LAMMPS's), the tangential stiffness 8 G* a (Mindlin) and Hertz's damping
//! with the contact radius a in place of sqrt(R* delta).

use super::{ContactLaw, ContactOptions, KeyError, NormalCoeffs, PairInertia};
use crate::case::ContactSection;
use crate::material::PairMaterial;
use std::f64::consts::PI;

/// The surface energy of the case: given, finite and positive, and the keys
/// of the other laws absent.
fn surface_energy(c: &ContactSection, model: &str) -> Result<f64, KeyError> {
    if c.stiffness.is_some() || c.characteristic_velocity.is_some() {
        return Err(KeyError::new(
            "contact.model",
            format!("\"{model}\""),
            "contact.stiffness and contact.characteristic_velocity belong to the hooke model",
        ));
    }
    if c.end_of_contact == Some(super::EndOfContact::Clip) {
        return Err(KeyError::new(
            "contact.end_of_contact",
            "\"clip\"",
            &format!("the {model} law pulls: a normal force clipped at zero would remove its adhesion"),
        ));
    }
    if c.friction_cap == Some(super::FrictionCap::Elastic) {
        return Err(KeyError::new(
            "contact.friction_cap",
            "\"elastic\"",
            &format!("the {model} law's elastic normal force goes negative as it pulls; its friction is capped by \"pulloff\" (|F_el + 2 F_pulloff|) or \"total\""),
        ));
    }
    match c.surface_energy {
        Some(g) if g.is_finite() && g > 0.0 => Ok(g),
        Some(g) => Err(KeyError::new("contact.surface_energy", g, "the surface energy must be a positive number of J/m^2")),
        None => Err(KeyError::new(
            "contact.model",
            format!("\"{model}\""),
            "give contact.surface_energy (J/m^2, gamma: the pull-off force is 4 pi gamma R* for dmt, 3 pi gamma R* for jkr)",
        )),
    }
}

/// Hertz's damping and tangential coefficients at contact radius `a`
/// (the same arithmetic as [`super::hertz::Hertz`], a = sqrt(R* delta) there).
#[inline(always)]
fn hertz_like(o_damping: usize, pm: &PairMaterial, pi: PairInertia, a: f64, f_elastic: f64) -> NormalCoeffs {
    let kt = 8.0 * pm.g_eff * a;
    let [cn, ct] = pm.hertz_damping[o_damping];
    let q = pi.sqrt_m_eff * a.sqrt();
    NormalCoeffs { f_elastic, gamma_n: cn * q, kt, gamma_t: ct * q }
}

/// `model = "dmt"`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dmt {
    /// gamma (J/m^2).
    pub surface_energy: f64,
    /// Which of `PairMaterial::hertz_damping`'s mappings.
    damping: usize,
}

impl ContactLaw for Dmt {
    /// The pull-off force 4 pi gamma R* (N).
    type Pair = f64;

    const PULLS: bool = true;

    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError> {
        Ok(Dmt { surface_energy: surface_energy(c, "dmt")?, damping: o.damping.index() })
    }

    #[inline(always)]
    fn pair(&self, _pm: &PairMaterial, pi: PairInertia) -> f64 {
        4.0 * PI * self.surface_energy * pi.r_eff
    }

    #[inline(always)]
    fn normal(&self, pm: &PairMaterial, pi: PairInertia, pulloff: &f64, overlap: f64) -> NormalCoeffs {
        let a = (pi.r_eff * overlap).sqrt();
        let f_elastic = 4.0 / 3.0 * pm.y_eff * a * overlap - pulloff;
        hertz_like(self.damping, pm, pi, a, f_elastic)
    }

    #[inline(always)]
    fn pulloff(&self, pulloff: &f64) -> f64 {
        *pulloff
    }
}

/// `model = "jkr"`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jkr {
    /// gamma (J/m^2).
    pub surface_energy: f64,
    damping: usize,
}

/// JKR's constants of one pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JkrPair {
    /// R* (m).
    pub r_eff: f64,
    /// c = sqrt(pi gamma / E*) (m^(1/2)): delta = a^2 / R* - 2 c sqrt(a).
    pub c: f64,
    /// How far beyond contact a contact pulls: -delta_c (m, > 0).
    pub reach: f64,
    /// The pull-off force 3 pi gamma R* (N).
    pub pulloff: f64,
}

impl Jkr {
    /// The pair's constants for E* `y_eff` (Pa) and R* `r_eff` (m).
    pub fn constants(&self, y_eff: f64, r_eff: f64) -> JkrPair {
        let g = self.surface_energy;
        let c = (PI * g / y_eff).sqrt();
        let a_c = (9.0 * PI * g * r_eff * r_eff / (4.0 * y_eff)).cbrt();
        let delta_c = a_c * a_c / r_eff - 2.0 * c * a_c.sqrt();
        JkrPair { r_eff, c, reach: -delta_c, pulloff: 3.0 * PI * g * r_eff }
    }
}

/// The JKR contact radius a (m) at overlap `delta` (m; negative beyond
/// contact, down to -reach): the root of delta = a^2 / R - 2 c sqrt(a) on the
/// branch of the larger a. With x = sqrt(a) it is the quartic
/// x^4 - 2 R c x - R delta = 0, solved by Ferrari's resolvent cubic
/// s^3 + R delta s - (R c)^2 / 2 = 0 (one real root s > 0 on this branch:
/// Cardano's A = cbrt(Q + sqrt(Q^2 + P^3)), P = R delta / 3, Q = (R c)^2 / 4,
/// and s = 2 Q / (A^2 + P + (P / A)^2), the form without cancellation); then
/// (x^2 + s)^2 = 2 s (x + R c / (2 s))^2 gives
/// x = (w + sqrt(4 R c / w - w^2)) / 2, w = sqrt(2 s).
///
/// ```
/// use talus::contact::adhesive::jkr_radius;
/// // R = 0.5 mm, c = sqrt(pi 0.05 / 5.333e6)
/// let (r, c) = (5e-4, (std::f64::consts::PI * 0.05 / 5.333e6f64).sqrt());
/// for delta in [-2e-7, 0.0, 1e-6, 1e-4] {
///     let a = jkr_radius(r, c, delta);
///     let back = a * a / r - 2.0 * c * a.sqrt();
///     assert!((back - delta).abs() < 1e-12 * r, "{delta}: {back}");
/// }
/// ```
#[inline(always)]
pub fn jkr_radius(r: f64, c: f64, delta: f64) -> f64 {
    let rc = r * c;
    let p = r * delta / 3.0;
    let q = 0.25 * rc * rc;
    let root = (q * q + p * p * p).max(0.0).sqrt();
    let a3 = (q + root).cbrt();
    let pa = p / a3;
    let s = 2.0 * q / (a3 * a3 + p + pa * pa);
    let w = (2.0 * s).sqrt();
    let x = 0.5 * (w + (4.0 * rc / w - w * w).max(0.0).sqrt());
    x * x
}

impl ContactLaw for Jkr {
    type Pair = JkrPair;

    const REACHES: bool = true;
    const PULLS: bool = true;

    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError> {
        Ok(Jkr { surface_energy: surface_energy(c, "jkr")?, damping: o.damping.index() })
    }

    #[inline(always)]
    fn pair(&self, pm: &PairMaterial, pi: PairInertia) -> JkrPair {
        self.constants(pm.y_eff, pi.r_eff)
    }

    #[inline(always)]
    fn normal(&self, pm: &PairMaterial, pi: PairInertia, k: &JkrPair, overlap: f64) -> NormalCoeffs {
        let a = jkr_radius(k.r_eff, k.c, overlap);
        let a15 = a * a.sqrt();
        let f_elastic = pm.y_eff * (4.0 / 3.0 * a * a * a / k.r_eff - 4.0 * k.c * a15);
        hertz_like(self.damping, pm, pi, a, f_elastic)
    }

    #[inline(always)]
    fn reach(&self, k: &JkrPair) -> f64 {
        k.reach
    }

    #[inline(always)]
    fn pulloff(&self, k: &JkrPair) -> f64 {
        k.pulloff
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// a from delta by bisection on a^2/R - 2 c sqrt(a) (increasing for a
    /// above (R c / 2)^(2/3), the branch the law follows).
    fn bisect(r: f64, c: f64, delta: f64) -> f64 {
        let f = |a: f64| a * a / r - 2.0 * c * a.sqrt() - delta;
        let mut lo = (r * c / 2.0).powf(2.0 / 3.0);
        let mut hi = lo + (r * delta.abs()).sqrt() * 10.0 + r;
        for _ in 0..300 {
            let m = 0.5 * (lo + hi);
            if f(m) > 0.0 {
                hi = m
            } else {
                lo = m
            }
        }
        0.5 * (lo + hi)
    }

    #[test]
    fn the_contact_radius_solves_the_jkr_overlap_relation_from_pull_off_to_deep_overlap() {
        let law = Jkr { surface_energy: 0.05, damping: 0 };
        for (y, r) in [(5.333e6, 5e-4), (1e9, 1e-3), (6.9e10, 2e-5), (1e6, 2e-3)] {
            let k = law.constants(y, r);
            assert!(k.reach > 0.0);
            for f in [-1.0, -0.999, -0.5, 0.0, 1e-9, 1e-3, 1.0, 1e3, 1e6] {
                let delta = if f < 0.0 { f * k.reach } else { f * k.reach.max(1e-12) };
                let (a, want) = (jkr_radius(r, k.c, delta), bisect(r, k.c, delta));
                assert!((a - want).abs() <= 1e-11 * want, "E* {y} R {r} delta {delta}: {a} against {want}");
            }
        }
    }

    #[test]
    fn the_force_at_the_end_of_the_reach_is_the_pull_off_force_3_pi_gamma_r() {
        let law = Jkr { surface_energy: 0.05, damping: 0 };
        let pm = PairMaterial { y_eff: 1e7 / (2.0 * (1.0 - 0.0625)), ..PairMaterial::default() };
        let pi = PairInertia { r_eff: 5e-4, m_eff: 1e-6, sqrt_m_eff: 1e-3 };
        let k = law.pair(&pm, pi);
        let f = law.normal(&pm, pi, &k, -k.reach).f_elastic;
        assert!((f + k.pulloff).abs() <= 1e-9 * k.pulloff, "{f} against -{}", k.pulloff);
        // the least force over the reach: a little inside it the pull is smaller
        for s in [0.9, 0.99, 1.01] {
            assert!(law.normal(&pm, pi, &k, -s * k.reach).f_elastic > f);
        }
        // LAMMPS 29Sep2021, two spheres R = 1 mm, E = 1e7, nu = 0.25, delta = 1e-4: 0.1588509 N
        let f = law.normal(&pm, pi, &k, 1e-4).f_elastic;
        assert!((f - 0.1588509).abs() < 2e-6, "{f}");
    }

    #[test]
    fn dmt_is_hertz_less_4_pi_gamma_r() {
        let law = Dmt { surface_energy: 0.05, damping: 0 };
        let pm = PairMaterial { y_eff: 1e7 / (2.0 * (1.0 - 0.0625)), ..PairMaterial::default() };
        let pi = PairInertia { r_eff: 5e-4, m_eff: 1e-6, sqrt_m_eff: 1e-3 };
        let p = law.pair(&pm, pi);
        // LAMMPS 29Sep2021: 0.1586951 N at delta = 1e-4
        let f = law.normal(&pm, pi, &p, 1e-4).f_elastic;
        assert!((f - 0.1586951).abs() < 1e-6, "{f}");
        assert!((law.pulloff(&p) - 4.0 * PI * 0.05 * 5e-4).abs() < 1e-18);
    }
}
