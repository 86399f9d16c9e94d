//! `[[contact.pair]]`: a law per pair of materials. The case's laws (the
//! `[contact]` section's, then each pair's with its keys replacing the
//! section's) are slots of one law, [`PerPair`]; the mixed-material table
//! marks each pair of materials with its slot (`PairMaterial::law`), so the
//! pair's constants (made once per pair at a list build) carry the law that
//! acts on it, and the sweep branches on it per contact. A case without a
//! pair table never meets this law: `dispatch` compiles its sweep for its one
//! law, as before.

use super::adhesive::{Dmt, Jkr, JkrPair};
use super::cohesion::Cohesion;
use super::geometry::{ContactGeom, Motion};
use super::hertz::Hertz;
use super::hooke::{Hooke, HookeExplicit};
use super::{evaluate, ContactForce, ContactLaw, ContactOptions, KeyError, NormalCoeffs, PairInertia};
use crate::case::{ContactSection, ModelName};
use crate::dim::Vec3;
use crate::material::PairMaterial;

/// The most laws a case may have: the section's and seven pairs'.
pub const MAX_LAWS: usize = 8;

/// One of the case's laws, whichever it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyLaw {
    Hooke(Hooke),
    HookeExplicit(HookeExplicit),
    Hertz(Hertz),
    Dmt(Dmt),
    Jkr(Jkr),
}

/// A slot: a law and its cohesion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    pub law: AnyLaw,
    pub cohesion: Option<Cohesion>,
}

impl Slot {
    /// The law of a section (a pair's, as `ContactSection::for_pair` makes
    /// it), with its own damping mapping and the run's other options.
    pub fn from_section(c: &ContactSection, o: &ContactOptions) -> Result<Slot, KeyError> {
        // (the run's options resolved the section's damping; a pair's own replaces it)
        let o = ContactOptions { damping: c.damping.unwrap_or(o.damping), ..*o };
        let law = match c.model {
            ModelName::Hooke if c.stiffness.is_some() => AnyLaw::HookeExplicit(HookeExplicit::from_case(c, &o)?),
            ModelName::Hooke => AnyLaw::Hooke(Hooke::from_case(c, &o)?),
            ModelName::Hertz => AnyLaw::Hertz(Hertz::from_case(c, &o)?),
            ModelName::Dmt => AnyLaw::Dmt(Dmt::from_case(c, &o)?),
            ModelName::Jkr => AnyLaw::Jkr(Jkr::from_case(c, &o)?),
        };
        if let Some(coh) = &c.cohesion {
            coh.check()?;
        }
        Ok(Slot { law, cohesion: c.cohesion })
    }
}

/// The laws of a case with a pair table, by slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerPair {
    pub slots: [Option<Slot>; MAX_LAWS],
}

/// A pair's law with its constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairLaw {
    /// Either Hooke form: its four coefficients for this pair.
    Hooke(HookeExplicit),
    Hertz(Hertz),
    Dmt(Dmt, f64),
    Jkr(Jkr, JkrPair),
}

/// The constants of one pair: its law and cohesion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairConstants {
    pub law: PairLaw,
    pub cohesion: Option<Cohesion>,
}

impl ContactLaw for PerPair {
    type Pair = PairConstants;
    const REACHES: bool = true;
    const PULLS: bool = true;

    /// Every law of the case, each pair's keys named as `contact.pair[k].KEY`.
    fn from_case(c: &ContactSection, o: &ContactOptions) -> Result<Self, KeyError> {
        if c.pairs.len() >= MAX_LAWS {
            return Err(KeyError::new("contact.pair", c.pairs.len(), &format!("at most {} pairs of materials have laws of their own", MAX_LAWS - 1)));
        }
        let mut slots = [None; MAX_LAWS];
        let section = ContactSection { pairs: Vec::new(), ..c.clone() };
        slots[0] = Some(Slot::from_section(&section, o)?);
        for (k, p) in c.pairs.iter().enumerate() {
            let slot = Slot::from_section(&c.for_pair(p), o)
                .map_err(|e| KeyError { key: e.key.replacen("contact.", &format!("contact.pair[{k}]."), 1), ..e })?;
            slots[k + 1] = Some(slot);
        }
        Ok(PerPair { slots })
    }

    #[inline(always)]
    fn pair(&self, pm: &PairMaterial, pi: PairInertia) -> PairConstants {
        // the table marks no slot beyond the case's laws
        let slot = self.slots[pm.law as usize].or(self.slots[0]).expect("slot 0 is the section's law");
        let law = match slot.law {
            AnyLaw::Hooke(h) => PairLaw::Hooke(h.pair(pm, pi)),
            AnyLaw::HookeExplicit(h) => PairLaw::Hooke(h),
            AnyLaw::Hertz(h) => PairLaw::Hertz(h),
            AnyLaw::Dmt(d) => PairLaw::Dmt(d, d.pair(pm, pi)),
            AnyLaw::Jkr(j) => PairLaw::Jkr(j, j.pair(pm, pi)),
        };
        PairConstants { law, cohesion: slot.cohesion }
    }

    #[inline(always)]
    fn normal(&self, pm: &PairMaterial, pi: PairInertia, k: &PairConstants, overlap: f64) -> NormalCoeffs {
        match &k.law {
            PairLaw::Hooke(h) => h.normal(pm, pi, &(), overlap),
            PairLaw::Hertz(h) => h.normal(pm, pi, &(), overlap),
            PairLaw::Dmt(d, f) => d.normal(pm, pi, f, overlap),
            PairLaw::Jkr(j, c) => j.normal(pm, pi, c, overlap),
        }
    }

    #[inline(always)]
    fn reach(&self, k: &PairConstants) -> f64 {
        match &k.law {
            PairLaw::Jkr(j, c) => j.reach(c),
            PairLaw::Hooke(_) | PairLaw::Hertz(_) | PairLaw::Dmt(..) => 0.0,
        }
    }

    #[inline(always)]
    fn pulloff(&self, k: &PairConstants) -> f64 {
        match &k.law {
            PairLaw::Dmt(d, f) => d.pulloff(f),
            PairLaw::Jkr(j, c) => j.pulloff(c),
            PairLaw::Hooke(_) | PairLaw::Hertz(_) => 0.0,
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn contact(
        &self,
        o: &ContactOptions,
        pm: &PairMaterial,
        pi: PairInertia,
        pair: &PairConstants,
        g: &ContactGeom,
        m: &Motion,
        hist: &mut Vec3,
        roll: &mut Vec3,
        dt: f64,
    ) -> ContactForce {
        let mut c = evaluate(*self, o, pm, pi, pair, g, m, hist, roll, dt);
        if let Some(coh) = pair.cohesion {
            coh.add_to(&mut c, g);
        }
        c
    }
}
