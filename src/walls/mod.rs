//! Walls: infinite planes and triangle meshes (STL). A wall reports, for a
//! sphere, the contacts it makes as contact geometry (normal, overlap, contact
//! point) plus a feature id that keys the contact's history.

pub mod mesh;

use crate::contact::geometry::ContactGeom;
use crate::contact::ContactForce;
use crate::dim::Vec3;
use crate::fixed::to_fixed;
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

impl WallHit {
    /// Contact geometry of a sphere of radius r from its hit: the force acts
    /// on the normal through the centre, `arm_overlap` of the overlap back from
    /// the sphere's deepest point (arm r - arm_overlap delta); R* is the pair's
    /// own (the sphere's radius, in series with a curved wall's).
    #[inline(always)]
    pub fn sphere_geometry(&self, r: f64, arm_overlap: f64) -> ContactGeom {
        ContactGeom::sphere_wall(self.n, self.overlap, r - arm_overlap * self.overlap, r)
    }
}

/// Merge contacts of one sphere with one wall whose contact points coincide to
/// within 1e-9 of the radius: near a shared edge or vertex, rounding can make two
/// triangles each report the same touch (one as a face, one as an edge point).
/// The face contact, else the first, is kept. `feats` are (wall, feature) per hit.
pub fn merge_coincident(feats: &[(u16, u32)], hits: &mut [Option<WallHit>], r: f64) {
    let tol2 = (1e-9 * r).powi(2);
    for a in 0..hits.len() {
        for b in a + 1..hits.len() {
            let (Some(ha), Some(hb)) = (hits[a], hits[b]) else { continue };
            if feats[a].0 != feats[b].0 || (ha.point - hb.point).norm_squared() > tol2 {
                continue;
            }
            // keep the deeper one (a face beats an edge point by rounding), ties to the first
            if hb.overlap > ha.overlap {
                hits[a] = None;
            } else {
                hits[b] = None;
            }
        }
    }
}

/// Let a contact that moves from one triangle of a wall to another keep its
/// tangential history: a new contact (zero history) takes over the history of a
/// contact on the same wall that has just ended (non-zero history, no hit).
pub fn carry_history(feats: &[(u16, u32)], hits: &[Option<WallHit>], hist: &mut [crate::dim::Vec3]) {
    let zero = Vec3::zeros();
    for new in 0..hits.len() {
        if hits[new].is_none() || hist[new] != zero {
            continue;
        }
        if let Some(old) =
            (0..hits.len()).find(|&o| o != new && hits[o].is_none() && hist[o] != zero && feats[o].0 == feats[new].0)
        {
            hist[new] = hist[old];
            hist[old] = zero;
        }
    }
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

/// A rigid ball (in 2D: a disc, the cross-section of a cylinder along z);
/// particles touch it from outside. The drag paper's cylinder.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Disc {
    pub center: Vec3,
    pub radius: f64,
}

impl Disc {
    #[inline(always)]
    pub fn contact(&self, c: &Vec3, r: f64) -> Option<WallHit> {
        let d = c - self.center;
        let dist = d.norm();
        let overlap = r + self.radius - dist;
        if overlap > 0.0 && dist > 0.0 {
            let n = d / dist;
            Some(WallHit { n, overlap, point: self.center + n * self.radius, feature: 0 })
        } else {
            None
        }
    }
}

/// Straight segments in the x-y plane (2D walls): one segment, or a closed box
/// of four; each segment is a feature, touched from either side, its end
/// points rounded (a disc meets the nearest point of the segment).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Segments {
    pub segs: Vec<[Vec3; 2]>,
}

impl Segments {
    #[inline(always)]
    pub fn segment(&self, k: usize) -> crate::contact::ellipse::Segment {
        crate::contact::ellipse::Segment { p: self.segs[k][0], q: self.segs[k][1] }
    }
}

