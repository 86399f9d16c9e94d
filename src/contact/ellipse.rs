//! Ellipse contact geometry in 2D (the drag paper's elliptical granules, its
//! eqs. 7-17), by the minimum-translation (separating-axis) method for smooth
//! convex bodies, which the paper's numerical boundary search approximates.
//!
//! An ellipse with centre c, semi-axes a >= b and orientation theta has the
//! support function h(n) = sqrt(n^T A n), A = R diag(a^2, b^2) R^T: the
//! farthest reach of the body along the unit direction n. Along n (pointing from
//! body 1 to body 2) the gap is s(n) = n.(c2 - c1) - h1(n) - h2(-n). Two convex
//! bodies are apart exactly when some direction has s > 0, and the overlap (the
//! shortest translation that separates them) is delta = -max_n s(n), reached at
//! the contact normal n*. So:
//!
//! 1. bounding circles: no contact if |c2 - c1| >= a1 + a2;
//! 2. s(phi) is sampled at 64 angles and every sampled local maximum refined by
//!    golden-section search on its bracket; the best is kept (s is smooth; nearly
//!    concentric pairs have several local maxima, which is why all are refined);
//! 3. overlap delta = -s(n*), normal n*, contact point halfway between the two
//!    support points c1 + A1 n / h1 and c2 - A2 n / h2.
//!
//! The result is symmetric in the pair (swapping the bodies flips n), equal to
//! the disc formula r1 + r2 - |c2 - c1| at aspect ratio 1, and continuous as the
//! bodies move. Against a wall (plane through q with unit normal m into the
//! domain): delta = h(m) - (c - q).m, point c - A m / h (the paper's eq. 17).

use crate::dim::Vec3;

/// An ellipse in the x-y plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    pub c: Vec3,
    /// Semi-axes, a along the body x axis.
    pub a: f64,
    pub b: f64,
    /// Orientation of the body x axis (rad).
    pub theta: f64,
}

/// A contact: overlap > 0, unit normal from body 1 to body 2, contact point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EllipseContact {
    pub overlap: f64,
    pub n: Vec3,
    pub point: Vec3,
}

impl Ellipse {
    /// A n (the support point offset is A n / h(n)).
    #[inline(always)]
    fn a_times(&self, nx: f64, ny: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        // local components
        let u = c * nx + s * ny;
        let v = -s * nx + c * ny;
        let (u, v) = (self.a * self.a * u, self.b * self.b * v);
        (c * u - s * v, s * u + c * v)
    }

    /// Support function h(n) for a unit n.
    #[inline(always)]
    pub fn support(&self, nx: f64, ny: f64) -> f64 {
        let (ax, ay) = self.a_times(nx, ny);
        (nx * ax + ny * ay).sqrt()
    }

    /// The boundary point whose outward normal is n (unit).
    pub fn support_point(&self, nx: f64, ny: f64) -> Vec3 {
        let (ax, ay) = self.a_times(nx, ny);
        let h = (nx * ax + ny * ay).sqrt();
        self.c + Vec3::new(ax / h, ay / h, 0.0)
    }

    /// Contact with a plane through q with unit normal m (pointing into the domain).
    pub fn wall_contact(&self, q: Vec3, m: Vec3) -> Option<EllipseContact> {
        let h = self.support(-m.x, -m.y);
        let overlap = h - (self.c - q).dot(&m);
        (overlap > 0.0).then(|| EllipseContact { overlap, n: -m, point: self.support_point(-m.x, -m.y) + m * (0.5 * overlap) })
    }
}

/// Gap along the direction of angle phi (from body 1 to body 2).
#[inline(always)]
fn gap(e1: &Ellipse, e2: &Ellipse, d: Vec3, phi: f64) -> f64 {
    let (ny, nx) = phi.sin_cos();
    nx * d.x + ny * d.y - e1.support(nx, ny) - e2.support(-nx, -ny)
}

/// Golden-section search for the maximum of the gap on [phi - w, phi + w].
fn golden_max(e1: &Ellipse, e2: &Ellipse, d: Vec3, phi: f64, w: f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (phi - w, phi + w);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (gap(e1, e2, d, x1), gap(e1, e2, d, x2));
    for _ in 0..60 {
        if f1 > f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = gap(e1, e2, d, x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = gap(e1, e2, d, x2);
        }
    }
    if f1 > f2 { (x1, f1) } else { (x2, f2) }
}

