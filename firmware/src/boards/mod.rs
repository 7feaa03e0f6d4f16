//! The boards, one module each: everything that differs between them is there (peripherals,
//! clocks, how the parameter slots are written, what a fault does).
//!
//! One board is built at a time: the Black Pill with the feature `board-blackpill`
//! (`cargo fw-board`, its image only), QEMU's mps2-an386 otherwise (every other image).
//! [`active`] names it for the modules that serve both: the fault handlers and the
//! parameter region.

#[cfg(feature = "board-blackpill")]
pub mod blackpill;
#[cfg(not(feature = "board-blackpill"))]
pub mod mps2_an386;

/// The board this build is for.
#[cfg(feature = "board-blackpill")]
pub use blackpill as active;
/// The board this build is for.
#[cfg(not(feature = "board-blackpill"))]
pub use mps2_an386 as active;
