//! The geometry stage (YADE's Ig2 functors and `ScGeom`): every contact, of two
//! particles or of a particle and a wall feature, whatever the shapes, becomes
//! one [`ContactGeom`]: the unit normal, the overlap, the contact point and the
//! branch vectors from each body's centre to it ([`Lever`]: stored for
//! ellipses, derived from the scalar arms along the normal for spheres) and,
//! where the shapes set it, the effective radius R*. The relative velocity at
//! the contact and the torques r x F follow from it once, in
//! [`ContactGeom::velocities`] and [`ContactGeom::torques`], so the force sweep
//! never asks which shapes touch.
//!
//! Where each shape's geometry lives:
//! - sphere-sphere (discs in 2D): [`sphere_sphere`], here;
//! - sphere-plane, -triangle (face, edge, vertex), -disc, -segment: the wall
//!   reports a [`WallHit`] (`walls/`), [`WallHit::sphere_geometry`] makes the
//!   geometry;
//! - ellipse-ellipse (and ellipse-disc particle pairs): [`ellipse::pair_geometry`];
//! - ellipse-wall: `Wall::ellipse_contact` reports the hit,
//!   [`ellipse::wall_geometry`] makes the geometry.
//!
//! [`Shapes`] picks the right one for a pair or a wall contact.

use super::ellipse::{self, Ellipse};
use super::{yade_shear_velocity, ShearKinematics};
use crate::dim::Vec3;
use crate::particles::Particles;
use crate::walls::{Wall, WallHit};

/// Geometry of one contact of body i with body j (a particle or a wall).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactGeom {
    /// Unit normal from j to i.
    pub n: Vec3,
    /// Overlap delta (m), positive in contact.
    pub overlap: f64,
    /// R* of this contact when the shapes set it (ellipses: from the radii of
    /// curvature at the contact point); `None`: the pair's own R*, fixed for the
    /// pair and computed once per pair at list build (spheres, discs).
    pub r_eff: Option<f64>,
    /// Where the contact point lies, and with it the branch vectors
    /// ([`ContactGeom::branch_i`], [`ContactGeom::branch_j`]) and how velocities
    /// and torques are evaluated from them.
    pub lever: Lever,
}

/// Where the contact point lies relative to the two centres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lever {
    /// On the normal through i's centre (spheres and discs, with each other
    /// and with any wall feature), at `arm_i` from i's centre and `arm_j` from
    /// j's: branch_i = -arm_i n, branch_j = arm_j n. Evaluated with the scalar
    /// arms as LIGGGHTS's `surface_model_default.h` does,
    /// v = (v_i - v_j) - (arm_i w_i + arm_j w_j) x n and torques -arm (n x F):
    /// w x b and b x F, rounded the reference code's way. `radius_i`, `radius_j`
    /// are the full radii of YADE's shear kinematics; `radius_j = arm_j = 0`
    /// for a wall.
    AlongNormal { arm_i: f64, arm_j: f64, radius_i: f64, radius_j: f64 },
    /// Anywhere (ellipses): the contact point and the branch vectors to it,
    /// evaluated as v = (v_i + w_i x b_i) - (v_j + w_j x b_j) and torques
    /// b_i x F, -b_j x F. The contact-point velocity drives the shear spring
    /// whatever [`ShearKinematics`] says (YADE's full
    /// radii have no meaning here). `branch_j` is `None` for a wall.
    Branch { point: Vec3, branch_i: Vec3, branch_j: Option<Vec3> },
}

/// Velocities of the two bodies of a contact: centres and spins (a wall: its
/// velocity, zero spin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    pub v_i: Vec3,
    pub w_i: Vec3,
    pub v_j: Vec3,
    pub w_j: Vec3,
}

impl ContactGeom {
    /// Two spheres (discs): the contact point on the normal through the
    /// centres, at `arm[0]` from i's centre and `arm[1]` from j's; `radius` the
    /// two radii.
    #[inline(always)]
    pub fn spheres(n: Vec3, overlap: f64, arm: [f64; 2], radius: [f64; 2]) -> Self {
        let lever = Lever::AlongNormal { arm_i: arm[0], arm_j: arm[1], radius_i: radius[0], radius_j: radius[1] };
        ContactGeom { n, overlap, r_eff: None, lever }
    }

    /// A sphere (disc) of radius `radius` on a wall: the contact point on the
    /// normal through the centre, at `arm` from it.
    #[inline(always)]
    pub fn sphere_wall(n: Vec3, overlap: f64, arm: f64, radius: f64) -> Self {
        ContactGeom { n, overlap, r_eff: None, lever: Lever::AlongNormal { arm_i: arm, arm_j: 0.0, radius_i: radius, radius_j: 0.0 } }
    }