/// Contact of two ellipses, if they overlap.
pub fn contact(e1: &Ellipse, e2: &Ellipse) -> Option<EllipseContact> {
    let d = e2.c - e1.c;
    if d.norm() >= e1.a + e2.a {
        return None;
    }
    const N: usize = 64;
    let step = std::f64::consts::TAU / N as f64;
    let phi0 = d.y.atan2(d.x);
    let samples: [f64; N] = std::array::from_fn(|k| gap(e1, e2, d, phi0 + k as f64 * step));
    // refine every sampled local maximum (near-concentric pairs have several)
    let (mut phi, mut s) = (phi0, f64::NEG_INFINITY);
    for k in 0..N {
        let (prev, next) = (samples[(k + N - 1) % N], samples[(k + 1) % N]);
        if samples[k] >= prev && samples[k] >= next {
            let (p, v) = golden_max(e1, e2, d, phi0 + k as f64 * step, step);
            let (p, v) = if v >= samples[k] { (p, v) } else { (phi0 + k as f64 * step, samples[k]) };
            if v > s {
                phi = p;
                s = v;
            }
        }
    }
    if s >= 0.0 {
        return None;
    }
    let (ny, nx) = phi.sin_cos();
    let p1 = e1.support_point(nx, ny);
    let p2 = e2.support_point(-nx, -ny);
    Some(EllipseContact { overlap: -s, n: Vec3::new(nx, ny, 0.0), point: (p1 + p2) * 0.5 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ell(x: f64, y: f64, a: f64, b: f64, t: f64) -> Ellipse {
        Ellipse { c: Vec3::new(x, y, 0.0), a, b, theta: t }
    }

    /// Whether two ellipses' inscribed polygons (k vertices) overlap (separating axis over polygon edges).
    fn polygons_overlap(e1: &Ellipse, e2: &Ellipse, k: usize) -> bool {
        let poly = |e: &Ellipse| -> Vec<(f64, f64)> {
            (0..k)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / k as f64;
                    let (u, v) = (e.a * t.cos(), e.b * t.sin());
                    let (s, c) = e.theta.sin_cos();
                    (e.c.x + c * u - s * v, e.c.y + s * u + c * v)
                })
                .collect()
        };
        let (p, q) = (poly(e1), poly(e2));
        for poly_edges in [&p, &q] {
            for i in 0..k {
                let (x0, y0) = poly_edges[i];
                let (x1, y1) = poly_edges[(i + 1) % k];
                let (nx, ny) = (y1 - y0, x0 - x1);
                let proj = |pts: &Vec<(f64, f64)>| {
                    pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(x, y)| {
                        let v = nx * x + ny * y;
                        (lo.min(v), hi.max(v))
                    })
                };
                let (a, b) = (proj(&p), proj(&q));
                if a.1 < b.0 || b.1 < a.0 {
                    return false;
                }
            }
        }
        true
    }

    #[test]
    fn discs_are_the_aspect_ratio_one_limit() {
        let e1 = ell(0.0, 0.0, 1.0, 1.0, 0.3);
        let e2 = ell(1.5, 0.4, 0.8, 0.8, -1.0);
        let c = contact(&e1, &e2).unwrap();
        let d = (e2.c - e1.c).norm();
        assert!((c.overlap - (1.8 - d)).abs() < 1e-12);
        assert!((c.n - (e2.c - e1.c) / d).norm() < 1e-6);
    }

    #[test]
    fn an_ellipse_on_a_wall_follows_the_support_function() {
        // a = 2, b = 1 lying at 90 degrees on the floor y = 0: reaches down by a
        let e = ell(0.0, 1.9, 2.0, 1.0, std::f64::consts::FRAC_PI_2);
        let c = e.wall_contact(Vec3::zeros(), Vec3::new(0.0, 1.0, 0.0)).unwrap();
        assert!((c.overlap - 0.1).abs() < 1e-12);
        assert!(c.point.x.abs() < 1e-12);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        #[test]
        fn symmetric_in_the_pair(x in -2.0..2.0f64, y in -2.0..2.0f64, a1 in 0.5..1.0f64, r1 in 1.0..2.0f64,
                                 a2 in 0.5..1.0f64, r2 in 1.0..2.0f64, t1 in 0.0..6.3f64, t2 in 0.0..6.3f64) {
            let e1 = ell(0.0, 0.0, a1 * r1, a1, t1);
            let e2 = ell(x, y, a2 * r2, a2, t2);
            match (contact(&e1, &e2), contact(&e2, &e1)) {
                (Some(p), Some(q)) => {
                    prop_assert!((p.overlap - q.overlap).abs() < 1e-9 * (1.0 + p.overlap));
                    prop_assert!((p.n + q.n).norm() < 1e-4);
                }
                (None, None) => {}
                (p, q) => prop_assert!(p.map_or(0.0, |c| c.overlap) + q.map_or(0.0, |c| c.overlap) < 1e-9),
            }
        }

        #[test]
        fn no_contact_missed_that_a_fine_polygon_test_finds(x in -2.5..2.5f64, y in -2.5..2.5f64, r1 in 1.0..2.0f64,
                                                            r2 in 1.0..2.0f64, t1 in 0.0..6.3f64, t2 in 0.0..6.3f64) {
            let e1 = ell(0.0, 0.0, r1, 1.0, t1);
            let e2 = ell(x, y, 0.8 * r2, 0.8, t2);
            if polygons_overlap(&e1, &e2, 256) {
                prop_assert!(contact(&e1, &e2).is_some(), "polygons overlap, ellipses reported apart");
            }
        }

        #[test]
        fn overlap_is_continuous_as_one_ellipse_slides_past_another(y in -0.5..0.5f64, t1 in 0.0..6.3f64, t2 in 0.0..6.3f64) {
            let e1 = ell(0.0, 0.0, 1.375, 1.0, t1);
            let h = 1e-3;
            let mut prev: Option<f64> = None;
            for k in 0..4000 {
                let x = -3.0 + h * k as f64;
                let ov = contact(&e1, &ell(x, y, 1.375, 1.0, t2)).map_or(0.0, |c| c.overlap);
                if let Some(p) = prev {
                    // the overlap changes by at most the distance moved
                    prop_assert!((ov - p).abs() <= h * (1.0 + 1e-6), "jump {} at x = {x}", ov - p);
                }
                prev = Some(ov);
            }
        }
    }
}
