//! Ghosts: after each rebuild, every owned particle within `range` (largest
//! interaction distance plus skin) of another rank's box is sent to that rank
//! (direct sends to any rank in range, so thin boxes and grids need no
//! multi-hop forwarding); every other step only the same ghosts' position,
//! velocity and spin travel, by non-blocking sends of sizes both sides know.
//! With one rank there is no other box, so there are no ghosts.
//!
//! In a periodic domain the periodic images are ghosts too: a particle within
//! `range` of a box shifted by whole periods (any rank's, this rank's own
//! included) is sent there with the shift (`Particles::image`). A ghost keeps
//! the owner's position bits and its image apart, so a pair across a periodic
//! face is evaluated from the same numbers on every rank (see
//! `contact::geometry::Shapes::pair`).

use super::{bin, unbin, Parallel};
use crate::dim::Vec3;
use crate::particles::{image_shift, Particles, Record};

/// Distance from a point or box to a box (zero inside or overlapping).
fn gap(lo: &Vec3, hi: &Vec3, plo: &Vec3, phi: &Vec3) -> f64 {
    let mut d2 = 0.0;
    for k in 0..3 {
        let d = (lo[k] - phi[k]).max(plo[k] - hi[k]).max(0.0);
        d2 += d * d;
    }
    d2.sqrt()
}

/// Every image shift of a domain with this period: -1, 0, 1 periods along
/// each periodic axis (only 0 where there is none), the unshifted one first.
pub fn image_shifts(period: &Vec3) -> Vec<[i32; 3]> {
    let span = |k: usize| {
        if period[k] > 0.0 {
            vec![0, -1, 1]
        } else {
            vec![0]
        }
    };
    let mut v = Vec::new();
    for &z in &span(2) {
        for &y in &span(1) {
            for &x in &span(0) {
                v.push([x, y, z]);
            }
        }
    }
    v
}

impl Parallel {
    /// Whether the domain is periodic along any axis.
    pub fn periodic(&self) -> bool {
        self.period != Vec3::zeros()
    }

    /// Send copies of the owned particles within `range` of another rank's box
    /// (or, in a periodic domain, of any box's periodic image) to that rank;
    /// append the ones received as ghosts, then this rank's own images.
    pub(super) fn make_ghosts(&mut self, p: &mut Particles) {
        self.send.clear();
        self.send_img.clear();
        self.recv.clear();
        self.self_images.clear();
        let p_count = self.size();
        let me = self.rank();
        let periodic = self.periodic();
        let boxes: Vec<(Vec3, Vec3)> = (0..p_count).map(|r| self.dec.bounds(r)).collect();
        let (mlo, mhi) = boxes[me];
        // (as far as the widest skin of this build reaches)
        let range = self.range + self.ghost_extra;
        // (rank, image shift, the shift in m): a particle x is sent to r as
        // image g when x + shift is within range of r's box
        let mut near: Vec<(usize, [i32; 3], Vec3)> = Vec::new();
        for g in image_shifts(&self.period) {
            let s = image_shift(&g, &self.period);
            for (r, b) in boxes.iter().enumerate() {
                if (r != me || g != [0; 3]) && gap(&(b.0 - s), &(b.1 - s), &mlo, &mhi) < range {
                    near.push((r, g, s));
                }
            }
        }
        let mut lists: Vec<Vec<(u32, [i32; 3])>> = vec![Vec::new(); p_count];
        let mut own_images: Vec<(u32, [i32; 3])> = Vec::new();
        if !near.is_empty() {
            for i in 0..p.owned() {
                for &(r, g, s) in &near {
                    let x = p.pos[i] + s;
                    let (lo, hi) = boxes[r];
                    let mut d2 = 0.0;
                    for k in 0..3 {
                        let d = (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0);
                        d2 += d * d;
                    }
                    if d2 < range * range {
                        if r == me {
                            own_images.push((i as u32, g));
                        } else {
                            lists[r].push((i as u32, g));
                        }
                    }
                }
            }
        }
        let msgs: Vec<Vec<u8>> = lists
            .iter()
            .map(|l| {
                if l.is_empty() {
                    Vec::new()
                } else {
                    bin(&l.iter().map(|&(i, g)| (p.record(i as usize), g)).collect::<Vec<_>>())
                }
            })
            .collect();
        let got = self.comm.exchange_bytes(&msgs);
        let mut images: Vec<[i32; 3]> = Vec::new();
        let mut ghosts = 0;
        for (r, m) in got.iter().enumerate() {
            if r == me || m.is_empty() {
                continue;
            }
            let recs: Vec<(Record, [i32; 3])> = unbin(m);
            for (rec, g) in &recs {
                p.push_record(rec);
                images.push(*g);
            }
            ghosts += recs.len();
            self.recv.push((r, recs.len()));
        }
        for &(i, g) in &own_images {
            let rec = p.record(i as usize);
            p.push_record(&rec);
            images.push(g);
        }
        ghosts += own_images.len();
        self.self_images = own_images;
        p.ghosts = ghosts;
        p.image.clear();
        if periodic {
            p.image.resize(p.owned(), [0; 3]);
            p.image.extend(images);
        }
        for (r, l) in lists.into_iter().enumerate() {
            if !l.is_empty() {
                self.send_img.push(l.iter().map(|x| x.1).collect());
                self.send.push((r, l.into_iter().map(|x| x.0).collect()));
            }
        }
    }

