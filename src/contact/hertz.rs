//! `hertz`: Hertz-Mindlin with tangential history, restitution-based damping and
//! a Coulomb cap (the drag paper's model).
//!
//! Elastic parts (Hertz 1882; Mindlin 1949, no-slip):
//! F_n,el = 4/3 Y* sqrt(R*) delta^(3/2),  k_t = 8 G* sqrt(R* delta).
//!
//! Damping from restitution e, by name:
//! - `liggghts` (LIGGGHTS 3.8 `normal_model_hertz.h`, after Tsuji et al. 1992):
//!   S_n = 2 Y* sqrt(R* delta), S_t = 8 G* sqrt(R* delta),
//!   beta = ln e / sqrt(ln^2 e + pi^2),
//!   gamma_n = -2 sqrt(5/6) beta sqrt(S_n m*),  gamma_t = -2 sqrt(5/6) beta sqrt(S_t m*).
//! - `yade` (YADE 2023 `Ip2_FrictMat_FrictMat_MindlinPhys` with `en`/`es`): see
//!   [`HertzDamping::Yade`].

use super::{ContactLaw, ContactOptions, KeyError, NormalCoeffs, PairInertia};
use crate::case::ContactSection;
use crate::material::PairMaterial;
use serde::{Deserialize, Serialize};

/// How restitution is mapped to a damping coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum HertzDamping {
    Liggghts,
    Yade,
    /// LAMMPS `damping tsuji`: gamma_n = alpha(e) sqrt(m* 4/3 E* a) with a =
    /// sqrt(R* delta) (the contact radius), alpha Tsuji's fit ([`tsuji_alpha`]);
    /// gamma_t = gamma_n (LAMMPS's tangential damping x_gt = 1).
    Tsuji,
}

impl HertzDamping {
    /// The mapping's row of `PairMaterial::hertz_damping`.
    #[inline(always)]
    pub fn index(self) -> usize {
        match self {
            HertzDamping::Liggghts => 0,
            HertzDamping::Yade => 1,
            HertzDamping::Tsuji => 2,
        }
    }

    /// The mapping's name in a case file.
    pub fn name(self) -> &'static str {
        match self {
            HertzDamping::Liggghts => "liggghts",
            HertzDamping::Yade => "yade",
            HertzDamping::Tsuji => "tsuji",
        }
    }
}

/// Tsuji et al. (1992)'s damping factor for restitution e as LAMMPS 29Sep2021
/// fits it (`pair_style granular` `damping tsuji`):
/// alpha = 1.2728 - 4.2783 e + 11.087 e^2 - 22.348 e^3 + 27.467 e^4 - 18.022 e^5 + 4.8218 e^6.
///
/// ```
/// // LAMMPS converts e = 0.5 to 0.3407
/// assert!((talus::contact::hertz::tsuji_alpha(0.5) - 0.3407).abs() < 1e-4);
/// ```
pub fn tsuji_alpha(e: f64) -> f64 {
    const C: [f64; 7] = [1.2728, -4.2783, 11.087, -22.348, 27.467, -18.022, 4.8218];
    let mut a = 0.0;
    for c in C.iter().rev() {
        a = a * e + c;
    }
    a
}

/// beta = ln e / sqrt(ln^2 e + pi^2) (<= 0), the LIGGGHTS damping parameter.
///
/// ```
/// let b = talus::contact::hertz::beta(0.5);
/// assert!((b - (-0.2154)).abs() < 1e-4);
/// ```
#[inline]
pub fn beta(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    let l = e.ln();
    l / (l * l + std::f64::consts::PI.powi(2)).sqrt()
}

/// Hertz-Mindlin normal part with the chosen damping mapping. Holds the
/// per-material-pair damping parameters precomputed so the kernel takes no logs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hertz {
    pub damping: HertzDamping,
}

impl ContactLaw for Hertz {
    /// Nothing per pair beyond R* and sqrt(m*) (`PairInertia`) and the damping
    /// prefactors per material pair (`PairMaterial::hertz_damping`).
    type Pair = ();

    /// `model = "hertz"` takes no coefficients; `damping` is a convention.
    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError> {
        if c.stiffness.is_some() || c.characteristic_velocity.is_some() {
            return Err(KeyError::new(
                "contact.model",
                "\"hertz\"",
                "contact.stiffness and contact.characteristic_velocity belong to the hooke model",
            ));
        }
        if let Some(g) = c.surface_energy {
            return Err(KeyError::new("contact.surface_energy", g, "the hertz law does not pull: a surface energy belongs to the dmt and jkr models"));
        }
        Ok(Hertz { damping: o.damping })
    }

    #[inline(always)]
    fn pair(&self, _pm: &PairMaterial, _pi: PairInertia) {}

    #[inline(always)]
    fn normal(&self, pm: &PairMaterial, pi: PairInertia, _pair: &(), overlap: f64) -> NormalCoeffs {
        let sqrt_rd = (pi.r_eff * overlap).sqrt();
        let f_elastic = 4.0 / 3.0 * pm.y_eff * sqrt_rd * overlap;
        let kt = 8.0 * pm.g_eff * sqrt_rd;
        // gamma = 2 zeta sqrt(S m*) with S = 2 Y* sqrt(R* delta) (normal) or 8 G* sqrt(R* delta)
        // (tangential); the constant parts are precomputed per material pair
        let [cn, ct] = pm.hertz_damping[self.damping.index()];
        let q = pi.sqrt_m_eff * sqrt_rd.sqrt();
        let (gamma_n, gamma_t) = (cn * q, ct * q);
        NormalCoeffs { f_elastic, gamma_n, kt, gamma_t }
    }
}

/// YADE 2023's damping ratio for restitution e (fraction of critical damping),
/// from the fit of Thornton, Cummins and Cleary (2013, Powder Technology 233,
/// Table 2 and eqs. B6-B7) used by `Ip2_FrictMat_FrictMat_MindlinPhys` with `en`:
/// alpha(e) = sum_{k=1..10} h_k e^k, beta = sqrt(1 / (1 - (1 + e)^2 exp(alpha)) - 1).
/// YADE then uses c_n = 2 beta sqrt(m* k_n) with the tangent stiffness
/// k_n = 3/2 k_no sqrt(delta) = 2 Y* sqrt(R* delta), and likewise c_s with k_s.
///
/// ```
/// // YADE 2023.02a gives betan = 0.2330249 for en = 0.5
/// let b = talus::contact::hertz::yade_damping_ratio(0.5);
/// assert!((b - 0.2330249).abs() < 1e-7);
/// ```
pub fn yade_damping_ratio(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    const H: [f64; 10] = [
        -6.918798, -16.41105, 146.8049, -796.4559, 2928.711, -7206.864, 11494.29, -11342.18, 6276.757, -1489.915,
    ];
    let mut alpha = 0.0;
    for h in H.iter().rev() {
        alpha = (alpha + h) * e;
    }
    (1.0 / (1.0 - (1.0 + e).powi(2) * alpha.exp()) - 1.0).sqrt()
}
