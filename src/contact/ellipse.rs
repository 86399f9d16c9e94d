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

use super::geometry::{ContactGeom, Lever};
use crate::dim::Vec3;
use crate::walls::WallHit;

/// An ellipse in the x-y plane (make it with [`Ellipse::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    pub c: Vec3,
    /// Semi-axes, a along the body x axis.
    pub a: f64,
    pub b: f64,
    /// Orientation of the body x axis (rad).
    pub theta: f64,
    /// sin and cos of theta.
    pub sc: (f64, f64),
}

/// A contact: overlap > 0, unit normal from body 1 to body 2, contact point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EllipseContact {
    pub overlap: f64,
    pub n: Vec3,
    pub point: Vec3,
}

impl Ellipse {
    pub fn new(c: Vec3, a: f64, b: f64, theta: f64) -> Ellipse {
        Ellipse { c, a, b, theta, sc: theta.sin_cos() }
    }

    /// A n (the support point offset is A n / h(n)).
    #[inline(always)]
    fn a_times(&self, nx: f64, ny: f64) -> (f64, f64) {
        let (s, c) = self.sc;
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

    /// Contact with a plane through q with unit normal m (pointing into the
    /// domain): overlap h(-m) - (c - q).m (the paper's eq. 17). Returns the
    /// normal from the wall to the ellipse (m) and the ellipse's deepest point.
    pub fn wall_contact(&self, q: Vec3, m: Vec3) -> Option<EllipseContact> {
        let h = self.support(-m.x, -m.y);
        let overlap = h - (self.c - q).dot(&m);
        (overlap > 0.0).then(|| EllipseContact { overlap, n: m, point: self.support_point(-m.x, -m.y) })
    }
}

/// Golden-section search for the maximum of f on [phi - w, phi + w].
fn golden_max(f: &impl Fn(f64) -> f64, phi: f64, w: f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (phi - w, phi + w);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 > f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 > f2 { (x1, f1) } else { (x2, f2) }
}

/// The global maximum of a 2 pi periodic function of the direction angle:
/// 64 samples from phi0, every sampled local maximum refined by golden section
/// on its bracket, the best kept. Returns (phi, f(phi)).
fn search_max(f: impl Fn(f64) -> f64, phi0: f64) -> (f64, f64) {
    const N: usize = 64;
    let step = std::f64::consts::TAU / N as f64;
    let samples: [f64; N] = std::array::from_fn(|k| f(phi0 + k as f64 * step));
    let (mut phi, mut s) = (phi0, f64::NEG_INFINITY);
    for k in 0..N {
        let (prev, next) = (samples[(k + N - 1) % N], samples[(k + 1) % N]);
        if samples[k] >= prev && samples[k] >= next {
            let (p, v) = golden_max(&f, phi0 + k as f64 * step, step);
            let (p, v) = if v >= samples[k] { (p, v) } else { (phi0 + k as f64 * step, samples[k]) };
            if v > s {
                phi = p;
                s = v;
            }
        }
    }
    (phi, s)
}

/// Contact of two ellipses, if they overlap, by the global search over every
/// direction (the reference method; [`contact_fast`] is what the engine calls).
pub fn contact(e1: &Ellipse, e2: &Ellipse) -> Option<EllipseContact> {
    let d = e2.c - e1.c;
    if d.norm() >= e1.a + e2.a {
        return None;
    }
    let gap = |phi: f64| {
        let (ny, nx) = phi.sin_cos();
        nx * d.x + ny * d.y - e1.support(nx, ny) - e2.support(-nx, -ny)
    };
    let (phi, s) = search_max(gap, d.y.atan2(d.x));
    if s >= 0.0 {
        return None;
    }
    let (ny, nx) = phi.sin_cos();
    let p1 = e1.support_point(nx, ny);
    let p2 = e2.support_point(-nx, -ny);
    Some(EllipseContact { overlap: -s, n: Vec3::new(nx, ny, 0.0), point: (p1 + p2) * 0.5 })
}

/// h(n), dh/dphi and d2h/dphi2 of an ellipse along n = (cos phi, sin phi).
/// With p = n^T A n, q = t^T A n, r = t^T A t (t = dn/dphi): h = sqrt(p),
/// h' = q / h, h'' = (r - p) / h - q^2 / h^3.
#[inline(always)]
fn support_derivatives(e: &Ellipse, nx: f64, ny: f64) -> (f64, f64, f64) {
    let (st, ct) = e.sc;
    let u = ct * nx + st * ny; // cos(phi - theta)
    let v = -st * nx + ct * ny; // sin(phi - theta)
    let (a2, b2) = (e.a * e.a, e.b * e.b);
    let p = a2 * u * u + b2 * v * v;
    let q = (b2 - a2) * u * v;
    let r = a2 * v * v + b2 * u * u;
    let h = p.sqrt();
    (h, q / h, (r - p) / h - q * q / (h * h * h))
}

impl Ellipse {
    /// Radius of curvature of the boundary at the point whose outward normal is
    /// n (unit): rho = a^2 b^2 / h(n)^3 (b^2 / a at the tips, a^2 / b at the flanks).
    #[inline(always)]
    pub fn curvature_radius(&self, nx: f64, ny: f64) -> f64 {
        let h = self.support(nx, ny);
        (self.a * self.b).powi(2) / (h * h * h)
    }
}

/// Contact of two ellipses by a certified Newton iteration on the common
/// normal, the method the engine uses every step.
///
/// With d = c2 - c1 and phi the direction angle measured from d, the gap is
/// s(phi) = |d| cos(phi) - H(phi), H = h1 + h2. Let H_d = H(0) and H_min = b1 + b2.
/// The global maximum phi* has |d| cos(phi*) >= |d| - (H_d - H_min) (since
/// s(phi*) >= s(0) and H >= H_min); on that arc s'' = -|d| cos(phi) - H'' is
/// below -(|d| - H_d + H_min) + K, where K = sum (a^2 - b^2) / a bounds -h''. So
/// when |d| - H_d + H_min > K (always so for small overlaps of the drag paper's
/// aspect ratios: the condition reads roughly b1 + b2 > K), s is strictly concave
/// on the arc, its one stationary point there is the global maximum, and
/// Newton's method safeguarded by bisection on the arc finds it (3-5 steps).
/// Any direction with s > 0 proves the bodies apart (exit at once; most
/// neighbour pairs leave at phi = 0). Where the certificate fails (deep or
/// near-concentric overlaps, slender ellipses), the global search [`contact`].
pub fn contact_fast(e1: &Ellipse, e2: &Ellipse) -> Option<EllipseContact> {
    newton_contact(e1, e2).unwrap_or_else(|| contact(e1, e2))
}

/// The certified Newton iteration of [`contact_fast`]; None where the
/// certificate fails (then the global search decides).
pub fn newton_contact(e1: &Ellipse, e2: &Ellipse) -> Option<Option<EllipseContact>> {
    let d = e2.c - e1.c;
    let dist = (d.x * d.x + d.y * d.y).sqrt();
    if dist >= e1.a + e2.a {
        return Some(None);
    }
    if dist <= 1e-12 * (e1.a + e2.a) {
        return None;
    }
    let (n0x, n0y) = (d.x / dist, d.y / dist);
    let eval = |sx: f64, cx: f64| {
        let (nx, ny) = (n0x * cx - n0y * sx, n0x * sx + n0y * cx);
        let (h1, d1, dd1) = support_derivatives(e1, nx, ny);
        let (h2, d2, dd2) = support_derivatives(e2, nx, ny);
        (dist * cx - h1 - h2, -dist * sx - d1 - d2, -dist * cx - dd1 - dd2, nx, ny)
    };
    let (s0, mut ds, mut dds, _, _) = eval(0.0, 1.0);
    if s0 > 0.0 {
        return Some(None);
    }
    let h_d = dist - s0;
    let h_min = e1.b + e2.b;
    let k = (e1.a * e1.a - e1.b * e1.b) / e1.a + (e2.a * e2.a - e2.b * e2.b) / e2.a;
    let margin = dist - h_d + h_min;
    if margin <= k {
        return None;
    }
    // the arc |x| <= beta, cos(beta) = margin / dist, holds the maximum; its
    // end points are computed only if a Newton step leaves it
    let cmin = margin / dist;
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut x = 0.0;
    let (mut s, mut nx, mut ny) = (s0, n0x, n0y);
    for _ in 0..60 {
        if ds > 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let mut xn = x - ds / dds;
        let (mut sx, mut cx) = xn.sin_cos();
        if !(xn > lo && xn < hi && cx >= cmin) {
            let beta = cmin.clamp(-1.0, 1.0).acos();
            lo = lo.max(-beta);
            hi = hi.min(beta);
            xn = 0.5 * (lo + hi);
            (sx, cx) = xn.sin_cos();
        }
        // quadratic convergence: a step below 1e-9 leaves an error far below round-off in s
        let done = (xn - x).abs() < 1e-9;
        x = xn;
        (s, ds, dds, nx, ny) = eval(sx, cx);
        if s > 0.0 {
            return Some(None);
        }
        if done {
            break;
        }
    }
    let p1 = e1.support_point(nx, ny);
    let p2 = e2.support_point(-nx, -ny);
    Some((s < 0.0).then(|| EllipseContact { overlap: -s, n: Vec3::new(nx, ny, 0.0), point: (p1 + p2) * 0.5 }))
}

/// Contact geometry of two particles, at least one an ellipse (`ei` is i,
/// `ej` is j; a round particle as an ellipse with a = b): the common normal and
/// overlap by [`contact_fast`] (body 1 = j, body 2 = i, so n points from j to
/// i), the branch vectors from each centre to the contact point (full lever
/// arms, not along n), and R* from the local radii of curvature at the
/// contact, rho = a^2 b^2 / h(n)^3 on each side.
#[inline(always)]
pub fn pair_geometry(ei: &Ellipse, ej: &Ellipse) -> Option<ContactGeom> {
    contact_fast(ej, ei).map(|ec| {
        let n = ec.n;
        let (rho_i, rho_j) = (ei.curvature_radius(-n.x, -n.y), ej.curvature_radius(n.x, n.y));
        ContactGeom {
            n,
            overlap: ec.overlap,
            r_eff: Some(rho_i * rho_j / (rho_i + rho_j)),
            lever: Lever::Branch { point: ec.point, branch_i: ec.point - ei.c, branch_j: Some(ec.point - ej.c) },
        }
    })
}

/// Contact geometry of an ellipse with a wall from the wall's hit (`hit.point`
/// is the ellipse's deepest point): the force acts `arm_overlap` of the overlap
/// back from it towards the ellipse (as for spheres), with the full lever arm
/// from the centre; R* from the radius of curvature there, in series with the
/// wall's (`wall_curvature`, None: flat).
#[inline(always)]
pub fn wall_geometry(e: &Ellipse, hit: &WallHit, arm_overlap: f64, wall_curvature: Option<f64>) -> ContactGeom {
    let point = hit.point + hit.n * (arm_overlap * hit.overlap);
    let rho = e.curvature_radius(-hit.n.x, -hit.n.y);
    ContactGeom {
        n: hit.n,
        overlap: hit.overlap,
        r_eff: Some(match wall_curvature {
            None => rho,
            Some(rw) => rho * rw / (rho + rw),
        }),
        lever: Lever::Branch { point, branch_i: point - e.c, branch_j: None },
    }
}

/// A straight segment from p to q (a 2D wall), two-sided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub p: Vec3,
    pub q: Vec3,
}

