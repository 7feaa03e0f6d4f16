//! The fit's two hot loops, the part evaluation (`Objective::evaluate_scope`, with the
//! block solve inlined into it) and J^T J (`part::gram_dense`), are each compiled twice:
//! for the x86-64 baseline (SSE2) and with AVX2, and the AVX2 build runs where the CPU
//! has it. A [`super::block_solve::Lane`] of four f64 is then one register instead of
//! two, and `round` one instruction instead of a software routine.
//!
//! Both builds give the same bits: the same operations in the same order, only wider. No
//! FMA is enabled, and Rust never fuses a multiply and an add on its own. The tests of
//! `objective` and `part` compare the two builds bit for bit.

/// Whether this CPU runs the AVX2 builds (detected once, then a cached flag).
#[cfg(target_arch = "x86_64")]
pub fn avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}
