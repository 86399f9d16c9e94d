//! Cohesion: an attractive normal force added to the contact law's, as
//! LIGGGHTS 3.8's cohesion sub-models compute it (`cohesion_model_sjkr.h`,
//! `cohesion_model_sjkr2.h`, "simplified JKR"):
//!
//! F_coh = -k A  (along the normal towards i: it pulls the bodies together),
//!
//! k the cohesion energy density (J/m^3, LIGGGHTS's `cohesionEnergyDensity`)
//! and A a contact area from the undeformed spheres' overlap:
//!
//! - `sjkr`: the area of the circle in which the two sphere surfaces intersect,
//!   A = pi a^2 with a^2 = (r^2 - (R_i - R_j)^2) ((R_i + R_j)^2 - r^2) / (4 r^2),
//!   r the distance of the centres; against a wall (R_j infinite, r the
//!   centre's distance to the wall) A = pi (R_i^2 - r^2). For a small overlap
//!   delta, A ~ 2 pi R* delta.
//! - `sjkr2`: A = 2 pi (2 R*) delta between two spheres (the surface of the
//!   overlap lens); against a wall A = 2 pi R_i delta, half the pair form's
//!   limit, as LIGGGHTS 3.8 writes it.
//!
//! It acts only while the bodies overlap, so it goes to zero with the overlap:
//! no pull-off jump and no reach beyond contact. As in LIGGGHTS (its default
//! `tangential_reduce off`) it does not enter the normal force that caps
//! friction, nor the rolling laws' normal force: those see the contact law's
//! own normal force. It acts between spheres and against every wall (planes,
//! meshes, balls: a wall is a body of infinite radius).

use super::geometry::{ContactGeom, Lever, Motion};
use super::{ContactForce, ContactLaw, ContactOptions, KeyError, NormalCoeffs, PairInertia};
use crate::case::ContactSection;
use crate::material::PairMaterial;
use crate::dim::Vec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The cohesion sub-model (`[contact] cohesion = { model = "sjkr", energy_density = K }`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Cohesion {
    pub model: CohesionModel,
    /// k (J/m^3): the force is k times the contact area.
    pub energy_density: f64,
}

/// Which contact area the cohesive force is proportional to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum CohesionModel {
    /// The intersection circle of the undeformed spheres (LIGGGHTS `cohesion sjkr`).
    Sjkr,
    /// The overlap lens's surface, 2 pi (2 R*) delta (LIGGGHTS `cohesion sjkr2`).
    Sjkr2,
}

impl CohesionModel {
    /// The model's name in a case file (and in LIGGGHTS's `cohesion` keyword).
    pub fn name(self) -> &'static str {
        match self {
            CohesionModel::Sjkr => "sjkr",
            CohesionModel::Sjkr2 => "sjkr2",
        }
    }
}

impl Cohesion {
    /// The values a case may give: k finite and not negative.
    pub fn check(&self) -> Result<(), KeyError> {
        let k = self.energy_density;
        if !(k.is_finite() && k >= 0.0) {
            return Err(KeyError::new("contact.cohesion.energy_density", k, "the cohesion energy density must be a finite number of J/m^3, 0 or more"));
        }
        Ok(())
    }

    /// The contact area A (m^2) of two spheres of radii `r_i`, `r_j` overlapping
    /// by `overlap` (> 0); `r_j` = 0 for a wall. LIGGGHTS's formulas, with its
    /// factors r - R_i - R_j (= -delta) and R_i^2 - r^2 (= delta (2 R_i - delta),
    /// a wall) written with the overlap itself: the same values without the
    /// cancellation of two nearly equal lengths at a small overlap.
    ///
    /// ```
    /// use talus::contact::cohesion::{Cohesion, CohesionModel};
    /// let c = Cohesion { model: CohesionModel::Sjkr2, energy_density: 1e5 };
    /// // 2 pi (2 R*) delta: R* = 0.5 mm, delta = 0.1 mm
    /// assert!((c.area(1e-3, 1e-3, 1e-4) - 2.0 * std::f64::consts::PI * 1e-3 * 1e-4).abs() < 1e-18);
    /// // the force: -k A = -0.0628 N
    /// assert!((c.force(1e-3, 1e-3, 1e-4) + 0.06283185).abs() < 1e-8);
    /// ```
    #[inline(always)]
    pub fn area(&self, r_i: f64, r_j: f64, overlap: f64) -> f64 {
        match (self.model, r_j > 0.0) {
            (CohesionModel::Sjkr, true) => {
                let r = r_i + r_j - overlap;
                PI / 4.0 * (overlap * (r + r_i - r_j) * (r - r_i + r_j) * (r + r_i + r_j)) / (r * r)
            }
            (CohesionModel::Sjkr, false) => overlap * (2.0 * r_i - overlap) * PI,
            (CohesionModel::Sjkr2, true) => PI * 2.0 * (2.0 * r_i * r_j / (r_i + r_j)) * overlap,
            (CohesionModel::Sjkr2, false) => PI * 2.0 * r_i * overlap,
        }
    }

    /// Add the cohesive force to a contact's force (spheres only: the case
    /// refuses cohesion for other shapes; while the bodies overlap: a law
    /// that reaches beyond touching pulls there by itself). A force along the
    /// normal through the centres adds no torque.
    #[inline(always)]
    pub fn add_to(&self, c: &mut ContactForce, g: &ContactGeom) {
        if let (Lever::AlongNormal { radius_i, radius_j, .. }, true) = (g.lever, g.overlap > 0.0) {
            let f = self.force(radius_i, radius_j, g.overlap);
            c.force += g.n * f;
            c.normal += f;
        }
    }

