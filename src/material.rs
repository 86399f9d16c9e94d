//! Materials and the per-type-pair mixing table.
//!
//! Mixing is done once at set-up into a dense table indexed by the two material
//! indices (YADE's Ip2 stage); the force kernels only read it.

use crate::error::TalusError;
use serde::{Deserialize, Serialize};

/// A particle or wall material, validated on construction.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub name: String,
    /// Young's modulus E (Pa).
    pub youngs_modulus: f64,
    /// Poisson's ratio nu, in [0, 0.5).
    pub poisson_ratio: f64,
    /// Density rho (kg/m^3).
    pub density: f64,
    /// Coefficient of normal restitution e, in (0, 1].
    pub restitution: f64,
    /// Coulomb friction coefficient mu >= 0.
    pub friction: f64,
    /// Rolling friction coefficient mu_r >= 0 (dimensionless; `contact.rolling`
    /// picks the law). 0 when not given.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rolling_friction: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl Material {
    /// Check every property against its physical range; `ctx` names where the material came from.
    pub fn validate(&self, ctx: &str) -> Result<(), TalusError> {
        let key = |k: &str| format!("{ctx}: materials.{}.{k}", self.name);
        let bad = |k: &str, v: f64, why: &str| Err(TalusError::Input(format!("{} = {v}: {why}", key(k))));
        if !(self.youngs_modulus.is_finite() && self.youngs_modulus > 0.0) {
            return bad("youngs_modulus", self.youngs_modulus, "Young's modulus must be a positive number of pascals");
        }
        if !(self.poisson_ratio >= 0.0 && self.poisson_ratio < 0.5) {
            return bad("poisson_ratio", self.poisson_ratio, "Poisson's ratio must lie in [0, 0.5)");
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return bad("density", self.density, "density must be a positive number of kg/m^3");
        }
        if !(self.restitution > 0.0 && self.restitution <= 1.0) {
            return bad("restitution", self.restitution, "the coefficient of restitution must lie in (0, 1]");
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return bad("friction", self.friction, "the friction coefficient must be zero or positive");
        }
        if !(self.rolling_friction.is_finite() && self.rolling_friction >= 0.0) {
            return bad("rolling_friction", self.rolling_friction, "the rolling friction coefficient must be zero or positive");
        }
        Ok(())
    }

    /// Shear modulus G = E / (2 (1 + nu)).
    pub fn shear_modulus(&self) -> f64 {
        self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
    }
}

/// Mixed properties of one pair of materials.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct PairMaterial {
    /// Effective Young's modulus Y* = 1 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2) (Pa); the same in LIGGGHTS and YADE.
    pub y_eff: f64,
    /// Effective shear modulus for the Mindlin tangential stiffness k_t = 8 G* sqrt(R* delta) (Pa):
    /// G* = 1 / ((2 - nu1)/G1 + (2 - nu2)/G2), the same in LIGGGHTS 3.8 (`createGeff`) and YADE 2023.
    pub g_eff: f64,
    /// Restitution of the pair.
    pub restitution: f64,
    /// Friction coefficient of the pair.
    pub friction: f64,
    /// Rolling friction coefficient of the pair (mixed as friction).
    pub rolling_friction: f64,
    /// Hertz damping prefactors, so that gamma = c sqrt(m*) (R* delta)^(1/4):
    /// [normal, tangential] for the LIGGGHTS mapping (from beta = ln e / sqrt(ln^2 e + pi^2)),
    /// then for the YADE mapping (from Thornton's damping ratio, the same for en and es),
    /// then for LAMMPS's `damping tsuji` (alpha(e) sqrt(4/3 Y*) for both: LAMMPS's
    /// tangential damping is x_gt = 1 times the normal one), indexed by
    /// `HertzDamping::index`.
    pub hertz_damping: [[f64; 2]; 3],
    /// Which of the case's laws acts on this pair: 0 the `[contact]`
    /// section's, k the k-th `[[contact.pair]]`'s (`PairTable::for_case`).
    #[serde(default)]
    pub law: u8,
}

/// How two materials are mixed into one pair (the conventions of the reference codes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mixing {
    /// LIGGGHTS: Y* and G* in series; e and mu taken from the pair (we use the mean of the two).
    Liggghts,
    /// YADE Mindlin: Y* and G* in series, mu = min(tan phi1, tan phi2).
    Yade,
}

/// Dense table of mixed pair properties, indexed by material index.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PairTable {
    n: usize,
    entries: Vec<PairMaterial>,
}

