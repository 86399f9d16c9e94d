//! The one module that decides the dimension.
//!
//! talus stores every vector as a 3-vector. A two-dimensional run (discs in the
//! x-y plane, spin about z) uses the same storage and kernels and constrains the
//! motion in the integrator: `Dimension::project` zeroes the out-of-plane
//! components. Kernels never carry `#[cfg]` for the dimension, and one binary
//! runs both, so features stay additive.

use serde::{Deserialize, Serialize};

/// The scalar type of the engine.
pub type Real = f64;
/// Position, velocity, force, angular velocity and torque vectors.
pub type Vec3 = nalgebra::Vector3<Real>;

/// Whether a run is three-dimensional or confined to the x-y plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Dimension {
    #[default]
    #[serde(rename = "3")]
    Three,
    #[serde(rename = "2")]
    Two,
}

impl Dimension {
    /// Remove the components of a translational vector that this dimension does not allow.
    #[inline(always)]
    pub fn project_linear(self, v: Vec3) -> Vec3 {
        match self {
            Dimension::Three => v,
            Dimension::Two => Vec3::new(v.x, v.y, 0.0),
        }
    }
    /// Remove the components of an angular vector that this dimension does not allow.
    #[inline(always)]
    pub fn project_angular(self, w: Vec3) -> Vec3 {
        match self {
            Dimension::Three => w,
            Dimension::Two => Vec3::new(0.0, 0.0, w.z),
        }
    }
}
