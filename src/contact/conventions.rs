//! The conventions of the reference codes, resolved in one place: every option
//! the case's `[contact]` section does not give is filled from its
//! `convention` (`talus`, `liggghts`, `yade` or `lammps`), as ARCHITECTURE.md's table
//! "Contact laws" lists them.

use super::hertz::HertzDamping;
use super::{Convention, EndOfContact, FrictionCap, ShearKinematics, TangentialHistory, TangentialOptions};
use crate::case::{ContactSection, ModelName, WallContactPoint};
use crate::material::Mixing;

/// Every convention option of a run, resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactOptions {
    /// How Hertz maps restitution to damping.
    pub damping: HertzDamping,
    /// Whether the normal force may go tensile at the end of a contact.
    pub end: EndOfContact,
    /// Tangential history, Coulomb cap and shear kinematics.
    pub tang: TangentialOptions,
    /// Where a wall contact acts: arm r - f delta from the centre, f = 1/2 at
    /// the middle of the overlap (LIGGGHTS `cr = r - delta/2`), f = 1 on the
    /// wall surface (YADE's `ScGeom` contact point for `Ig2_Wall_Sphere_ScGeom`),
    /// f = 0 at the particle's undeformed surface (LAMMPS `fix wall/gran`).
    pub wall_arm_overlap: f64,
    /// How two materials mix into a pair.
    pub mixing: Mixing,
    /// Rolling resistance (no convention default: given or none).
    pub rolling: Option<crate::case::RollingModel>,
    /// Against a wall, the epsd2 rolling spring is driven by the particle's
    /// spin scaled by arm / (r - delta) (LIGGGHTS 3.8's `surface_model_default.h`
    /// hands its rolling models the wall contact's `wr = cr w_i / r`, which
    /// epsd2 integrates as it is; cdt uses only its direction); else by the
    /// spin itself (talus, YADE).
    pub rolling_wall_spin_scaled: bool,
}

/// The options of the case's `[contact]` section: each one given, or its
/// convention's.
pub fn resolve(c: &ContactSection) -> ContactOptions {
    use Convention::{Lammps, Liggghts, Talus, Yade};
    let conv = c.convention;
    // dmt and jkr pull: their normal force is never clipped, and friction is
    // capped by |F_el + 2 F_pulloff| unless the case says otherwise
    let (pulls, _) = super::law_traits(c);
    let damping = c.damping.unwrap_or(match conv {
        Liggghts | Talus => HertzDamping::Liggghts,
        Yade => HertzDamping::Yade,
        Lammps => HertzDamping::Tsuji,
    });
    let end = c.end_of_contact.unwrap_or(match conv {
        _ if pulls => EndOfContact::Tensile,
        Liggghts | Talus | Lammps => EndOfContact::Tensile,
        Yade => EndOfContact::Clip,
    });
    let history = c.tangential.unwrap_or(match conv {
        Liggghts | Talus => TangentialHistory::Total,
        Yade => TangentialHistory::Incremental,
        Lammps => TangentialHistory::Rescaled,
    });
    // YADE: Mindlin increments shear with full radii; ViscEl with the contact point
    let kinematics = c.shear_kinematics.unwrap_or(match (conv, c.model) {
        (Yade, ModelName::Hertz | ModelName::Dmt | ModelName::Jkr) => ShearKinematics::FullRadii,
        (Lammps, _) => ShearKinematics::Radii,
        (Yade, ModelName::Hooke) | (Liggghts | Talus, _) => ShearKinematics::ContactPoint,
    });
    let wall_contact = c.wall_contact_point.unwrap_or(match conv {
        Yade => WallContactPoint::Surface,
        Liggghts | Talus => WallContactPoint::MidOverlap,
        Lammps => WallContactPoint::Radius,
    });
    let cap = c.friction_cap.unwrap_or(match conv {
        _ if pulls => FrictionCap::Pulloff,
        Talus => FrictionCap::Elastic,
        Liggghts | Yade => FrictionCap::Total,
        Lammps => FrictionCap::Pulloff,
    });
    let mixing = match conv {
        Liggghts | Talus | Lammps => Mixing::Liggghts,
        Yade => Mixing::Yade,
    };
    ContactOptions {
        damping,
        end,
        tang: TangentialOptions { history, cap, kinematics },
        wall_arm_overlap: match wall_contact {
            WallContactPoint::MidOverlap => 0.5,
            WallContactPoint::Surface => 1.0,
            WallContactPoint::Radius => 0.0,
        },
        mixing,
        rolling: c.rolling,
        rolling_wall_spin_scaled: conv == Liggghts,
    }
}
