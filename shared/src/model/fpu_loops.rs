//! The device's inner loops on the Cortex-M4F FPU, in assembly: the same single-precision
//! operations, in the same order, as their Rust definitions (`ModalGroup::run` for the
//! model step, `readout::accumulate` for the joint outputs), so the results are the same
//! bits; only the data movement differs.
//!
//! Why: the model step is the largest item of the device's per-sample budget and the
//! joint readout the next one of the model's (issue 16, BENCHMARKS.md), and the compiler
//! moves each coefficient and state with an instruction of its own (`vldr`/`vstr`) and
//! keeps three induction variables per loop. Here a block's coefficients arrive in one
//! `vldm`, its state in one `vldm` and leaves in one `vstm`, and a loop keeps one counter.
//! The arithmetic is `vmul` and `vadd` only, exactly the rounding steps of the Rust code
//! (no `vfma`/`vmla`: Rust never contracts float arithmetic), so the host, which runs the
//! Rust definitions, computes the same bits (the self-test and the QEMU tests compare).
//!
//! Rust offers no `sreg` operands on this target without an unstable target feature (see
//! [`crate::fpu`]): values cross in core registers and the loops use `s0`-`s15`, declared
//! clobbered (the calling convention treats them as scratch anyway).
#![allow(unsafe_code)]

use super::discrete::{ModalBlock, ModalGroup};
use super::readout::MAX_JOINT_ROWS;

/// Bytes from one block's first coefficient to the next block's: the device realization
/// stores three output rows per block (`ModalBlock<f32, 3>`, `repr(C)`), of which a group
/// uses its first `output_count`.
const BLOCK_BYTES: usize = core::mem::size_of::<ModalBlock<f32, 3>>();
const _: () = assert!(BLOCK_BYTES == 40);
const _: () = assert!(core::mem::offset_of!(ModalBlock<f32, 3>, output) == 16);

/// One row step of the model's output: `acc = (acc + c0 x0) + c1 x1`, the state in `s0`,
/// `s1`, the product in `s13`.
macro_rules! step_row {
    ($acc:literal, $c0:literal, $c1:literal) => {
        concat!(
            "vmul.f32 s13, ",
            $c0,
            ", s0\n",
            "vadd.f32 ",
            $acc,
            ", ",
            $acc,
            ", s13\n",
            "vmul.f32 s13, ",
            $c1,
            ", s1\n",
            "vadd.f32 ",
            $acc,
            ", ",
            $acc,
            ", s13",
        )
    };
}

/// The model step's loop over `n` blocks for one row count: its coefficients' `vldm`
/// list (Phi - I in `s2`-`s5`, then the rows), its accumulators' `vldm` list and
/// `vmul`s by the input, its rows, its results.
macro_rules! step_loop {
    (
        $blocks:expr, $states:expr, $n:ident, $u:ident, $ft:ident,
        coefficients: $coeffs:literal,
        accumulators: $accs:literal,
        init: [$($init:literal),*],
        rows: [$($row:expr),*],
        out: [$($out:ident => $reg:literal),*]
    ) => {
        core::arch::asm!(
            "vmov s10, {u}",
            concat!("vldmia {ft}, {{", $accs, "}}"),
            $(concat!("vmul.f32 ", $init, ", ", $init, ", s10"),)*
            "cmp {n}, #0",
            "beq 3f",
            "2:",
            "vldmia {x}, {{s0-s1}}",
            concat!("vldmia {b}, {{", $coeffs, "}}"),
            "add {b}, {b}, #{stride}",
            $($row,)*
            // x0 += (d00 x0 + d01 x1) + u; x1 += d10 x0 + d11 x1.
            "vmul.f32 s13, s2, s0",
            "vmul.f32 s14, s3, s1",
            "vadd.f32 s13, s13, s14",
            "vadd.f32 s13, s13, s10",
            "vadd.f32 s13, s0, s13",
            "vmul.f32 s14, s4, s0",
            "vmul.f32 s15, s5, s1",
            "vadd.f32 s14, s14, s15",
            "vadd.f32 s14, s1, s14",
            "vstmia {x}!, {{s13-s14}}",
            "subs {n}, {n}, #1",
            "bne 2b",
            "3:",
            $(concat!("vmov {", stringify!($out), "}, ", $reg),)*
            u = in(reg) $u.to_bits(),
            ft = in(reg) $ft,
            n = inout(reg) $n => _,
            x = inout(reg) $states => _,
            b = inout(reg) $blocks => _,
            stride = const BLOCK_BYTES,
            $($out = lateout(reg) $out,)*
            out("s0") _, out("s1") _, out("s2") _, out("s3") _, out("s4") _,
            out("s5") _, out("s6") _, out("s7") _, out("s8") _, out("s9") _,
            out("s10") _, out("s11") _, out("s12") _, out("s13") _, out("s14") _,
            out("s15") _,
            options(nostack),
        )
    };
}