    /// From i's centre to the contact point (m).
    #[inline(always)]
    pub fn branch_i(&self) -> Vec3 {
        match self.lever {
            Lever::AlongNormal { arm_i, .. } => -(self.n * arm_i),
            Lever::Branch { branch_i, .. } => branch_i,
        }
    }

    /// From j's centre to the contact point (m); `None` for a wall, which has
    /// no centre and does not spin (its load is referred to the contact point).
    #[inline(always)]
    pub fn branch_j(&self) -> Option<Vec3> {
        match self.lever {
            Lever::AlongNormal { arm_j, radius_j, .. } => (radius_j > 0.0).then(|| self.n * arm_j),
            Lever::Branch { branch_j, .. } => branch_j,
        }
    }

    /// The contact point (m), i's centre being `x_i`.
    #[inline(always)]
    pub fn point(&self, x_i: Vec3) -> Vec3 {
        match self.lever {
            // x_i + (-(n arm_i)) is x_i - n arm_i to the bit
            Lever::AlongNormal { .. } => x_i + self.branch_i(),
            Lever::Branch { point, .. } => point,
        }
    }

    /// Velocity of i's material point at the contact relative to j's, and the
    /// velocity whose tangential part drives the shear spring and dashpot: the
    /// same, or YADE's full-radii variant for spheres (see [`ShearKinematics`]).
    #[inline(always)]
    pub fn velocities(&self, kinematics: ShearKinematics, m: &Motion) -> (Vec3, Vec3) {
        match self.lever {
            Lever::AlongNormal { arm_i, arm_j, radius_i, radius_j } => {
                let v = (m.v_i - m.v_j) - (m.w_i * arm_i + m.w_j * arm_j).cross(&self.n);
                let vs = match kinematics {
                    ShearKinematics::ContactPoint => v,
                    ShearKinematics::FullRadii => {
                        yade_shear_velocity(self.n, self.overlap, radius_i, radius_j, m.v_i, m.v_j, m.w_i, m.w_j)
                    }
                    ShearKinematics::Radii => (m.v_i - m.v_j) - (m.w_i * radius_i + m.w_j * radius_j).cross(&self.n),
                };
                (v, vs)
            }
            Lever::Branch { branch_i, branch_j, .. } => {
                let vi = m.v_i + m.w_i.cross(&branch_i);
                let v = match branch_j {
                    Some(bj) => vi - (m.v_j + m.w_j.cross(&bj)),
                    None => vi - m.v_j,
                };
                (v, v)
            }
        }
    }

    /// Torques on i and on j from the force f on i (-f acts on j). A wall's
    /// torque is about the contact point: zero for a force alone.
    #[inline(always)]
    pub fn torques(&self, f: Vec3) -> (Vec3, Vec3) {
        match self.lever {
            Lever::AlongNormal { arm_i, arm_j, .. } => {
                let nxf = self.n.cross(&f);
                (-nxf * arm_i, -nxf * arm_j)
            }
            Lever::Branch { branch_i, branch_j, .. } => {
                (branch_i.cross(&f), branch_j.map_or_else(Vec3::zeros, |bj| -bj.cross(&f)))
            }
        }
    }
}

/// Sphere-sphere (disc-disc in 2D) contact: n from j to i, overlap
/// r_i + r_j - |x_i - x_j|, the contact point in the middle of the overlap
/// (arms r - delta/2, LIGGGHTS's `cr`). ([`Shapes::pair`] makes the same
/// geometry after its own bounding-sphere test.)
#[inline(always)]
pub fn sphere_sphere(x_i: Vec3, r_i: f64, x_j: Vec3, r_j: f64) -> Option<ContactGeom> {
    let d = x_i - x_j;
    let dist2 = d.norm_squared();
    let rsum = r_i + r_j;
    (dist2 < rsum * rsum).then(|| spheres_apart_by(d, dist2, r_i, r_j))
}

/// Sphere-sphere geometry from the centre offset d = x_i - x_j and |d|^2,
/// known to overlap.
#[inline(always)]
fn spheres_apart_by(d: Vec3, dist2: f64, r_i: f64, r_j: f64) -> ContactGeom {
    let dist = dist2.sqrt();
    let n = d * (1.0 / dist);
    let overlap = (r_i + r_j) - dist;
    ContactGeom::spheres(n, overlap, [r_i - 0.5 * overlap, r_j - 0.5 * overlap], [r_i, r_j])
}

/// The particles' shapes for one force sweep: spheres (discs) from position
/// and radius, 2D ellipses with their orientation's sine and cosine computed
/// once per sweep. It answers "geometry of this pair" and "geometry of this
/// wall contact" for any shapes.
#[derive(Clone, Debug, Default)]
pub struct Shapes {
    /// Every particle as an ellipse (a round one with a = b), only when the run has ellipses.
    ellipses: Vec<Ellipse>,
    /// The period along each axis where the domain is periodic (else None).
    period: Option<Vec3>,
}

