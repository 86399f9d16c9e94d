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
pub fn carry_history(feats: &[(u16, u32)], hits: &[Option<WallHit>], hist: &mut [Vec3], roll: &mut [Vec3]) {
    let zero = Vec3::zeros();
    // a rolling spring torque (where kept) goes along with the shear history
    let kept = |hist: &[Vec3], roll: &[Vec3], k: usize| hist[k] != zero || roll.get(k).is_some_and(|r| *r != zero);
    for new in 0..hits.len() {
        if hits[new].is_none() || kept(hist, roll, new) {
            continue;
        }
        if let Some(old) = (0..hits.len()).find(|&o| o != new && hits[o].is_none() && kept(hist, roll, o) && feats[o].0 == feats[new].0) {
            hist[new] = hist[old];
            hist[old] = zero;
            if !roll.is_empty() {
                roll[new] = roll[old];
                roll[old] = zero;
            }
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

impl Shape {
    /// Turn the shape by `rot` about `center`.
    pub fn rotate(&mut self, center: Vec3, rot: &nalgebra::Rotation3<f64>) {
        let turn = |x: &mut Vec3| *x = center + rot * (*x - center);
        match self {
            Shape::Plane(p) => {
                turn(&mut p.point);
                p.normal = rot * p.normal;
            }
            Shape::Mesh(m) => m.rotate(center, rot),
            Shape::Disc(b) => turn(&mut b.center),
            Shape::Segments(s) => {
                for seg in &mut s.segs {
                    turn(&mut seg[0]);
                    turn(&mut seg[1]);
                }
            }
        }
    }

    /// The farthest that a point of the shape within the box [lo, hi] lies from
    /// the line through `point` along the unit vector `axis` (m): a bound on how
    /// far the surface moves when the shape turns about that line by a small
    /// angle (per radian).
    pub fn reach_from_axis(&self, point: Vec3, axis: Vec3, lo: Vec3, hi: Vec3) -> f64 {
        let off = |x: Vec3| (x - point).cross(&axis).norm();
        match self {
            // a plane reaches as far as the box does
            Shape::Plane(_) => (0..8)
                .map(|i| off(Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z })))
                .fold(0.0, f64::max),
            Shape::Mesh(m) => m.vertices.iter().map(|&v| off(v)).fold(0.0, f64::max),
            Shape::Disc(b) => off(b.center) + b.radius,
            Shape::Segments(s) => s.segs.iter().flat_map(|g| [off(g[0]), off(g[1])]).fold(0.0, f64::max),
        }
    }
}

/// A wall's sinusoidal displacement `amplitude sin(omega (t - t0))`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Oscillation {
    /// Amplitude (m).
    pub amplitude: Vec3,
    /// Angular frequency, 2 pi f (rad/s).
    pub omega: f64,
    /// Time the oscillation starts from zero displacement (s).
    pub t0: f64,
}

impl Oscillation {
    pub fn displacement(&self, t: f64) -> Vec3 {
        self.amplitude * (self.omega * (t - self.t0)).sin()
    }
    pub fn velocity(&self, t: f64) -> Vec3 {
        self.amplitude * (self.omega * (self.omega * (t - self.t0)).cos())
    }
}

/// A wall's rotation about the axis through `point` (which moves with the
/// wall's translation and oscillation) at `rate` (rad/s, right-handed).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Rotation {
    /// Unit vector along the axis.
    pub axis: Vec3,
    /// A point of the axis, where it is now (m).
    pub point: Vec3,
    /// Angular velocity about the axis (rad/s).
    pub rate: f64,
    /// How far from the axis the wall reaches within the domain (m), for the
    /// neighbour list's displacement bound (a plane's is made anew as its axis moves).
    pub reach: f64,
    /// The domain (lo, hi) a plane's reach is measured in.
    pub domain: (Vec3, Vec3),
}

/// A servo: the wall moves along `direction` at gain x (target - R), limited to
/// +-max_speed, R = -force . direction the particles' push against it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Servo {
    /// Unit vector: the way the wall moves to press harder.
    pub direction: Vec3,
    /// The load to hold (N).
    pub target: f64,
    /// m/s per N.
    pub gain: f64,
    /// m/s.
    pub max_speed: f64,
    /// How far the wall has moved along `direction` (m).
    pub travel: f64,
}

impl Servo {
    /// The speed along the direction for a wall that carries `force` (m/s).
    #[inline]
    pub fn speed(&self, force: Vec3) -> f64 {
        let push = -force.dot(&self.direction);
        (self.gain * (self.target - push)).clamp(-self.max_speed, self.max_speed)
    }
}