    /// The cohesive normal force on i (N, negative: towards j).
    #[inline(always)]
    pub fn force(&self, r_i: f64, r_j: f64, overlap: f64) -> f64 {
        -self.energy_density * self.area(r_i, r_j, overlap)
    }
}

/// A contact law with cohesion: the law's force and torques, then -k A along
/// the normal (`contact::dispatch` wraps the case's law in it where
/// `contact.cohesion` is given, so the sweeps without cohesion are compiled
/// without it). A force along the normal through the centres adds no torque.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cohesive<L: ContactLaw> {
    pub law: L,
    pub cohesion: Cohesion,
}

impl<L: ContactLaw> ContactLaw for Cohesive<L> {
    type Pair = L::Pair;
    const USES_INERTIA: bool = L::USES_INERTIA;
    const REACHES: bool = L::REACHES;
    const PULLS: bool = L::PULLS;

    #[inline(always)]
    fn reach(&self, pair: &Self::Pair) -> f64 {
        self.law.reach(pair)
    }

    #[inline(always)]
    fn pulloff(&self, pair: &Self::Pair) -> f64 {
        self.law.pulloff(pair)
    }

    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError> {
        let cohesion = c.cohesion.ok_or_else(|| KeyError::new("contact.cohesion", "(none)", "a cohesive law needs contact.cohesion"))?;
        cohesion.check()?;
        Ok(Cohesive { law: L::from_case(c, o)?, cohesion })
    }

    #[inline(always)]
    fn pair(&self, pm: &PairMaterial, pi: PairInertia) -> Self::Pair {
        self.law.pair(pm, pi)
    }

    #[inline(always)]
    fn normal(&self, pm: &PairMaterial, pi: PairInertia, pair: &Self::Pair, overlap: f64) -> NormalCoeffs {
        self.law.normal(pm, pi, pair, overlap)
    }

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
        let mut c = self.law.contact(o, pm, pi, pair, g, m, hist, roll, dt);
        self.cohesion.add_to(&mut c, g);
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pi a^2 from the spherical cap the other sphere cuts from sphere i (the
    /// closed form, derived apart from `area`): the circle's plane lies at
    /// x = (d^2 + r_i^2 - r_j^2) / (2 d) from i's centre, so the cap's height
    /// is h = r_i - x = delta (r_j - r_i + d) / (2 d), and a^2 = h (2 r_i - h).
    fn circle(r_i: f64, r_j: f64, overlap: f64) -> f64 {
        let d = r_i + r_j - overlap;
        let h = overlap * (r_j - r_i + d) / (2.0 * d);
        PI * h * (2.0 * r_i - h)
    }

    #[test]
    fn sjkr_is_the_intersection_circle_of_the_undeformed_spheres_at_every_overlap() {
        let c = Cohesion { model: CohesionModel::Sjkr, energy_density: 3.0e5 };
        for (ri, rj) in [(1e-3f64, 1e-3f64), (1e-3, 2.5e-3), (2.35e-3, 1.95e-3)] {
            for f in [1e-9, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 0.3] {
                let d = f * ri.min(rj);
                let want = circle(ri, rj, d);
                assert!((c.area(ri, rj, d) - want).abs() <= 1e-12 * want, "{ri} {rj} {d}: {} against {want}", c.area(ri, rj, d));
                assert!((c.force(ri, rj, d) + 3.0e5 * want).abs() <= 1e-12 * 3.0e5 * want);
            }
        }
    }

    #[test]
    fn sjkr_against_a_wall_is_the_limit_of_an_ever_larger_partner() {
        let c = Cohesion { model: CohesionModel::Sjkr, energy_density: 1.0 };
        let (ri, d) = (2e-3, 1e-4);
        // the circle a plane cuts from the sphere: pi (2 r delta - delta^2)
        let wall = PI * (2.0 * ri * d - d * d);
        assert!((c.area(ri, 0.0, d) - wall).abs() <= 1e-12 * wall);
        let far = c.area(ri, 1e3, d);
        assert!((far - wall).abs() <= 1e-5 * wall, "{far} against {wall}");
    }

    #[test]
    fn sjkr2_is_the_overlap_lens_and_half_its_limit_at_a_wall() {
        let c = Cohesion { model: CohesionModel::Sjkr2, energy_density: 1.0 };
        for (ri, rj, d) in [(1e-3, 1e-3, 1e-5), (1e-3, 3e-3, 2e-4), (2e-3, 1.5e-3, 4e-4)] {
            let r_eff = ri * rj / (ri + rj);
            let want = 4.0 * PI * r_eff * d;
            assert!((c.area(ri, rj, d) - want).abs() <= 1e-12 * want);
        }
        // a wall: 2 pi R delta (LIGGGHTS 3.8), not the pair form's limit 4 pi R delta
        assert!((c.area(2e-3, 0.0, 1e-4) - 2.0 * PI * 2e-3 * 1e-4).abs() <= 1e-12 * 2.0 * PI * 2e-7);
        // for a small overlap sjkr's circle is about half sjkr2's lens
        let s = Cohesion { model: CohesionModel::Sjkr, energy_density: 1.0 };
        let ratio = s.area(1e-3, 1e-3, 1e-7) / c.area(1e-3, 1e-3, 1e-7);
        assert!((ratio - 0.5).abs() < 1e-3, "{ratio}");
    }

    #[test]
    fn a_bad_energy_density_is_refused_naming_the_key() {
        for k in [-1.0, f64::NAN, f64::INFINITY] {
            let e = Cohesion { model: CohesionModel::Sjkr, energy_density: k }.check().unwrap_err();
            assert_eq!(e.key, "contact.cohesion.energy_density");
        }
        assert!(Cohesion { model: CohesionModel::Sjkr2, energy_density: 0.0 }.check().is_ok());
    }
}