/// A group's blocks advanced one sample on input `u`, with `K` (1 or 2) packed output rows:
/// returns the rows' sums (direct term included), as `ModalGroup::run` accumulates them.
/// `blocks` and `states` have the same length (the caller slices both).
#[inline(always)]
pub(super) fn advance<const K: usize>(
    group: &ModalGroup<f32, 3>,
    blocks: &[ModalBlock<f32, 3>],
    states: &mut [[f32; 2]],
    u: f32,
) -> [f32; K] {
    const { assert!(K == 1 || K == 2) };
    let n = blocks.len().min(states.len());
    let (mut a0, mut a1) = (0u32, 0u32);
    let ft = group.feedthrough.as_ptr();
    // Per block, in the Rust definition's order: each row's acc = (acc + c0 x0) + c1 x1;
    // x0 += (d00 x0 + d01 x1) + u; x1 += d10 x0 + d11 x1 (x0, x1 the state before).
    // Registers: s0, s1 the state; s2-s5 Phi - I; s6-s9 the rows; s10 u; s11, s12 the
    // accumulators; s13-s15 products.
    //
    // SAFETY: reads `n` blocks of `BLOCK_BYTES` from `blocks` and `n` states of 8 bytes
    // from `states` (both at least `n` long, as `n` is the shorter length), writes those
    // states back in place (`states` is borrowed mutably), reads the group's first `K`
    // direct terms. No stack; the FPU registers used are declared clobbered.
    unsafe {
        if K == 1 {
            step_loop!(blocks.as_ptr(), states.as_mut_ptr(), n, u, ft,
                coefficients: "s2-s7",
                accumulators: "s11",
                init: ["s11"],
                rows: [step_row!("s11", "s6", "s7")],
                out: [a0 => "s11"]);
        } else {
            step_loop!(blocks.as_ptr(), states.as_mut_ptr(), n, u, ft,
                coefficients: "s2-s9",
                accumulators: "s11-s12",
                init: ["s11", "s12"],
                rows: [step_row!("s11", "s6", "s7"), step_row!("s12", "s8", "s9")],
                out: [a0 => "s11", a1 => "s12"]);
        }
    }
    core::array::from_fn(|i| f32::from_bits(if i == 0 { a0 } else { a1 }))
}

/// One vmul-vmul-vadd-vadd row step of the readout: `acc += c0 x0 + c1 x1` with the state
/// in `s0`, `s1` and products in `s14`, `s15`.
macro_rules! readout_row {
    ($acc:literal, $c0:literal, $c1:literal) => {
        concat!(
            "vmul.f32 s14, ",
            $c0,
            ", s0\n",
            "vmul.f32 s15, ",
            $c1,
            ", s1\n",
            "vadd.f32 s14, s14, s15\n",
            "vadd.f32 ",
            $acc,
            ", ",
            $acc,
            ", s14",
        )
    };
}

