//! Particle storage: structure of arrays, dense local indices, stable global ids.
//!
//! Local order is the order of increasing global id (the lattice generator and
//! the CSV loader assign ids so that neighbours in space have close ids). Later,
//! with MPI, owned particles come first and ghosts after.

use crate::dim::Vec3;
use crate::fixed::{from_fixed, to_fixed};
use serde::{Deserialize, Serialize};

/// `$m!(a, b, ...)` over every per-particle array of [`Particles`] but
/// `image` (periodic domains only): the one list the operations on whole
/// particles (drop the ghosts, keep some, reorder) go through, so an array
/// added to `Particles` is added here once.
macro_rules! every_array {
    ($m:ident) => {
        $m!(id, pos, vel, omega, force, torque, radius, mass, inv_mass, inv_inertia, material, clump, ellipse, minor, angle)
    };
}

/// Spheres (3D) or discs (2D), one entry per particle in each array.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Particles {
    /// Stable global id, unique in the run.
    pub id: Vec<u64>,
    pub pos: Vec<Vec3>,
    pub vel: Vec<Vec3>,
    /// Angular velocity (rad/s).
    pub omega: Vec<Vec3>,
    pub force: Vec<Vec3>,
    pub torque: Vec<Vec3>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// 1 / I, with I = 2/5 m r^2 for a sphere.
    pub inv_inertia: Vec<f64>,
    /// Material index into the case's material list.
    pub material: Vec<u16>,
    /// Clump (rigid body) each particle belongs to, 1-based; 0 = a free particle.
    #[serde(default)]
    pub clump: Vec<u32>,
    /// Whether the particle is an ellipse (2D): then `radius` is its semi-major
    /// axis a (the bounding circle every neighbour search uses) and `minor` its
    /// semi-minor axis b; a round particle has minor = radius.
    #[serde(default)]
    pub ellipse: Vec<bool>,
    #[serde(default)]
    pub minor: Vec<f64>,
    /// Orientation about z of the body x axis (the major axis of an ellipse),
    /// rad; integrated from the spin in 2D.
    #[serde(default)]
    pub angle: Vec<f64>,
    /// The last `ghosts` entries are copies of particles owned by other ranks
    /// (and, in a periodic domain, periodic images of any rank's, this one's too).
    #[serde(default)]
    pub ghosts: usize,
    /// Periodic domains only (else empty): each particle's image, the whole
    /// periods to add to its position to place it where the neighbour list
    /// sees it (`list_pos`). Made with the ghosts at each list rebuild (an
    /// owned particle's is 0 then, a ghost's its image's shift); an owned
    /// particle wrapped back into the domain between rebuilds counts the
    /// period it crossed here, so `pos + image * period` moves continuously.
    #[serde(skip)]
    pub image: Vec<[i32; 3]>,
}

/// One particle's full record: what migrates to another rank, what a ghost is
/// made from, and what a checkpoint stores.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct Record {
    pub id: u64,
    pub pos: Vec3,
    pub vel: Vec3,
    pub omega: Vec3,
    pub force: Vec3,
    pub torque: Vec3,
    pub radius: f64,
    pub mass: f64,
    pub inv_mass: f64,
    pub inv_inertia: f64,
    pub material: u16,
    #[serde(default)]
    pub clump: u32,
    #[serde(default)]
    pub ellipse: bool,
    #[serde(default)]
    pub minor: f64,
    #[serde(default)]
    pub angle: f64,
}

/// One particle as read from input, before it enters the arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleInit {
    pub id: u64,
    pub pos: Vec3,
    pub vel: Vec3,
    pub omega: Vec3,
    pub radius: f64,
}

