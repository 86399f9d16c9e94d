//! Walls: infinite planes and triangle meshes (STL). A wall reports, for a
//! sphere, the contacts it makes as contact geometry (normal, overlap, contact
//! point) plus a feature id that keys the contact's history.

pub mod mesh;

use crate::dim::Vec3;
pub use mesh::Mesh;
use serde::{Deserialize, Serialize};

/// A contact between a sphere and a wall feature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallHit {
    /// Unit normal from the wall to the sphere centre.
    pub n: Vec3,
    /// Overlap (m), > 0.
    pub overlap: f64,
    /// Contact point (m), on the wall surface.
    pub point: Vec3,
    /// Feature id within the wall (triangle index; 0 for a plane).
    pub feature: u32,
}

/// An infinite plane; spheres live on the side its normal points to.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Plane {
    pub point: Vec3,
    /// Unit normal.
    pub normal: Vec3,
}

impl Plane {
    /// Signed distance of x from the plane.
    #[inline(always)]
    pub fn distance(&self, x: &Vec3) -> f64 {
        (x - self.point).dot(&self.normal)
    }
    /// The contact of a sphere (centre c, radius r), if any. A centre behind the
    /// plane makes no contact (the plane is one-sided).
    #[inline(always)]
    pub fn contact(&self, c: &Vec3, r: f64) -> Option<WallHit> {
        let d = self.distance(c);
        if d > 0.0 && d < r {
            Some(WallHit { n: self.normal, overlap: r - d, point: c - self.normal * d, feature: 0 })
        } else {
            None
        }
    }
}

/// The geometry of a wall.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum Shape {
    Plane(Plane),
    Mesh(Mesh),
}

/// A named wall with its material, prescribed velocity and accumulated load.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Wall {
    pub name: String,
    pub shape: Shape,
    pub material: u16,
    /// Prescribed translational velocity (m/s).
    pub velocity: Vec3,
    /// Whether the wall still takes part (a removed gate does not).
    pub active: bool,
    /// Simulated time at which the wall is removed, if any (s).
    pub remove_at: Option<f64>,
    /// Force exerted by the particles on the wall this step (N).
    pub force: Vec3,
    /// Torque about the origin exerted by the particles on the wall this step (N m).
    pub torque: Vec3,
}

impl Wall {
    /// Move the wall by its prescribed velocity over dt.
    pub fn advance(&mut self, dt: f64) {
        if self.velocity == Vec3::zeros() {
            return;
        }
        let d = self.velocity * dt;
        match &mut self.shape {
            Shape::Plane(p) => p.point += d,
            Shape::Mesh(m) => m.translate(d),
        }
    }

    /// Features possibly within `reach` of a sphere surface, for the neighbour list.
    pub fn candidates(&self, c: &Vec3, r: f64, reach: f64, out: &mut Vec<u32>) {
        match &self.shape {
            Shape::Plane(p) => {
                let d = p.distance(c);
                if d > -r && d < r + reach {
                    out.push(0);
                }
            }
            Shape::Mesh(m) => m.candidates(c, r + reach, out),
        }
    }

    /// The contact of a sphere with one feature, honouring edge and vertex ownership.
    #[inline(always)]
    pub fn contact(&self, feature: u32, c: &Vec3, r: f64) -> Option<WallHit> {
        match &self.shape {
            Shape::Plane(p) => p.contact(c, r),
            Shape::Mesh(m) => m.contact(feature as usize, c, r),
        }
    }
}
