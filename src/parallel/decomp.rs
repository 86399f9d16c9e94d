//! Domain decomposition by parallel cutting planes (the hopper paper, section 3).
//!
//! The domain is cut by planes normal to a first axis into `n[0]` slabs; each
//! slab by planes normal to a second axis into `n[1]` columns; each column by
//! planes normal to the third axis into `n[2]` boxes. One box per rank, rank =
//! (i0 n1 + i1) n2 + i2. With n = [P, 1, 1] these are the paper's slabs. Planes
//! are placed at weighted quantiles of the particles: each subdomain gets an
//! equal share of the weight (1 per particle at the start; the estimated cost
//! per particle when balancing).

use crate::dim::Vec3;
use crate::parallel::comm::Comm;
use serde::{Deserialize, Serialize};

/// Bins of the load histogram along a cut axis (the planes are then placed to
/// within extent / BINS, by linear interpolation inside a bin).
const BINS: usize = 4096;

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Decomposition {
    /// Axis indices (0 = x, 1 = y, 2 = z) in cutting order.
    pub axes: [usize; 3],
    /// Number of boxes along each of `axes`.
    pub n: [usize; 3],
    pub lo: Vec3,
    pub hi: Vec3,
    /// Plane positions along axes[0]: n0 + 1 values from lo to hi.
    pub cuts0: Vec<f64>,
    /// Per slab, n1 + 1 values along axes[1].
    pub cuts1: Vec<Vec<f64>>,
    /// Per column (slab * n1 + column), n2 + 1 values along axes[2].
    pub cuts2: Vec<Vec<f64>>,
}

/// Split P into a grid nx * ny * nz that minimises the area of the cuts for a
/// domain of extent `ext` (ties go to fewer cuts along x). Returns counts per axis x, y, z.
pub fn choose_grid(p: usize, ext: Vec3) -> [usize; 3] {
    let mut best = ([p, 1, 1], f64::INFINITY);
    for nx in 1..=p {
        if p % nx != 0 {
            continue;
        }
        for ny in 1..=p / nx {
            if (p / nx) % ny != 0 {
                continue;
            }
            let nz = p / nx / ny;
            // total area of internal planes
            let area = (nx - 1) as f64 * ext.y * ext.z + (ny - 1) as f64 * ext.x * ext.z + (nz - 1) as f64 * ext.x * ext.y;
            if area < best.1 * (1.0 - 1e-9) {
                best = ([nx, ny, nz], area);
            }
        }
    }
    best.0
}

fn find(cuts: &[f64], x: f64) -> usize {
    // index k with cuts[k] <= x < cuts[k+1], clamped to the ends
    let n = cuts.len() - 1;
    let k = cuts[1..n].partition_point(|&c| c <= x);
    k.min(n - 1)
}

fn even(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|k| if k == n { hi } else { lo + (hi - lo) * k as f64 / n as f64 }).collect()
}

/// Planes at equal shares of a histogram's weight (bins of equal width over [lo, hi]).
fn quantile_cuts(hist: &[f64], lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let total: f64 = hist.iter().sum();
    if !(total > 0.0) {
        return even(lo, hi, n);
    }
    let w = (hi - lo) / hist.len() as f64;
    let mut cuts = vec![lo];
    let mut acc = 0.0;
    let mut b = 0;
    for k in 1..n {
        let target = total * k as f64 / n as f64;
        while b < hist.len() && acc + hist[b] < target {
            acc += hist[b];
            b += 1;
        }
        let x = if b >= hist.len() {
            hi
        } else {
            let f = if hist[b] > 0.0 { (target - acc) / hist[b] } else { 0.0 };
            lo + w * (b as f64 + f)
        };
        cuts.push(x.max(*cuts.last().unwrap()));
    }
    cuts.push(hi);
    cuts
}

impl Decomposition {
    /// Even planes over the domain, for a grid (counts per axis x, y, z).
    pub fn new(grid: [usize; 3], lo: Vec3, hi: Vec3) -> Decomposition {
        let mut axes = [0usize, 1, 2];
        // the axis with the most boxes is cut first
        axes.sort_by_key(|&a| std::cmp::Reverse(grid[a]));
        let n = [grid[axes[0]], grid[axes[1]], grid[axes[2]]];
        let cuts0 = even(lo[axes[0]], hi[axes[0]], n[0]);
        let cuts1 = vec![even(lo[axes[1]], hi[axes[1]], n[1]); n[0]];
        let cuts2 = vec![even(lo[axes[2]], hi[axes[2]], n[2]); n[0] * n[1]];
        Decomposition { axes, n, lo, hi, cuts0, cuts1, cuts2 }
    }

    /// Boxes along x, y, z.
    pub fn grid(&self) -> [usize; 3] {
        let mut g = [1; 3];
        for k in 0..3 {
            g[self.axes[k]] = self.n[k];
        }
        g
    }

    pub fn ranks(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }

    /// The rank owning a point (points outside the domain go to the nearest box).
    pub fn owner(&self, x: &Vec3) -> usize {
        let i0 = find(&self.cuts0, x[self.axes[0]]);
        let i1 = find(&self.cuts1[i0], x[self.axes[1]]);
        let c = i0 * self.n[1] + i1;
        let i2 = find(&self.cuts2[c], x[self.axes[2]]);
        c * self.n[2] + i2
    }