    /// Refresh the ghosts' position, velocity and spin (every step the lists
    /// are not rebuilt); in a periodic domain also their images (the owner's
    /// image, which counts its wraps since the rebuild, plus the ghost's shift).
    pub fn update_ghosts(&self, p: &mut Particles) {
        let periodic = self.periodic();
        let stride = if periodic { 12 } else { 9 };
        let to: Vec<usize> = self.send.iter().map(|s| s.0).collect();
        let sends: Vec<Vec<f64>> = self
            .send
            .iter()
            .enumerate()
            .map(|(s, (_, l))| {
                let mut b = Vec::with_capacity(stride * l.len());
                for (j, &i) in l.iter().enumerate() {
                    let i = i as usize;
                    for v in [p.pos[i], p.vel[i], p.omega[i]] {
                        b.extend_from_slice(&[v.x, v.y, v.z]);
                    }
                    if periodic {
                        let (k, g) = (p.image[i], self.send_img[s][j]);
                        b.extend((0..3).map(|a| (k[a] + g[a]) as f64));
                    }
                }
                b
            })
            .collect();
        let from: Vec<usize> = self.recv.iter().map(|r| r.0).collect();
        let mut recvs: Vec<Vec<f64>> = self.recv.iter().map(|r| vec![0.0; stride * r.1]).collect();
        self.comm.exchange_f64(&to, &sends, &from, &mut recvs);
        let mut g = p.owned();
        for b in &recvs {
            for c in b.chunks_exact(stride) {
                p.pos[g] = Vec3::new(c[0], c[1], c[2]);
                p.vel[g] = Vec3::new(c[3], c[4], c[5]);
                p.omega[g] = Vec3::new(c[6], c[7], c[8]);
                if periodic {
                    p.image[g] = [c[9] as i32, c[10] as i32, c[11] as i32];
                }
                g += 1;
            }
        }
        for &(i, s) in &self.self_images {
            let i = i as usize;
            p.pos[g] = p.pos[i];
            p.vel[g] = p.vel[i];
            p.omega[g] = p.omega[i];
            let k = p.image[i];
            p.image[g] = [k[0] + s[0], k[1] + s[1], k[2] + s[2]];
            g += 1;
        }
    }

    /// Bring every owned particle that left the domain through a periodic face
    /// back through the opposite one, counting the period in its image (so the
    /// place its ghosts and the list see does not jump). The same for every
    /// particle whatever the number of ranks: it depends on its position only.
    pub fn wrap(&self, p: &mut Particles, lo: &Vec3, hi: &Vec3) {
        if !self.periodic() {
            return;
        }
        for i in 0..p.owned() {
            for k in 0..3 {
                let l = self.period[k];
                if l == 0.0 {
                    continue;
                }
                let x = p.pos[i][k];
                if x >= hi[k] {
                    p.pos[i][k] = x - l;
                    p.image[i][k] += 1;
                } else if x < lo[k] {
                    let w = x + l;
                    // rounding can land exactly on hi: that is the point lo
                    p.pos[i][k] = if w >= hi[k] { lo[k] } else { w };
                    p.image[i][k] -= 1;
                }
                // a particle more than a period out is left for the domain check
            }
        }
    }
}