/// A named wall with its material, prescribed motion and accumulated load.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Wall {
    pub name: String,
    pub shape: Shape,
    pub material: u16,
    /// Prescribed translational velocity (m/s).
    pub velocity: Vec3,
    /// Sinusoidal displacement on top of the translation, if any.
    pub oscillation: Option<Oscillation>,
    /// Rotation about an axis through a point moving with the wall, if any.
    pub rotation: Option<Rotation>,
    /// The oscillation's velocity at the current time (m/s; zero without one).
    pub osc_velocity: Vec3,
    /// A servo that sets the velocity from the load every step, if any.
    pub servo: Option<Servo>,
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
    /// A wall at rest.
    pub fn new(name: &str, shape: Shape, material: u16) -> Wall {
        Wall {
            name: name.to_string(),
            shape,
            material,
            velocity: Vec3::zeros(),
            oscillation: None,
            rotation: None,
            osc_velocity: Vec3::zeros(),
            servo: None,
            active: true,
            remove_at: None,
            force: Vec3::zeros(),
            torque: Vec3::zeros(),
            load: [0; 6],
        }
    }

    /// Prescribe the wall's motion from time `t` on: translation at `velocity`,
    /// an oscillation `(amplitude, frequency in Hz)` starting at t, a rotation
    /// `(axis, point, rate)`; [lo, hi] is the domain (a turning plane reaches
    /// across it).
    pub fn set_motion(
        &mut self,
        velocity: Vec3,
        oscillation: Option<(Vec3, f64)>,
        rotation: Option<(Vec3, Vec3, f64)>,
        t: f64,
        (lo, hi): (Vec3, Vec3),
    ) {
        self.velocity = velocity;
        self.oscillation =
            oscillation.map(|(amplitude, f)| Oscillation { amplitude, omega: 2.0 * std::f64::consts::PI * f, t0: t });
        self.osc_velocity = self.oscillation.as_ref().map_or(Vec3::zeros(), |o| o.velocity(t));
        // a wall that stops turning keeps its axis (rate 0), for its axis torque
        self.rotation = match rotation {
            Some((axis, point, rate)) => {
                let axis = axis.normalize();
                Some(Rotation { axis, point, rate, reach: self.shape.reach_from_axis(point, axis, lo, hi), domain: (lo, hi) })
            }
            None => self.rotation.take().map(|r| Rotation { rate: 0.0, ..r }),
        };
    }

    /// A servo wall's velocity for the next step, from the load of the last
    /// (and how far that step will take it along its direction).
    pub fn servo_update(&mut self, dt: f64) {
        if let Some(s) = &mut self.servo {
            let v = s.speed(self.force);
            self.velocity = s.direction * v;
            s.travel += v * dt;
        }
    }

    /// Move the wall over one step, from time t - dt to t: translation,
    /// oscillation, then rotation about the axis where the translation left it.
    /// Returns a bound on how far any point of its surface moved (m).
    pub fn advance(&mut self, dt: f64, t: f64) -> f64 {
        let mut moved = 0.0;
        let mut d = None;
        if self.velocity != Vec3::zeros() {
            d = Some(self.velocity * dt);
            moved += self.velocity.norm() * dt;
        }
        if let Some(o) = &self.oscillation {
            let step = o.displacement(t) - o.displacement(t - dt);
            d = Some(d.unwrap_or_else(Vec3::zeros) + step);
            moved += step.norm();
            self.osc_velocity = o.velocity(t);
        }
        if let Some(d) = d {
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
            if let Some(r) = &mut self.rotation {
                r.point += d;
                if let Shape::Plane(_) = self.shape {
                    r.reach = self.shape.reach_from_axis(r.point, r.axis, r.domain.0, r.domain.1);
                }
            }
        }
        if let Some(r) = &self.rotation {
            if r.rate != 0.0 {
                let angle = r.rate * dt;
                let rot = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(r.axis), angle);
                self.shape.rotate(r.point, &rot);
                moved += angle.abs() * r.reach;
            }
        }
        moved
    }

    /// The wall's velocity at point x (m/s): translation, oscillation and rotation.
    #[inline(always)]
    pub fn velocity_at(&self, x: Vec3) -> Vec3 {
        if self.oscillation.is_none() && self.rotation.is_none() {
            return self.velocity;
        }
        let mut v = self.velocity + self.osc_velocity;
        if let Some(r) = &self.rotation {
            v += (r.axis * r.rate).cross(&(x - r.point));
        }
        v
    }

    /// The particles' torque on the wall about its rotation axis (N m), if it has one.
    pub fn axis_torque(&self) -> Option<f64> {
        self.rotation.as_ref().map(|r| (self.torque - r.point.cross(&self.force)).dot(&r.axis))
    }

    /// For a block of spheres centred in `lo..hi`, radii at most `r`: where
    /// the wall is a scanned mesh, the triangles any of them may have as
    /// candidates ([`Mesh::near_box`]), for [`Wall::candidates_in`]; else
    /// false (each sphere is looked at alone).
    pub fn near_box(&self, lo: &Vec3, hi: &Vec3, r: f64, reach: f64, out: &mut Vec<u32>) -> bool {
        match &self.shape {
            Shape::Mesh(m) => m.near_box(lo, hi, r + reach, out),
            _ => false,
        }
    }

    /// [`Wall::candidates`], of a sphere of a block for which
    /// [`Wall::near_box`] gave `near` (`None`: it gave false): the same
    /// features in the same order.
    #[inline]
    pub fn candidates_in(&self, c: &Vec3, r: f64, reach: f64, near: Option<&[u32]>, out: &mut Vec<u32>) {
        match (&self.shape, near) {
            (Shape::Mesh(m), Some(near)) => m.candidates_among(c, r + reach, near, out),
            _ => self.candidates(c, r, reach, out),
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
