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
///
/// Where the scaled value fits 64 bits (|x| < 0.5, nearly every term: a
/// contact's force on a wall, its torque) it is converted by the processor's
/// 64-bit instruction; else by the 128-bit conversion (a library routine, some
/// tens of cycles). Both truncate toward zero, so the bits are the same.
#[inline(always)]
pub fn to_fixed(x: f64) -> i128 {
    let y = x * SCALE;
    if y.abs() < I64_RANGE {
        y as i64 as i128
    } else {
        y as i128
    }
}

/// 2^63: the scaled values the 64-bit conversion holds lie below it in size.
const I64_RANGE: f64 = 9223372036854775808.0;

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
    fn the_64_bit_path_gives_the_128_bit_conversion() {
        // either side of 0.5 (the 64-bit path's edge), tiny, negative, NaN
        let edge = 0.5f64;
        let xs = [0.0, -0.0, 1e-30, -1e-19, 0.123456789, -0.4999999999, edge, -edge, f64::from_bits(edge.to_bits() - 1), -f64::from_bits(edge.to_bits() - 1), 0.75, -3.5, 1e18, f64::NAN];
        for &x in &xs {
            assert_eq!(to_fixed(x), (x * SCALE) as i128, "{x:e}");
        }
        for k in 0..20_000 {
            let x = ((k as f64) * 0.618033988749895).fract() - 0.5 + (k % 7) as f64 * 1e-3;
            assert_eq!(to_fixed(x), (x * SCALE) as i128, "{x:e}");
        }
    }

    #[test]
    fn a_term_beyond_the_range_saturates_instead_of_wrapping() {
        assert_eq!(to_fixed(1e30), i128::MAX);
        assert_eq!(to_fixed(-1e30), i128::MIN);
    }
}