/// x_a - x_b of particles a and b as the list sees them: with `period`
/// (a periodic domain), across a periodic face the owners' position bits,
/// then whole periods (the images' difference, an integer times the period),
/// so every rank that evaluates the pair gets the same bits.
#[inline(always)]
pub fn pair_offset(p: &Particles, a: usize, b: usize, period: Option<&Vec3>) -> Vec3 {
    let mut d = p.pos[a] - p.pos[b];
    if let Some(l) = period {
        let (ka, kb) = (p.image[a], p.image[b]);
        for k in 0..3 {
            let n = ka[k] - kb[k];
            if n != 0 {
                d[k] += n as f64 * l[k];
            }
        }
    }
    d
}

impl Shapes {
    /// The shapes of `p` in a domain of this period (zero: not periodic along that axis).
    pub fn new(p: &Particles, period: &Vec3) -> Self {
        let ellipses = if p.ellipse.iter().any(|&e| e) { (0..p.len()).map(|i| p.ellipse_of(i)).collect() } else { Vec::new() };
        let period = (!p.image.is_empty()).then_some(*period);
        Shapes { ellipses, period }
    }

    /// Geometry of the contact of particles a (i) and b (j), if they touch.
    #[inline(always)]
    pub fn pair(&self, p: &Particles, a: usize, b: usize) -> Option<ContactGeom> {
        self.pair_within(p, a, b, 0.0)
    }

    /// Geometry of the contact of particles a (i) and b (j) if they are
    /// closer than touching plus `reach` (m, >= 0; the overlap is then down to
    /// -reach: a JKR contact that goes on beyond touching). Spheres only
    /// where `reach` > 0 (laws that reach refuse other shapes).
    #[inline(always)]
    pub fn pair_within(&self, p: &Particles, a: usize, b: usize, reach: f64) -> Option<ContactGeom> {
        // bounding spheres first (an ellipse's radius is its semi-major axis)
        let d = pair_offset(p, a, b, self.period.as_ref());
        let rsum = p.radius[a] + p.radius[b];
        let dist2 = d.norm_squared();
        if reach > 0.0 {
            let r = rsum + reach;
            return (dist2 < r * r).then(|| spheres_apart_by(d, dist2, p.radius[a], p.radius[b]));
        }
        if dist2 >= rsum * rsum {
            None
        } else if p.ellipse[a] || p.ellipse[b] {
            ellipse::pair_geometry(&self.ellipses[a], &self.ellipses[b])
        } else {
            Some(spheres_apart_by(d, dist2, p.radius[a], p.radius[b]))
        }
    }

    /// Particle i's contact with one feature of a wall (none if the wall was
    /// removed), the particle at `x` (its position, or a periodic image's).
    #[inline(always)]
    pub fn wall_hit(&self, p: &Particles, i: usize, x: &Vec3, wall: &Wall, feature: u32) -> Option<WallHit> {
        match (wall.active, p.ellipse[i]) {
            (false, _) => None,
            (true, false) => wall.contact(feature, x, p.radius[i]),
            (true, true) => wall.ellipse_contact(feature, &self.ellipses[i]),
        }
    }

    /// As [`Shapes::wall_hit`], for a contact that goes on `reach` (m, >= 0)
    /// beyond touching (its overlap then down to -reach; spheres only where
    /// `reach` > 0).
    #[inline(always)]
    pub fn wall_hit_within(&self, p: &Particles, i: usize, x: &Vec3, wall: &Wall, feature: u32, reach: f64) -> Option<WallHit> {
        if reach > 0.0 && wall.active && !p.ellipse[i] {
            return wall.contact(feature, x, p.radius[i] + reach).map(|h| WallHit { overlap: h.overlap - reach, ..h });
        }
        self.wall_hit(p, i, x, wall, feature)
    }

    /// Geometry of particle i's contact `hit` with `wall`; the force acts
    /// `arm_overlap` of the overlap back from the particle's deepest point
    /// (see [`ContactOptions::wall_arm_overlap`](super::conventions::ContactOptions)).
    #[inline(always)]
    pub fn wall(&self, p: &Particles, i: usize, wall: &Wall, hit: &WallHit, arm_overlap: f64) -> ContactGeom {
        if p.ellipse[i] {
            ellipse::wall_geometry(&self.ellipses[i], hit, arm_overlap, wall.curvature_radius())
        } else {
            hit.sphere_geometry(p.radius[i], arm_overlap)
        }
    }
}