/// The readout's loop over `n` blocks for one row count: its coefficients' `vldm` list,
/// its accumulators' `vldm` list and `vmul`s, its rows, its results.
macro_rules! readout_loop {
    (
        $rows:ident, $state:ident, $n:ident, $u:ident, $ft:ident,
        coefficients: $coeffs:literal,
        accumulators: $accs:literal,
        init: [$($init:literal),*],
        rows: [$($row:expr),*],
        out: [$($out:ident => $reg:literal),*]
    ) => {
        core::arch::asm!(
            "vmov s14, {u}",
            concat!("vldmia {ft}, {{", $accs, "}}"),
            $(concat!("vmul.f32 ", $init, ", ", $init, ", s14"),)*
            "cmp {n}, #0",
            "beq 3f",
            "2:",
            "vldmia {x}!, {{s0-s1}}",
            concat!("vldmia {b}, {{", $coeffs, "}}"),
            "add {b}, {b}, #{stride}",
            $($row,)*
            "subs {n}, {n}, #1",
            "bne 2b",
            "3:",
            $(concat!("vmov {", stringify!($out), "}, ", $reg),)*
            u = in(reg) $u.to_bits(),
            ft = in(reg) $ft,
            n = inout(reg) $n => _,
            x = inout(reg) $state => _,
            b = inout(reg) $rows => _,
            stride = const ROW_BLOCK_BYTES,
            $($out = lateout(reg) $out,)*
            out("s0") _, out("s1") _, out("s2") _, out("s3") _, out("s4") _,
            out("s5") _, out("s6") _, out("s7") _, out("s8") _, out("s9") _,
            out("s10") _, out("s11") _, out("s12") _, out("s13") _, out("s14") _,
            out("s15") _,
            options(nostack, readonly),
        )
    };
}

/// Bytes of one block's joint rows (`MAX_JOINT_ROWS` rows of two coefficients).
const ROW_BLOCK_BYTES: usize = core::mem::size_of::<[[f32; 2]; MAX_JOINT_ROWS]>();

/// The first `R` (1 to 4) joint rows of one axis group at a sample, as
/// `readout::accumulate` computes them: each row's direct term times `u`, plus per block
/// `c0 x0 + c1 x1` with the block's state before the sample's step.
#[inline(always)]
pub(super) fn accumulate<const R: usize>(
    feedthrough: &[f32; MAX_JOINT_ROWS],
    u: f32,
    block_rows: &[[[f32; 2]; MAX_JOINT_ROWS]],
    states: &[[f32; 2]],
) -> [f32; R] {
    const { assert!(R >= 1 && R <= MAX_JOINT_ROWS) };
    let n = block_rows.len().min(states.len());
    let (rows, state, ft) = (block_rows.as_ptr(), states.as_ptr(), feedthrough.as_ptr());
    let (mut a0, mut a1, mut a2, mut a3) = (0u32, 0u32, 0u32, 0u32);
    // SAFETY: reads `n` blocks of rows (`ROW_BLOCK_BYTES` each) and `n` states of 8 bytes
    // (both slices at least `n` long), and the first `R` of the four direct terms. Writes
    // no memory and no stack; the FPU registers used are declared clobbered.
    unsafe {
        match R {
            1 => readout_loop!(rows, state, n, u, ft,
                coefficients: "s2-s3",
                accumulators: "s10",
                init: ["s10"],
                rows: [readout_row!("s10", "s2", "s3")],
                out: [a0 => "s10"]),
            2 => readout_loop!(rows, state, n, u, ft,
                coefficients: "s2-s5",
                accumulators: "s10-s11",
                init: ["s10", "s11"],
                rows: [readout_row!("s10", "s2", "s3"), readout_row!("s11", "s4", "s5")],
                out: [a0 => "s10", a1 => "s11"]),
            3 => readout_loop!(rows, state, n, u, ft,
                coefficients: "s2-s7",
                accumulators: "s10-s12",
                init: ["s10", "s11", "s12"],
                rows: [
                    readout_row!("s10", "s2", "s3"),
                    readout_row!("s11", "s4", "s5"),
                    readout_row!("s12", "s6", "s7")
                ],
                out: [a0 => "s10", a1 => "s11", a2 => "s12"]),
            _ => readout_loop!(rows, state, n, u, ft,
                coefficients: "s2-s9",
                accumulators: "s10-s13",
                init: ["s10", "s11", "s12", "s13"],
                rows: [
                    readout_row!("s10", "s2", "s3"),
                    readout_row!("s11", "s4", "s5"),
                    readout_row!("s12", "s6", "s7"),
                    readout_row!("s13", "s8", "s9")
                ],
                out: [a0 => "s10", a1 => "s11", a2 => "s12", a3 => "s13"]),
        }
    }
    let all = [a0, a1, a2, a3];
    core::array::from_fn(|r| f32::from_bits(all[r % MAX_JOINT_ROWS]))
}
