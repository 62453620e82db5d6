//! Clearing the upper halves of the vector registers after faer.
//!
//! faer's AVX-512 kernels can return with the upper register state dirty. Until a `vzeroupper`
//! runs, every legacy-SSE instruction on that thread pays a merge penalty, and libm's `tanh` and
//! `exp` (SSE code) became about 30x slower: measured 130 ns instead of 4 ns per call after a
//! faer product, which made MLP training five times slower. The state survives context
//! switches, so it is cleared right after faer calls and at the start of hot loops that call libm.

/// Mark the upper vector-register state clean (`vzeroupper`). No-op on CPUs without AVX and on
/// other architectures.
#[inline]
pub(crate) fn clear_upper_vector_state() {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx")]
        unsafe fn zero_upper() {
            std::arch::x86_64::_mm256_zeroupper();
        }
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU supports AVX, checked just above.
            unsafe { zero_upper() }
        }
    }
}