impl Segment {
    /// Contact of an ellipse with the segment. The segment is a convex body
    /// whose lowest point along n is an end point, so the gap along n (from the
    /// ellipse to the segment) is s(n) = min_k n.(x_k - c) - h(n); its maximum
    /// over n is either at a face normal (where the two end terms are equal) or
    /// at a maximum of one end term: every face normal is tried exactly and the
    /// rest by the global search. Returns the overlap, the unit normal from the
    /// segment to the ellipse, and the contact point.
    pub fn ellipse_contact(&self, e: &Ellipse) -> Option<EllipseContact> {
        let (ep, eq) = (self.p - e.c, self.q - e.c);
        let gap = |nx: f64, ny: f64| (nx * ep.x + ny * ep.y).min(nx * eq.x + ny * eq.y) - e.support(nx, ny);
        let t = self.q - self.p;
        let len = t.norm();
        let mut best = (0.0, f64::NEG_INFINITY);
        if len > 0.0 {
            let m = Vec3::new(-t.y / len, t.x / len, 0.0);
            for sgn in [1.0, -1.0] {
                let (nx, ny) = (sgn * m.x, sgn * m.y);
                let v = gap(nx, ny);
                if v > best.1 {
                    best = (ny.atan2(nx), v);
                }
            }
        }
        let mid = (ep + eq) * 0.5;
        let (phi, v) = search_max(|phi: f64| {
            let (ny, nx) = phi.sin_cos();
            gap(nx, ny)
        }, mid.y.atan2(mid.x));
        if v > best.1 {
            best = (phi, v);
        }
        let (phi, s) = best;
        if s >= 0.0 {
            return None;
        }
        let (ny, nx) = phi.sin_cos();
        let deepest = e.support_point(nx, ny);
        // n points from the ellipse into the segment: the normal on the ellipse is -n
        Some(EllipseContact { overlap: -s, n: Vec3::new(-nx, -ny, 0.0), point: deepest })
    }