/// The geometry of a wall.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum Shape {
    Plane(Plane),
    Mesh(Mesh),
    Disc(Disc),
    Segments(Segments),
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
    /// This rank's part of force and torque in fixed point (exact sums, the
    /// same for any number of ranks); `force` and `torque` are made from the
    /// sum over ranks.
    #[serde(skip)]
    pub load: [i128; 6],
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
            Shape::Disc(b) => b.center += d,
            Shape::Segments(s) => {
                for seg in &mut s.segs {
                    seg[0] += d;
                    seg[1] += d;
                }
            }
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
            Shape::Disc(b) => {
                if (c - b.center).norm() < b.radius + r + reach {
                    out.push(0);
                }
            }
            Shape::Segments(s) => {
                for k in 0..s.segs.len() {
                    if s.segment(k).disc_contact(c, r + reach).is_some() {
                        out.push(k as u32);
                    }
                }
            }
        }
    }

    /// The contact of a sphere with one feature, honouring edge and vertex ownership.
    #[inline(always)]
    pub fn contact(&self, feature: u32, c: &Vec3, r: f64) -> Option<WallHit> {
        match &self.shape {
            Shape::Plane(p) => p.contact(c, r),
            Shape::Mesh(m) => m.contact(feature as usize, c, r),
            Shape::Disc(b) => b.contact(c, r),
            Shape::Segments(s) => s
                .segment(feature as usize)
                .disc_contact(c, r)
                .map(|(n, overlap, point)| WallHit { n, overlap, point, feature }),
        }
    }

    /// The contact of an ellipse with one feature: the normal from the wall to
    /// the ellipse, the overlap and the ellipse's deepest point (its boundary
    /// point farthest into the wall). STL meshes do not take ellipses (3D).
    #[inline(always)]
    pub fn ellipse_contact(&self, feature: u32, e: &crate::contact::ellipse::Ellipse) -> Option<WallHit> {
        use crate::contact::ellipse::{contact_fast, Ellipse};
        let hit = |c: crate::contact::ellipse::EllipseContact| WallHit { n: c.n, overlap: c.overlap, point: c.point, feature };
        match &self.shape {
            // one-sided, as for spheres: a centre behind the plane makes no contact
            Shape::Plane(p) => (p.distance(&e.c) > 0.0).then(|| e.wall_contact(p.point, p.normal)).flatten().map(hit),
            Shape::Mesh(_) => None,
            Shape::Disc(b) => {
                let disc = Ellipse::new(b.center, b.radius, b.radius, 0.0);
                contact_fast(&disc, e).map(|c| WallHit { n: c.n, overlap: c.overlap, point: e.support_point(-c.n.x, -c.n.y), feature })
            }
            Shape::Segments(s) => s.segment(feature as usize).ellipse_contact(e).map(hit),
        }
    }

    /// Radius of curvature of the wall's surface (None: flat).
    #[inline(always)]
    pub fn curvature_radius(&self) -> Option<f64> {
        match &self.shape {
            Shape::Disc(b) => Some(b.radius),
            _ => None,
        }
    }
}

/// Add a contact's reaction to a wall load `[Fx, Fy, Fz, Tx, Ty, Tz]` (exact
/// fixed point, see `crate::fixed`): the force -F at the contact point
/// (torque point x -F about the origin) and the law's torque on the wall,
/// `torque_j`, referred to the contact point (a couple; zero unless the law
/// has one).
#[inline(always)]
pub fn add_load(load: &mut [i128; 6], point: Vec3, c: &ContactForce) {
    let t = point.cross(&c.force);
    for k in 0..3 {
        load[k] -= to_fixed(c.force[k]);
        load[3 + k] -= to_fixed(t[k]);
    }
    // (+-0 for a force alone: adding it would add the integer 0)
    if c.torque_j != Vec3::zeros() {
        for k in 0..3 {
            load[3 + k] += to_fixed(c.torque_j[k]);
        }
    }
}