    /// The box of a rank.
    pub fn bounds(&self, r: usize) -> (Vec3, Vec3) {
        let i2 = r % self.n[2];
        let c = r / self.n[2];
        let i1 = c % self.n[1];
        let i0 = c / self.n[1];
        let mut lo = self.lo;
        let mut hi = self.hi;
        let (a0, a1, a2) = (self.axes[0], self.axes[1], self.axes[2]);
        lo[a0] = self.cuts0[i0];
        hi[a0] = self.cuts0[i0 + 1];
        lo[a1] = self.cuts1[i0][i1];
        hi[a1] = self.cuts1[i0][i1 + 1];
        lo[a2] = self.cuts2[c][i2];
        hi[a2] = self.cuts2[c][i2 + 1];
        (lo, hi)
    }

    /// Distance from a point to a rank's box (0 inside).
    pub fn distance_to(&self, r: usize, x: &Vec3) -> f64 {
        let (lo, hi) = self.bounds(r);
        let mut d2 = 0.0;
        for k in 0..3 {
            let d = (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0);
            d2 += d * d;
        }
        d2.sqrt()
    }

    /// Move the planes so that every box holds an equal share of the weight of
    /// the particles (positions `x`, weights `w`, this rank's part; a collective
    /// over `comm`). Slabs first, then columns within each slab, then boxes
    /// within each column, each from a histogram summed over all ranks.
    pub fn fit(&mut self, comm: &Comm, x: &[Vec3], w: &[f64]) {
        let (a0, a1, a2) = (self.axes[0], self.axes[1], self.axes[2]);
        let bin = |a: usize, v: f64| -> usize {
            let f = (v - self.lo[a]) / (self.hi[a] - self.lo[a]);
            ((f * BINS as f64).floor().max(0.0) as usize).min(BINS - 1)
        };
        // slabs
        let mut h = vec![0.0; BINS];
        for (xi, wi) in x.iter().zip(w) {
            h[bin(a0, xi[a0])] += wi;
        }
        comm.sum_f64(&mut h);
        self.cuts0 = quantile_cuts(&h, self.lo[a0], self.hi[a0], self.n[0]);
        // columns in each slab
        if self.n[1] > 1 {
            let mut h = vec![0.0; BINS * self.n[0]];
            for (xi, wi) in x.iter().zip(w) {
                let s = find(&self.cuts0, xi[a0]);
                h[s * BINS + bin(a1, xi[a1])] += wi;
            }
            comm.sum_f64(&mut h);
            for s in 0..self.n[0] {
                self.cuts1[s] = quantile_cuts(&h[s * BINS..(s + 1) * BINS], self.lo[a1], self.hi[a1], self.n[1]);
            }
        }
        // boxes in each column
        if self.n[2] > 1 {
            let nc = self.n[0] * self.n[1];
            let mut h = vec![0.0; BINS * nc];
            for (xi, wi) in x.iter().zip(w) {
                let s = find(&self.cuts0, xi[a0]);
                let c = s * self.n[1] + find(&self.cuts1[s], xi[a1]);
                h[c * BINS + bin(a2, xi[a2])] += wi;
            }
            comm.sum_f64(&mut h);
            for c in 0..nc {
                self.cuts2[c] = quantile_cuts(&h[c * BINS..(c + 1) * BINS], self.lo[a2], self.hi[a2], self.n[2]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_follows_the_domain_shape() {
        assert_eq!(choose_grid(2, Vec3::new(0.2, 0.2, 0.4)), [1, 1, 2]);
        assert_eq!(choose_grid(4, Vec3::new(1.0, 1.0, 1.0)), [1, 2, 2]);
        assert_eq!(choose_grid(8, Vec3::new(1.0, 1.0, 1.0)), [2, 2, 2]);
        assert_eq!(choose_grid(3, Vec3::new(0.1, 0.1, 0.5)), [1, 1, 3]);
    }

    #[test]
    fn planes_split_the_weight_evenly_and_boxes_tile_the_domain() {
        let lo = Vec3::new(0.0, 0.0, 0.0);
        let hi = Vec3::new(1.0, 1.0, 1.0);
        let mut d = Decomposition::new([2, 2, 2], lo, hi);
        // particles crowded towards low z and low x
        let x: Vec<Vec3> = (0..20000)
            .map(|k| {
                let f = |m: u64| ((k as u64 * m) % 10007) as f64 / 10007.0;
                Vec3::new(f(7919).powi(2), f(104729), f(1299709).powi(3))
            })
            .collect();
        let w = vec![1.0; x.len()];
        d.fit(&Comm::Serial, &x, &w);
        let mut count = vec![0usize; 8];
        for xi in &x {
            let r = d.owner(xi);
            let (a, b) = d.bounds(r);
            assert!((0..3).all(|k| xi[k] >= a[k] - 1e-12 && xi[k] <= b[k] + 1e-12));
            count[r] += 1;
        }
        for c in count {
            assert!((c as f64 - 2500.0).abs() < 25.0, "{c}");
        }
    }
}