impl Particles {
    pub fn len(&self) -> usize {
        self.id.len()
    }
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }
    /// Number of particles this rank owns (they come first).
    #[inline(always)]
    pub fn owned(&self) -> usize {
        self.id.len() - self.ghosts
    }

    /// Where the neighbour search sees particle i: its position plus its
    /// periodic image's shift (`period` zero along axes that are not periodic;
    /// the position itself where the domain is not periodic).
    #[inline]
    pub fn list_pos(&self, i: usize, period: &Vec3) -> Vec3 {
        match self.image.get(i) {
            Some(k) => self.pos[i] + image_shift(k, period),
            None => self.pos[i],
        }
    }

    pub fn record(&self, i: usize) -> Record {
        Record {
            id: self.id[i],
            pos: self.pos[i],
            vel: self.vel[i],
            omega: self.omega[i],
            force: self.force[i],
            torque: self.torque[i],
            radius: self.radius[i],
            mass: self.mass[i],
            inv_mass: self.inv_mass[i],
            inv_inertia: self.inv_inertia[i],
            material: self.material[i],
            clump: self.clump[i],
            ellipse: self.ellipse[i],
            minor: self.minor[i],
            angle: self.angle[i],
        }
    }

    pub fn push_record(&mut self, r: &Record) {
        self.id.push(r.id);
        self.pos.push(r.pos);
        self.vel.push(r.vel);
        self.omega.push(r.omega);
        self.force.push(r.force);
        self.torque.push(r.torque);
        self.radius.push(r.radius);
        self.mass.push(r.mass);
        self.inv_mass.push(r.inv_mass);
        self.inv_inertia.push(r.inv_inertia);
        self.material.push(r.material);
        self.clump.push(r.clump);
        self.ellipse.push(r.ellipse);
        self.minor.push(r.minor);
        self.angle.push(r.angle);
    }

    /// Drop the ghosts.
    pub fn drop_ghosts(&mut self) {
        let n = self.owned();
        macro_rules! cut {
            ($($f:ident),*) => { $( self.$f.truncate(n); )* };
        }
        every_array!(cut);
        self.image.truncate(n.min(self.image.len()));
        self.ghosts = 0;
    }

    /// Add a sphere of the given density and material index.
    pub fn push_sphere(&mut self, p: &ParticleInit, density: f64, material: u16) {
        let mass = density * 4.0 / 3.0 * std::f64::consts::PI * p.radius.powi(3);
        let inertia = 0.4 * mass * p.radius * p.radius;
        self.id.push(p.id);
        self.pos.push(p.pos);
        self.vel.push(p.vel);
        self.omega.push(p.omega);
        self.force.push(Vec3::zeros());
        self.torque.push(Vec3::zeros());
        self.radius.push(p.radius);
        self.mass.push(mass);
        self.inv_mass.push(1.0 / mass);
        self.inv_inertia.push(1.0 / inertia);
        self.material.push(material);
        self.clump.push(0);
        self.ellipse.push(false);
        self.minor.push(p.radius);
        self.angle.push(0.0);
    }

    /// Make particle i an ellipse of aspect ratio a/b = `aspect` with the area
    /// (and mass) of its present disc, pi a b = pi r^2, at orientation `angle`.
    /// Mass stays that of the equivalent sphere (as for discs in 2D, LIGGGHTS's
    /// convention); the moment of inertia is that of the ellipsoid with semi-axes
    /// a, b, r about its c axis, m (a^2 + b^2) / 5 (2/5 m r^2 at aspect ratio 1).
    pub fn make_ellipse(&mut self, i: usize, aspect: f64, angle: f64) {
        let r = (self.radius[i] * self.minor[i]).sqrt();
        self.set_shape(i, r * aspect.sqrt(), r / aspect.sqrt(), 1.0 / self.inv_mass[i]);
        self.ellipse[i] = true;
        self.angle[i] = angle;
    }

    /// Semi-axes a >= b and mass of particle i; inertia follows (m (a^2 + b^2) / 5).
    pub fn set_shape(&mut self, i: usize, a: f64, b: f64, mass: f64) {
        self.radius[i] = a;
        self.minor[i] = b;
        self.mass[i] = mass;
        self.inv_mass[i] = 1.0 / mass;
        // a disc keeps the sphere's 2/5 m r^2 to the bit
        self.inv_inertia[i] = 1.0 / if a == b { 0.4 * mass * a * a } else { 0.2 * mass * (a * a + b * b) };
    }

    /// The ellipse of particle i (a round particle as an ellipse with a = b).
    #[inline(always)]
    pub fn ellipse_of(&self, i: usize) -> crate::contact::ellipse::Ellipse {
        crate::contact::ellipse::Ellipse::new(self.pos[i], self.radius[i], self.minor[i], self.angle[i])
    }

    /// Sort every array by global id (stable local order); no ghosts.
    pub fn sort_by_id(&mut self) {
        let mut perm: Vec<usize> = (0..self.len()).collect();
        perm.sort_by_key(|&i| self.id[i]);
        self.permute(&perm);
    }

    /// Keep only the particles at places `keep` (increasing), in that order,
    /// moved down in place (no ghosts).
    pub fn keep_places(&mut self, keep: &[usize]) {
        debug_assert!(keep.windows(2).all(|w| w[0] < w[1]));
        self.ghosts = 0;
        self.image.clear();
        macro_rules! keep {
            ($($f:ident),*) => { $(
                for (j, &i) in keep.iter().enumerate() {
                    self.$f[j] = self.$f[i];
                }
                self.$f.truncate(keep.len());
            )* };
        }
        every_array!(keep);
    }

    /// A copy of the particles at places `perm`, in that order (entry k is
    /// entry perm[k] here), no ghosts: each array made at its size.
    pub fn selected(&self, perm: &[usize]) -> Particles {
        let mut q = Particles::default();
        macro_rules! select {
            ($($f:ident),*) => { $( q.$f = perm.iter().map(|&i| self.$f[i]).collect(); )* };
        }
        every_array!(select);
        q
    }

    /// The particles of `other` (owned only, no periodic images) after these.
    pub fn append(&mut self, mut other: Particles) {
        debug_assert!(self.ghosts == 0 && other.ghosts == 0 && self.image.is_empty() && other.image.is_empty());
        macro_rules! append {
            ($($f:ident),*) => { $( self.$f.append(&mut other.$f); )* };
        }
        every_array!(append);
    }

    /// Reorder (or select) particles: entry k becomes old entry perm[k]. Ghosts are dropped.
    pub fn permute(&mut self, perm: &[usize]) {
        self.ghosts = 0;
        self.image.clear();
        macro_rules! permute {
            ($($f:ident),*) => { $( self.$f = perm.iter().map(|&i| self.$f[i]).collect(); )* };
        }
        every_array!(permute);
    }

    /// The particles as initial conditions (for writing a cloud file), in order of id.
    pub fn to_inits(&self) -> Vec<ParticleInit> {
        let mut v: Vec<ParticleInit> = (0..self.len())
            .map(|i| ParticleInit { id: self.id[i], pos: self.pos[i], vel: self.vel[i], omega: self.omega[i], radius: self.radius[i] })
            .collect();
        v.sort_by_key(|x| x.id);
        v
    }

    /// Local index of a global id (linear search; used for set-up and probes only).
    pub fn index_of(&self, id: u64) -> Option<usize> {
        self.id.iter().position(|&x| x == id)
    }

    /// Kinetic energy of particle i, translational plus rotational (J).
    #[inline(always)]
    fn kinetic_energy_of(&self, i: usize) -> f64 {
        0.5 * self.mass[i] * self.vel[i].norm_squared() + 0.5 / self.inv_inertia[i] * self.omega[i].norm_squared()
    }

    /// Kinetic energy of the owned particles, translational plus rotational,
    /// as an exact fixed-point sum (see `crate::fixed`).
    pub fn kinetic_energy_fixed(&self) -> i128 {
        (0..self.owned()).map(|i| to_fixed(self.kinetic_energy_of(i))).sum()
    }

    /// The same in floating point, summed in storage order: cheaper (no
    /// conversion per particle), for checks, not for results.
    pub fn kinetic_energy_float(&self) -> f64 {
        (0..self.owned()).map(|i| self.kinetic_energy_of(i)).sum()
    }

    /// Potential energy of the owned particles in gravity g relative to the origin, fixed point.
    pub fn potential_energy_fixed(&self, g: Vec3) -> i128 {
        (0..self.owned()).map(|i| to_fixed(-self.mass[i] * g.dot(&self.pos[i]))).sum()
    }

    /// Kinetic energy of the owned particles (J).
    pub fn kinetic_energy(&self) -> f64 {
        from_fixed(self.kinetic_energy_fixed())
    }

    /// Potential energy of the owned particles (J).
    pub fn potential_energy(&self, g: Vec3) -> f64 {
        from_fixed(self.potential_energy_fixed(g))
    }

    pub fn total_mass(&self) -> f64 {
        self.mass[..self.owned()].iter().sum()
    }
}

/// The shift of a periodic image `k` (whole periods along each axis), m.
#[inline]
pub fn image_shift(k: &[i32; 3], period: &Vec3) -> Vec3 {
    Vec3::new(k[0] as f64 * period.x, k[1] as f64 * period.y, k[2] as f64 * period.z)
}
