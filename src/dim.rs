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

/// Whether a run is three-dimensional or confined to the x-y plane. A case
/// gives it as `dimension = 3` or `2` (a number or a string).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default)]
pub enum Dimension {
    #[default]
    #[serde(rename = "3")]
    Three,
    #[serde(rename = "2")]
    Two,
}

impl<'de> Deserialize<'de> for Dimension {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Dimension;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("2 or 3")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Dimension, E> {
                match v {
                    3 => Ok(Dimension::Three),
                    2 => Ok(Dimension::Two),
                    _ => Err(E::custom(format!("dimension = {v}: must be 2 (a run in the x-y plane) or 3"))),
                }
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Dimension, E> {
                self.visit_i64(i64::try_from(v).unwrap_or(i64::MAX))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Dimension, E> {
                Err(E::custom(format!("dimension = {v}: must be 2 (a run in the x-y plane) or 3")))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Dimension, E> {
                match v {
                    "3" => Ok(Dimension::Three),
                    "2" => Ok(Dimension::Two),
                    _ => Err(E::custom(format!("dimension = \"{v}\": must be 2 (a run in the x-y plane) or 3"))),
                }
            }
        }
        d.deserialize_any(V)
    }
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

/// In a case file: the number 2 or 3.
impl schemars::JsonSchema for Dimension {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Dimension".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "description": "2 (a run in the x-y plane) or 3",
            "enum": [2, 3, "2", "3"]
        })
    }
}
