//! Clearing the upper halves of the vector registers after faer.
//!
//! faer's AVX-512 kernels can return with the upper register state dirty. Until a `vzeroupper`
//! runs, legacy-SSE code on that thread (such as libm's `tanh` and `exp`) pays a penalty on every
//! instruction: measured on this VM (Xeon with AVX-512), `tanh` took 130-200 ns per call after a
//! faer product instead of about 17 ns, which made MLP training 3x (order 800) to 14x (order 40)
//! slower. The state survives context switches, so it is cleared right after faer calls and at
//! the start of hot loops that may follow faer code on the same thread.

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