impl PairTable {
    pub fn new(materials: &[Material], mixing: Mixing) -> Self {
        let n = materials.len();
        let mut entries = Vec::with_capacity(n * n);
        for a in materials {
            for b in materials {
                entries.push(mix(a, b, mixing));
            }
        }
        PairTable { n, entries }
    }
    /// The table of a case's materials, each pair of `[[contact.pair]]` marked
    /// with its law (`PairMaterial::law`); a pair named twice takes the last.
    pub fn for_case(case: &crate::case::Case, mixing: Mixing) -> Self {
        let mut t = PairTable::new(&case.materials, mixing);
        for (k, p) in case.contact.pairs.iter().enumerate() {
            let idx = |name: &str| case.materials.iter().position(|m| m.name == name);
            if let (Some(a), Some(b)) = (idx(&p.materials[0]), idx(&p.materials[1])) {
                t.entries[a * t.n + b].law = (k + 1) as u8;
                t.entries[b * t.n + a].law = (k + 1) as u8;
            }
        }
        t
    }

    #[inline(always)]
    pub fn get(&self, a: u16, b: u16) -> &PairMaterial {
        &self.entries[a as usize * self.n + b as usize]
    }
    pub fn len(&self) -> usize {
        self.n
    }
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
}

/// Mix two materials into the pair properties.
pub fn mix(a: &Material, b: &Material, mixing: Mixing) -> PairMaterial {
    let y_eff = 1.0
        / ((1.0 - a.poisson_ratio.powi(2)) / a.youngs_modulus + (1.0 - b.poisson_ratio.powi(2)) / b.youngs_modulus);
    let g_eff = 1.0 / ((2.0 - a.poisson_ratio) / a.shear_modulus() + (2.0 - b.poisson_ratio) / b.shear_modulus());
    let (restitution, friction, rolling_friction) = match mixing {
        Mixing::Liggghts => (
            0.5 * (a.restitution + b.restitution),
            0.5 * (a.friction + b.friction),
            0.5 * (a.rolling_friction + b.rolling_friction),
        ),
        Mixing::Yade => (0.5 * (a.restitution + b.restitution), a.friction.min(b.friction), a.rolling_friction.min(b.rolling_friction)),
    };
    let beta = crate::contact::hertz::beta(restitution);
    let ratio = crate::contact::hertz::yade_damping_ratio(restitution);
    // S_n = 2 Y* sqrt(R* delta), S_t = 8 G* sqrt(R* delta): sqrt(S m*) = sqrt(2 Y*) sqrt(m*) (R* delta)^(1/4)
    let (sn, st) = ((2.0 * y_eff).sqrt(), (8.0 * g_eff).sqrt());
    let l = -2.0 * (5.0f64 / 6.0).sqrt() * beta;
    // LAMMPS tsuji: eta = alpha(e) sqrt(m* 4/3 Y* a), a = sqrt(R* delta)
    let ts = crate::contact::hertz::tsuji_alpha(restitution) * (4.0 / 3.0 * y_eff).sqrt();
    let hertz_damping = [[l * sn, l * st], [2.0 * ratio * sn, 2.0 * ratio * st], [ts, ts]];
    PairMaterial { y_eff, g_eff, restitution, friction, rolling_friction, hertz_damping, law: 0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn soft() -> Material {
        Material {
            name: "seed-soft".into(),
            youngs_modulus: 1e6,
            poisson_ratio: 0.3,
            density: 2500.0,
            restitution: 0.5,
            friction: 0.4,
            rolling_friction: 0.0,
        }
    }

    #[test]
    fn identical_materials_mix_the_same_in_both_conventions() {
        let m = soft();
        let l = mix(&m, &m, Mixing::Liggghts);
        let y = mix(&m, &m, Mixing::Yade);
        // Y* = E / (2 (1 - nu^2))
        assert_relative_eq!(l.y_eff, 1e6 / (2.0 * 0.91), max_relative = 1e-14);
        assert_relative_eq!(l.y_eff, y.y_eff, max_relative = 1e-14);
        // G* = G / (2 (2 - nu)) = E / (4 (2 - nu)(1 + nu))
        assert_relative_eq!(l.g_eff, 1e6 / (4.0 * 1.7 * 1.3), max_relative = 1e-14);
        assert_relative_eq!(l.g_eff, y.g_eff, max_relative = 1e-14);
    }

    #[test]
    fn validation_names_key_and_value() {
        let mut m = soft();
        m.poisson_ratio = 0.5;
        let e = m.validate("case.toml").unwrap_err().to_string();
        assert!(e.contains("case.toml") && e.contains("poisson_ratio") && e.contains("0.5"), "{e}");
        let mut m = soft();
        m.restitution = 0.0;
        assert!(m.validate("x").unwrap_err().to_string().contains("restitution"));
    }
}