    /// Contact of a disc (centre c, radius r): the nearest point of the segment.
    pub fn disc_contact(&self, c: &Vec3, r: f64) -> Option<(Vec3, f64, Vec3)> {
        let t = self.q - self.p;
        let l2 = t.norm_squared();
        let u = if l2 > 0.0 { ((c - self.p).dot(&t) / l2).clamp(0.0, 1.0) } else { 0.0 };
        let x = self.p + t * u;
        let dv = c - x;
        let dist = dv.norm();
        if dist < r && dist > 0.0 {
            Some((dv / dist, r - dist, x))
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ell(x: f64, y: f64, a: f64, b: f64, t: f64) -> Ellipse {
        Ellipse::new(Vec3::new(x, y, 0.0), a, b, t)
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

        #[test]
        fn the_newton_contact_equals_the_global_search(x in -2.5..2.5f64, y in -2.5..2.5f64, l1 in 1.0..1.6f64,
                                                     l2 in 1.0..1.6f64, r2 in 0.8..1.25f64, t1 in 0.0..6.3f64, t2 in 0.0..6.3f64) {
            let e1 = ell(0.0, 0.0, l1.sqrt(), 1.0 / l1.sqrt(), t1);
            let e2 = ell(x, y, r2 * l2.sqrt(), r2 / l2.sqrt(), t2);
            match (contact(&e1, &e2), contact_fast(&e1, &e2)) {
                (Some(p), Some(q)) => {
                    prop_assert!((p.overlap - q.overlap).abs() < 1e-10, "{} vs {}", p.overlap, q.overlap);
                    prop_assert!((p.n - q.n).norm() < 1e-5);
                    prop_assert!((p.point - q.point).norm() < 1e-5);
                }
                (None, None) => {}
                (p, q) => prop_assert!(p.map_or(0.0, |c| c.overlap) + q.map_or(0.0, |c| c.overlap) < 1e-10, "{p:?} {q:?}"),
            }
        }

        #[test]
        fn a_long_segment_acts_as_its_line_and_a_round_ellipse_as_a_disc(x in -0.5..0.5f64, y in 0.5..1.2f64,
                                                                        l in 1.0..1.5f64, t in 0.0..6.3f64) {
            let e = ell(x, y, l.sqrt(), 1.0 / l.sqrt(), t);
            let seg = Segment { p: Vec3::new(-5.0, 0.0, 0.0), q: Vec3::new(5.0, 0.0, 0.0) };
            let plane = e.wall_contact(Vec3::zeros(), Vec3::new(0.0, 1.0, 0.0));
            let s = seg.ellipse_contact(&e);
            prop_assert_eq!(plane.is_some(), s.is_some());
            if let (Some(p), Some(s)) = (plane, s) {
                prop_assert!((p.overlap - s.overlap).abs() < 1e-12);
                prop_assert!((p.n - s.n).norm() < 1e-12 && (p.point - s.point).norm() < 1e-9);
            }
            // near an end: a round ellipse and the disc formula agree
            let seg = Segment { p: Vec3::new(-3.0, 0.0, 0.0), q: Vec3::new(x, 0.2, 0.0) };
            let c = Vec3::new(x + 0.3, y, 0.0);
            let d = seg.disc_contact(&c, 0.9);
            let s = seg.ellipse_contact(&ell(c.x, c.y, 0.9, 0.9, t));
            prop_assert_eq!(d.is_some(), s.is_some());
            if let (Some((n, ov, _)), Some(s)) = (d, s) {
                prop_assert!((ov - s.overlap).abs() < 1e-9, "{ov} vs {}", s.overlap);
                prop_assert!((n - s.n).norm() < 1e-4);
            }
        }

        #[test]
        fn small_overlaps_of_the_drag_aspect_ratios_are_certified(phi in 0.0..6.3f64, l1 in 1.0..1.375f64, l2 in 1.0..1.375f64,
                                                                  r2 in 0.8..1.25f64, t1 in 0.0..6.3f64, t2 in 0.0..6.3f64,
                                                                  depth in 0.0..0.05f64) {
            // place e2 along phi so that the pair overlaps by `depth` of the smaller minor axis
            let e1 = ell(0.0, 0.0, l1.sqrt(), 1.0 / l1.sqrt(), t1);
            let mut e2 = ell(0.0, 0.0, r2 * l2.sqrt(), r2 / l2.sqrt(), t2);
            let u = Vec3::new(phi.cos(), phi.sin(), 0.0);
            let (mut lo, mut hi) = (0.0, 5.0);
            for _ in 0..100 {
                let m = 0.5 * (lo + hi);
                e2.c = u * m;
                if contact(&e1, &e2).is_some() { lo = m } else { hi = m }
            }
            e2.c = u * (lo - depth * e1.b.min(e2.b));
            let fast = newton_contact(&e1, &e2);
            prop_assert!(fast.is_some(), "certificate failed");
            let (f, g) = (fast.unwrap(), contact(&e1, &e2));
            prop_assert_eq!(f.is_some(), g.is_some());
            if let (Some(f), Some(g)) = (f, g) {
                prop_assert!((f.overlap - g.overlap).abs() < 1e-12);
            }
        }
    }
}
