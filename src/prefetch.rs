//! A hint to the processor to bring an element of a slice into cache ahead
//! of its use.
//!
//! The force sweep, the gather of pair results and the history carry of a
//! list build read memory in an order the hardware prefetcher cannot guess
//! (a partner's place, a pair's slot in an incidence list), so each asks for
//! the element it will need a few iterations on. The hint changes no result:
//! it loads nothing into a register and cannot fault.

/// Ask for `s[i]` to be brought into the first-level cache. Does nothing if
/// `i` is out of bounds, or off x86_64.
#[inline(always)]
pub fn prefetch<T>(s: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(x) = s.get(i) {
        // SAFETY: a prefetch is only a hint; the address is that of an
        // element of the slice (SSE, which has the instruction, is part of
        // every x86_64 target)
        #[allow(unused_unsafe)]
        unsafe {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            _mm_prefetch::<_MM_HINT_T0>(x as *const T as *const i8);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (s, i);
}

#[cfg(test)]
mod tests {
    use super::prefetch;

    #[test]
    fn in_and_out_of_bounds_are_harmless() {
        let v = vec![1.0f64, 2.0, 3.0];
        prefetch(&v, 0);
        prefetch(&v, 2);
        prefetch(&v, 3);
        prefetch(&v, usize::MAX);
        let e: [u8; 0] = [];
        prefetch(&e, 0);
        assert_eq!(v, [1.0, 2.0, 3.0]);
    }
}
