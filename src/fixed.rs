//! Exact sums: values converted to 2^-64 fixed point and added as integers.
//!
//! Integer addition is associative, so a sum of fixed-point terms has the same
//! bits whatever the order of its terms: over MPI ranks (wall loads, energies,
//! discharged mass summed by the communicator) and over the contacts of a sweep
//! (a wall's load). Scale 2^64: resolution 5.4e-20, range +-9.2e18 in the
//! value's unit (N, N m, J, kg), far beyond any force or energy of a granular
//! run. A term beyond the range saturates (`as` conversion), it never wraps;
//! sums of saturated terms wrap only past 2^127, i.e. after 1.8e19 such terms.

/// Fixed-point scale of exact sums: 2^64.
pub const SCALE: f64 = 18446744073709551616.0;

/// `x` in fixed point (saturating beyond +-9.2e18).
#[inline(always)]
pub fn to_fixed(x: f64) -> i128 {
    (x * SCALE) as i128
}

/// A fixed-point value back as a float.
#[inline(always)]
pub fn from_fixed(x: i128) -> f64 {
    x as f64 / SCALE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_sums_do_not_depend_on_the_order_of_their_terms() {
        let xs: Vec<f64> = (0..1000).map(|k| ((k * 7919) % 1013) as f64 * 1.37e-3 - 0.5).collect();
        let fwd: i128 = xs.iter().map(|&x| to_fixed(x)).sum();
        let back: i128 = xs.iter().rev().map(|&x| to_fixed(x)).sum();
        assert_eq!(fwd, back);
        assert!((from_fixed(fwd) - xs.iter().sum::<f64>()).abs() < 1e-9);
    }

    #[test]
    fn a_term_beyond_the_range_saturates_instead_of_wrapping() {
        assert_eq!(to_fixed(1e30), i128::MAX);
        assert_eq!(to_fixed(-1e30), i128::MIN);
    }
}
