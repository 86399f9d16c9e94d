//! Coarse-graining kernels (Weinhart et al., Granular Matter 14, 2012;
//! Goldhirsch, Granular Matter 12, 2010): each spreads a particle's mass,
//! momentum and a contact's force over space, and integrates to one.
//!
//! `width` means what MercuryDPM's coarse-graining means by it: a Gaussian's
//! standard deviation (cut off at three widths and scaled so that what is
//! left still integrates to one), or Lucy's polynomial's radius (it is zero
//! beyond).

use std::f64::consts::PI;

/// How far a Gaussian is kept, in standard deviations.
pub const GAUSS_CUT: f64 = 3.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    /// A Gaussian of standard deviation `w` (m), cut off at 3 w.
    Gauss { w: f64 },
    /// Lucy's polynomial, 1 - 6 q^2 + 8 q^3 - 3 q^4 with q = r / c, zero beyond `c` (m).
    Lucy { c: f64 },
}

impl Kernel {
    /// The kernel named `name` ("gauss", "lucy") of width `width` (m, > 0).
    pub fn new(name: &str, width: f64) -> Result<Kernel, String> {
        if !(width.is_finite() && width > 0.0) {
            return Err(format!("the kernel's width must be a positive length in metres, not {width}"));
        }
        match name {
            "gauss" => Ok(Kernel::Gauss { w: width }),
            "lucy" => Ok(Kernel::Lucy { c: width }),
            _ => Err(format!("unknown kernel \"{name}\" (gauss or lucy)")),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Kernel::Gauss { .. } => "gauss",
            Kernel::Lucy { .. } => "lucy",
        }
    }

    pub fn width(&self) -> f64 {
        match *self {
            Kernel::Gauss { w } => w,
            Kernel::Lucy { c } => c,
        }
    }

    /// The distance beyond which the kernel is zero (m).
    pub fn cutoff(&self) -> f64 {
        match *self {
            Kernel::Gauss { w } => GAUSS_CUT * w,
            Kernel::Lucy { c } => c,
        }
    }

    /// The kernel in one dimension (1/m): what is left of the 3D kernel
    /// averaged over a plane, so that a profile along one axis is the field
    /// averaged over the other two.
    #[inline]
    pub fn phi1(&self, x: f64) -> f64 {
        match *self {
            Kernel::Gauss { w } => {
                let q = x / w;
                if q.abs() >= GAUSS_CUT {
                    return 0.0;
                }
                (-0.5 * q * q).exp() / ((2.0 * PI).sqrt() * w * gauss_mass_1d())
            }
            Kernel::Lucy { c } => {
                let q = x.abs() / c;
                if q >= 1.0 {
                    return 0.0;
                }
                1.25 / c * lucy(q)
            }
        }
    }

    /// The integral of [`Kernel::phi1`] from minus infinity to `x` (0 to 1).
    #[inline]
    pub fn cdf1(&self, x: f64) -> f64 {
        match *self {
            Kernel::Gauss { w } => {
                let q = (x / w).clamp(-GAUSS_CUT, GAUSS_CUT);
                0.5 + 0.5 * libm::erf(q / std::f64::consts::SQRT_2) / gauss_mass_1d()
            }
            Kernel::Lucy { c } => {
                let q = (x / c).clamp(-1.0, 1.0);
                // the integral of 1.25 (1 - 6 q^2 + 8 |q|^3 - 3 q^4) from 0 to q, odd in q
                let a = q.abs();
                let half = 1.25 * (a - 2.0 * a.powi(3) + 2.0 * a.powi(4) - 0.6 * a.powi(5));
                0.5 + half.copysign(q)
            }
        }
    }

    /// The kernel in three dimensions at squared distance `r2` (1/m^3).
    #[inline]
    pub fn phi3(&self, r2: f64) -> f64 {
        match *self {
            Kernel::Gauss { w } => {
                let q2 = r2 / (w * w);
                if q2 >= GAUSS_CUT * GAUSS_CUT {
                    return 0.0;
                }
                (-0.5 * q2).exp() / ((2.0 * PI).powf(1.5) * w.powi(3) * gauss_mass_3d())
            }
            Kernel::Lucy { c } => {
                let q = r2.sqrt() / c;
                if q >= 1.0 {
                    return 0.0;
                }
                105.0 / (16.0 * PI * c.powi(3)) * lucy(q)
            }
        }
    }

    /// The line integral of [`Kernel::phi1`] from x0 to x1 along a segment,
    /// per unit of the segment's parameter: the mean of phi1 over [x0, x1]
    /// (a contact's force spread along its branch vector, in a profile).
    #[inline]
    pub fn mean1(&self, x0: f64, x1: f64) -> f64 {
        let d = x1 - x0;
        // where the ends almost coincide the difference of the integrals
        // loses its digits: the midpoint's value (the error is of order d^2)
        if d.abs() <= 1e-6 * self.width() {
            return self.phi1(0.5 * (x0 + x1));
        }
        (self.cdf1(x1) - self.cdf1(x0)) / d
    }
}

/// Lucy's polynomial at q in [0, 1].
#[inline]
fn lucy(q: f64) -> f64 {
    let q2 = q * q;
    1.0 - 6.0 * q2 + 8.0 * q2 * q - 3.0 * q2 * q2
}

/// What a unit Gaussian keeps within the cutoff, in one dimension.
fn gauss_mass_1d() -> f64 {
    libm::erf(GAUSS_CUT / std::f64::consts::SQRT_2)
}

/// What a unit Gaussian keeps within the cutoff, in three dimensions.
fn gauss_mass_3d() -> f64 {
    let c = GAUSS_CUT;
    libm::erf(c / std::f64::consts::SQRT_2) - (2.0 / PI).sqrt() * c * (-0.5 * c * c).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each kernel integrates to one, and its integral is its CDF.
    #[test]
    fn kernels_integrate_to_one() {
        for k in [Kernel::Gauss { w: 0.3 }, Kernel::Lucy { c: 0.7 }] {
            let cut = k.cutoff();
            let n = 20000;
            let h = 2.0 * cut / n as f64;
            // midpoint rule in 1D
            let mut s1 = 0.0;
            for i in 0..n {
                let x = -cut + (i as f64 + 0.5) * h;
                s1 += k.phi1(x) * h;
                if i % 1000 == 0 {
                    let cdf: f64 = (0..=i).map(|j| k.phi1(-cut + (j as f64 + 0.5) * h) * h).sum();
                    assert!((cdf - k.cdf1(-cut + (i + 1) as f64 * h)).abs() < 1e-6, "{} cdf at {i}", k.name());
                }
            }
            assert!((s1 - 1.0).abs() < 1e-6, "{} 1D: {s1}", k.name());
            assert!(k.cdf1(-2.0 * cut) == 0.0 && k.cdf1(2.0 * cut) == 1.0);
            // 3D: shells
            let mut s3 = 0.0;
            let hr = cut / n as f64;
            for i in 0..n {
                let r = (i as f64 + 0.5) * hr;
                s3 += 4.0 * PI * r * r * k.phi3(r * r) * hr;
            }
            assert!((s3 - 1.0).abs() < 1e-6, "{} 3D: {s3}", k.name());
            // the mean over a segment
            let m = k.mean1(-0.1, 0.25);
            let direct: f64 = (0..10000).map(|i| k.phi1(-0.1 + (i as f64 + 0.5) * 0.35e-4)).sum::<f64>() / 10000.0;
            assert!((m - direct).abs() < 1e-6 * direct, "{} mean", k.name());
        }
    }
}
