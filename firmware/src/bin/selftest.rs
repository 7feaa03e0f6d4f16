//! The self-test image: runs the model core on the built-in test vector under QEMU.
//!
//! It decodes the built-in realization, runs [`SAMPLES`] samples of
//! `TestVector::new(SEED)` through the device's model step (the FPU assembly of
//! `supine_core::model::fpu_loops`) and prints every output's f32 bits, compares that
//! assembly with the Rust definitions compiled beside it (`DiscreteModal::step` and
//! `JointReadout::read_packed_by::<true>`) bit for bit, for every row count the step and
//! the readout take, with and without blocks, and for every selection of joint outputs,
//! checks the wire protocol's golden bytes (`supine_core::protocol::golden`: every
//! message and the example blob must encode to exactly the bytes the host recorded, and
//! decode back), then measures the instructions per model step and the stack high-water
//! mark. The host test (`tests/tests/selftest.rs`) recomputes the same samples and
//! compares bit for bit.
//!
//! Output (semihosting stdout), one item per line:
//! ```text
//! selftest: supine-firmware <version>
//! realization_bytes: <n>
//! realization_crc32: <8 hex digits>
//! sample_rate_hz: <whole Hz>
//! seed: <u32>
//! samples: <n>
//! y <index> <x bits> <y bits> <z bits>      (f32 bits, 8 hex digits each)
//! stack_model_bytes: <n>                  (stack high-water mark after the model run)
//! asm_step_cases: <n> ok                  (block layouts x row counts, assembly = Rust)
//! asm_readout_selections: <n> ok          (joint-output masks, assembly = Rust)
//! asm_readout_layouts: <n> ok             (block layouts with empty groups, all rows)
//! golden_host_to_device: <n> ok
//! golden_device_to_host: <n> ok
//! golden_blob: <bytes> ok
//! multiply_adds_per_sample: <n>
//! timed_steps: <n>
//! step_ticks: <n>
//! baseline_ticks: <n>
//! instructions_per_step: <n>
//! exposure_stage_instructions_per_sample: <n>  (weighting, running rms, VDV, alerts; 3 axes)
//! pipeline_instructions_per_sample: <n>   (DeviceParams::process, telemetry not encoded)
//! telemetry_frame_instructions: <n>       (hand-written telemetry frame encoding)
//! sqrtf_instructions: <n>                 (one libm::sqrtf)
//! stack_high_water_bytes: <n>             (after everything, golden checks included)
//! stack_size_bytes: <n>
//! selftest: ok
//! ```
//! Exit status 0 when every output is finite, every golden check passed and every line
//! was written; otherwise a line `selftest: failed: <why>` on stderr and status 1 (101 on
//! a panic).
#![no_std]
#![no_main]

use core::fmt::{self, Write};
use core::hint::black_box;

use cortex_m_rt::entry;
use cortex_m_semihosting::hio;
use serde::Serialize;
use serde::de::DeserializeOwned;
use supine_core::blob::{DeviceParams, MAX_BLOB_LEN};
use supine_core::fpu::sqrt_f32;
use supine_core::model::{DeviceRealization, JOINT_OUTPUT_COUNT, JointReadout, ModalState};
use supine_core::protocol::{FrameAccumulator, FrameEvent, MAX_FRAME_LEN, encode_frame, golden};
use supine_core::test_vector::TestVector;
use supine_core::timing::INSTRUCTIONS_PER_TICK;
use supine_firmware::boards::mps2_an386::{Board, SYSCLK_HZ};
use supine_firmware::console::Console;
use supine_firmware::cycles::SysTickCounter;
use supine_firmware::{VERSION, exit, params, stack};

/// Seed of the test vector; the host test reads it from the output.
const SEED: u32 = 1;
/// Samples run and printed (4 s at 500 Hz).
const SAMPLES: usize = 2_000;
/// Inputs held in memory for the timing loop, so it times the model and not the generator.
const TIMING_INPUTS: usize = 64;
/// Passes over the timing inputs: 64 x 64 = 4,096 timed steps.
const TIMING_ROUNDS: usize = 64;

/// What made the self-test fail.
#[derive(Debug, Clone, Copy)]
enum Failure {
    Peripherals,
    Console,
    Params(params::ParamsError),
    NotFinite {
        index: usize,
    },
    Golden {
        what: &'static str,
        index: usize,
    },
    Assembly {
        what: &'static str,
        case: usize,
        sample: usize,
    },
    Output,
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Peripherals => f.write_str("the peripherals were already taken"),
            Self::Console => f.write_str("semihosting stdout is not available"),
            Self::Params(err) => write!(f, "built-in realization: {err}"),
            Self::NotFinite { index } => write!(f, "output {index} is not finite"),
            Self::Golden { what, index } => {
                write!(f, "golden {what} example {index} does not match its bytes")
            }
            Self::Assembly { what, case, sample } => write!(
                f,
                "the assembly's {what} differs from its Rust definition in case {case} at sample {sample}"
            ),
            Self::Output => f.write_str("writing to semihosting stdout failed"),
        }
    }
}

impl From<fmt::Error> for Failure {
    fn from(_: fmt::Error) -> Self {
        Self::Output
    }
}

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => exit::exit(exit::SUCCESS),
        Err(failure) => {
            if let Ok(mut stderr) = hio::hstderr() {
                let _ = writeln!(stderr, "selftest: failed: {failure}");
            }
            exit::exit(exit::FAILURE)
        }
    }
}

fn run() -> Result<(), Failure> {
    let board = Board::take().ok_or(Failure::Peripherals)?;
    let counter = SysTickCounter::new(board.syst, SYSCLK_HZ);
    let mut out = Console::stdout().map_err(|_| Failure::Console)?;

    writeln!(out, "selftest: supine-firmware {VERSION}")?;
    let bytes = params::builtin_bytes();
    writeln!(out, "realization_bytes: {}", bytes.len())?;
    writeln!(out, "realization_crc32: {:08x}", params::identity(bytes))?;
    writeln!(out, "sample_rate_hz: {}", params::SAMPLE_RATE_HZ)?;
    let realization = params::decode(bytes).map_err(Failure::Params)?;

    run_test_vector(&realization, &mut out)?;
    // The stack so far: decoding the realization and running the model.
    writeln!(out, "stack_model_bytes: {}", stack::high_water_bytes())?;
    compare_assembly(&mut out)?;
    check_golden(&mut out)?;

    writeln!(
        out,
        "multiply_adds_per_sample: {}",
        realization.multiply_adds_per_sample()
    )?;
    let (step_ticks, baseline_ticks) = time_steps(&realization, &counter);
    let timed = TIMING_INPUTS * TIMING_ROUNDS;
    writeln!(out, "timed_steps: {timed}")?;
    writeln!(out, "step_ticks: {step_ticks}")?;
    writeln!(out, "baseline_ticks: {baseline_ticks}")?;
    let net_instructions =
        u64::from(step_ticks.saturating_sub(baseline_ticks)) * u64::from(INSTRUCTIONS_PER_TICK);
    // Rounded to the nearest whole instruction.
    let per_step = (net_instructions + timed as u64 / 2) / timed as u64;
    writeln!(out, "instructions_per_step: {per_step}")?;

    time_stages(&counter, &mut out)?;

    writeln!(out, "stack_high_water_bytes: {}", stack::high_water_bytes())?;
    writeln!(out, "stack_size_bytes: {}", stack::size_bytes())?;
    writeln!(out, "selftest: ok")?;
    Ok(())
}

/// Runs the test vector through the realization as the device steps it and prints every
/// output's bits.
fn run_test_vector(realization: &DeviceRealization, out: &mut Console) -> Result<(), Failure> {
    writeln!(out, "seed: {SEED}")?;
    writeln!(out, "samples: {SAMPLES}")?;
    let mut state = ModalState::<f32>::default();
    for (index, input) in TestVector::new(SEED).take(SAMPLES).enumerate() {
        let y = realization.step_device(&mut state, input);
        writeln!(
            out,
            "y {index} {:08x} {:08x} {:08x}",
            y[0].to_bits(),
            y[1].to_bits(),
            y[2].to_bits()
        )?;
        if !y.iter().all(|v| v.is_finite()) {
            return Err(Failure::NotFinite { index });
        }
    }
    Ok(())
}

/// Samples each comparison of the assembly runs.
const ASM_SAMPLES: usize = 48;
/// Of those, the first ones only move the state away from rest before the readout is read.
const ASM_SETTLE_SAMPLES: usize = 16;
/// Block layouts compared: as built, then with each group's blocks given to its neighbour
/// (a group of zero blocks), then with every block in the z group (x and y empty).
const ASM_LAYOUTS: usize = 5;

/// The built-in realization with its blocks regrouped by `layout` (see [`ASM_LAYOUTS`];
/// the blocks themselves unchanged, so every one stays stable).
fn regrouped(head: &DeviceRealization, layout: usize) -> DeviceRealization {
    let mut r = *head;
    let [x, y, z] = head.groups.map(|g| g.block_count);
    let counts = match layout {
        1 => [0, x + y, z],
        2 => [x + y, 0, z],
        3 => [x, y + z, 0],
        4 => [0, 0, x + y + z],
        _ => [x, y, z],
    };
    for (g, n) in r.groups.iter_mut().zip(counts) {
        g.block_count = n;
    }
    r
}

/// `head` with every group's output rows set to `rows` (0-3): the rows it has are kept,
/// a row it lacks is its first row halved (so nothing multiplies by zero).
fn with_rows(head: &DeviceRealization, rows: u8) -> DeviceRealization {
    let mut r = *head;
    let mut first = 0;
    for g in r.groups.iter_mut() {
        let end = (first + usize::from(g.block_count)).min(r.blocks.len());
        let built = usize::from(g.output_count);
        for k in built.max(1)..3 {
            g.feedthrough[k] = 0.5 * g.feedthrough[k - 1];
            for block in &mut r.blocks[first..end] {
                block.output[k] = block.output[k - 1].map(|c| 0.5 * c);
            }
        }
        g.output_count = rows;
        g.outputs = [0, 1, 2];
        first = end;
    }
    r
}

/// The model step's assembly (`step_device`) against its Rust definition (`step`), in
/// outputs and state, from rest over [`ASM_SAMPLES`] samples.
fn compare_step(r: &DeviceRealization, case: usize) -> Result<(), Failure> {
    let (mut asm, mut definition) = (ModalState::<f32>::default(), ModalState::<f32>::default());
    let inputs = TestVector::new(SEED.wrapping_add(3)).take(ASM_SAMPLES);
    for (sample, u) in inputs.enumerate() {
        let a = black_box(r).step_device(&mut asm, u);
        let d = black_box(r).step(&mut definition, u);
        let same_state = asm
            .blocks
            .iter()
            .zip(&definition.blocks)
            .all(|(a, d)| a.map(f32::to_bits) == d.map(f32::to_bits));
        if a.map(f32::to_bits) != d.map(f32::to_bits) || !same_state {
            return Err(Failure::Assembly {
                what: "model step",
                case,
                sample,
            });
        }
    }
    Ok(())
}

/// The readout's assembly (`read_packed`) against its Rust definition, on the states of
/// `head` stepped over [`ASM_SAMPLES`] samples.
fn compare_readout(
    head: &DeviceRealization,
    readout: &JointReadout,
    case: usize,
) -> Result<(), Failure> {
    let mut state = ModalState::<f32>::default();
    let inputs = TestVector::new(SEED.wrapping_add(4)).take(ASM_SAMPLES);
    for (sample, u) in inputs.enumerate() {
        if sample >= ASM_SETTLE_SAMPLES {
            let (mut a, mut d) = ([0.0; JOINT_OUTPUT_COUNT], [0.0; JOINT_OUTPUT_COUNT]);
            let n = black_box(readout).read_packed(head, &state, u, &mut a);
            let m = black_box(readout).read_packed_by::<true>(head, &state, u, &mut d);
            if n != m || a.map(f32::to_bits) != d.map(f32::to_bits) {
                return Err(Failure::Assembly {
                    what: "joint readout",
                    case,
                    sample,
                });
            }
        }
        head.step_device(&mut state, u);
    }
    Ok(())
}

/// The FPU assembly against the Rust definitions compiled beside it, bit for bit: the
/// model step for 0 to 3 rows a group on every layout of [`ASM_LAYOUTS`]; the joint
/// readout (1 to 4 rows a group, or none) for every selection of the built-in default's
/// joint outputs, and for all of them on the layouts with empty groups (a loop over zero
/// blocks).
fn compare_assembly(out: &mut Console) -> Result<(), Failure> {
    let failure = Failure::Golden {
        what: "default blob",
        index: 0,
    };
    let device = DeviceParams::decode(params::default_blob()).map_err(|_| failure)?;
    let head = &device.realization;
    let mut case = 0;
    for layout in 0..ASM_LAYOUTS {
        for rows in 0..=3 {
            compare_step(&with_rows(&regrouped(head, layout), rows), case)?;
            case += 1;
        }
    }
    writeln!(out, "asm_step_cases: {case} ok")?;
    let selections = 1u16 << JOINT_OUTPUT_COUNT;
    for mask in 0..selections {
        compare_readout(head, &device.joints.select(head, mask), usize::from(mask))?;
    }
    writeln!(out, "asm_readout_selections: {selections} ok")?;
    for layout in 1..ASM_LAYOUTS {
        compare_readout(&regrouped(head, layout), &device.joints, layout)?;
    }
    writeln!(out, "asm_readout_layouts: {} ok", ASM_LAYOUTS - 1)?;
    Ok(())
}

/// Checks the golden bytes of every protocol message and of the example blob.
fn check_golden(out: &mut Console) -> Result<(), Failure> {
    let host_to_device = check_frames(
        &golden::host_to_device_examples(),
        &golden::HOST_TO_DEVICE,
        "host_to_device",
    )?;
    writeln!(out, "golden_host_to_device: {host_to_device} ok")?;
    let device_to_host = check_frames(
        &golden::device_to_host_examples(),
        &golden::DEVICE_TO_HOST,
        "device_to_host",
    )?;
    writeln!(out, "golden_device_to_host: {device_to_host} ok")?;

    let blob_failure = Failure::Golden {
        what: "blob",
        index: 0,
    };
    // Built on the device: its filter design runs here, so this also checks that the
    // device computes the host's coefficients bit for bit.
    let example = golden::blob_example().map_err(|_| blob_failure)?;
    let mut buf = [0u8; MAX_BLOB_LEN];
    let len = example.encode(&mut buf).map_err(|_| blob_failure)?;
    if buf.get(..len) != Some(golden::BLOB) {
        return Err(blob_failure);
    }
    if DeviceParams::decode(golden::BLOB).map_err(|_| blob_failure)? != example {
        return Err(blob_failure);
    }
    writeln!(out, "golden_blob: {len} ok")?;
    Ok(())
}

/// Each example must encode to its golden frame and decode from it to itself; returns
/// how many were checked.
fn check_frames<T: Serialize + DeserializeOwned + PartialEq>(
    examples: &[T],
    frames: &[&[u8]],
    what: &'static str,
) -> Result<usize, Failure> {
    if examples.len() != frames.len() {
        let index = examples.len().min(frames.len());
        return Err(Failure::Golden { what, index });
    }
    for (index, (example, golden)) in examples.iter().zip(frames).enumerate() {
        let failure = Failure::Golden { what, index };
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = encode_frame(example, &mut buf).map_err(|_| failure)?;
        if &*frame != *golden {
            return Err(failure);
        }
        let mut accumulator = FrameAccumulator::new();
        let mut decoded = None;
        for &byte in *golden {
            match accumulator.push::<T>(byte) {
                FrameEvent::Pending => {}
                FrameEvent::Message(message) if decoded.is_none() => decoded = Some(message),
                FrameEvent::Message(_) | FrameEvent::Dropped(_) => return Err(failure),
            }
        }
        if decoded.as_ref() != Some(example) {
            return Err(failure);
        }
    }
    Ok(examples.len())
}

/// SysTick ticks for `TIMING_ROUNDS` passes over `TIMING_INPUTS` inputs, with the model
/// step and with the step replaced by a pass-through (the loop's own cost).
fn time_steps(realization: &DeviceRealization, counter: &SysTickCounter) -> (u32, u32) {
    let mut inputs = [[0.0_f32; 3]; TIMING_INPUTS];
    for (slot, input) in inputs.iter_mut().zip(TestVector::new(SEED.wrapping_add(1))) {
        *slot = input;
    }
    let mut state = ModalState::<f32>::default();
    let (step_ticks, ()) = counter.ticks(|| {
        for _ in 0..TIMING_ROUNDS {
            for input in &inputs {
                let y =
                    black_box(realization).step_device(black_box(&mut state), black_box(*input));
                black_box(y);
            }
        }
    });
    let (baseline_ticks, ()) = counter.ticks(|| {
        for _ in 0..TIMING_ROUNDS {
            for input in &inputs {
                black_box(black_box(*input));
            }
        }
    });
    (step_ticks, baseline_ticks)
}

/// Samples in the stage timings: 64 blocks of 16 at the built-in default's 500 Hz.
const STAGE_SAMPLES: usize = 1024;

/// Times the stages of the device pipeline on the built-in default parameters and prints
/// instructions per sample (QEMU -icount): the exposure stage alone (`step_block` of the
/// exposure and the alerts on 16-sample blocks of head accelerations), the whole
/// `DeviceParams::process` with a no-op `emit`, one telemetry frame's encoding and one
/// `libm::sqrtf` (the telemetry's six square roots are in software on this target).
fn time_stages(counter: &SysTickCounter, out: &mut Console) -> Result<(), Failure> {
    use supine_core::alerts::{AlertState, FaultFlags};
    use supine_core::exposure::{ExposureSample, ExposureState};
    use supine_core::pipeline::{BLOCK_LEN, PipelineState};
    use supine_core::protocol::{Telemetry, telemetry_frame};

    let failure = Failure::Golden {
        what: "default blob",
        index: 0,
    };
    let device = DeviceParams::decode(params::default_blob()).map_err(|_| failure)?;
    let mut inputs = [[0.0_f32; 3]; BLOCK_LEN];
    let mut indices = [0u32; BLOCK_LEN];
    let mut vector = TestVector::new(SEED.wrapping_add(2));
    let rounds = (STAGE_SAMPLES / BLOCK_LEN) as u32;
    let per_sample = |ticks: u32, samples: usize| {
        (u64::from(ticks) * u64::from(INSTRUCTIONS_PER_TICK) + samples as u64 / 2) / samples as u64
    };

    // Exposure and alerts, on the model's typical outputs (the test vector scaled down),
    // timed after the warm-up: before it the alert stage skips its comparisons.
    let mut exposure_state = ExposureState::new();
    let mut alert_state = AlertState::new();
    let mut samples = [ExposureSample::default(); BLOCK_LEN];
    let warmup_rounds = device.exposure.warmup_samples / BLOCK_LEN as u32 + 1;
    let mut ticks = 0u32;
    let mut timed_valid = true;
    for round in 0..warmup_rounds + rounds {
        for slot in inputs.iter_mut() {
            *slot = vector.next().unwrap_or_default().map(|v| 0.5 * v);
        }
        let first = round * BLOCK_LEN as u32;
        if round < warmup_rounds {
            device.exposure_stage(
                &mut exposure_state,
                &mut alert_state,
                &inputs,
                first,
                &mut samples,
                &mut |_| {},
            );
            continue;
        }
        let (t, ()) = counter.ticks(|| {
            device.exposure_stage(
                black_box(&mut exposure_state),
                black_box(&mut alert_state),
                black_box(&inputs),
                first,
                &mut samples,
                &mut |e| {
                    black_box(e);
                },
            );
        });
        ticks = ticks.wrapping_add(t);
        timed_valid &= samples.iter().all(|s| s.valid);
    }
    writeln!(
        out,
        "exposure_stage_instructions_per_sample: {}",
        per_sample(ticks, STAGE_SAMPLES)
    )?;
    writeln!(
        out,
        "exposure_stage_timed_after_warmup: {}",
        u8::from(timed_valid)
    )?;

    let mut state = PipelineState::new();
    let mut ticks = 0u32;
    for round in 0..warmup_rounds + rounds {
        for (k, (slot, index)) in inputs.iter_mut().zip(indices.iter_mut()).enumerate() {
            *slot = vector.next().unwrap_or_default();
            *index = round * BLOCK_LEN as u32 + k as u32;
        }
        if round < warmup_rounds {
            device.process(&mut state, &indices, &inputs, |_| {});
            continue;
        }
        let (t, ()) = counter.ticks(|| {
            device.process(black_box(&mut state), &indices, black_box(&inputs), |o| {
                black_box(o);
            });
        });
        ticks = ticks.wrapping_add(t);
    }
    writeln!(
        out,
        "pipeline_instructions_per_sample: {}",
        per_sample(ticks, STAGE_SAMPLES)
    )?;

    let telemetry = Telemetry {
        sample_index: 123_456,
        head_acc_m_s2: [0.1, -0.2, 0.3],
        running_rms_m_s2: [0.01, 0.02, 0.5],
        vector_running_rms_m_s2: 0.7,
        vdv_m_s175: 3.5,
        alert_level: supine_core::alerts::Level::Warning,
        fault_flags: FaultFlags::empty(),
        valid: true,
        // All ten joint outputs, the default: the largest record.
        joints: supine_core::joint_exposure::JointValues::packed(
            10,
            [
                1e-3, -2e-3, 3e-3, 4e-3, -5e-3, 6e-3, 7e-3, -8e-3, 9e-3, 1e-2,
            ],
        ),
    };
    let mut frame = [0u8; telemetry_frame::MAX_FRAME];
    let (t, ()) = counter.ticks(|| {
        for seq in 0..STAGE_SAMPLES as u32 {
            black_box(telemetry_frame::encode(
                black_box(seq + 1_000_000),
                black_box(&telemetry),
                &mut frame,
            ));
            // Read the frame, or the compiler drops the stores and most of the work.
            black_box(&mut frame);
        }
    });
    writeln!(
        out,
        "telemetry_frame_instructions: {}",
        per_sample(t, STAGE_SAMPLES)
    )?;
    let (t, ()) = counter.ticks(|| {
        let mut x = 1.234_f32;
        for _ in 0..STAGE_SAMPLES {
            x = libm::sqrtf(black_box(x)) + 1.0;
        }
        black_box(x);
    });
    writeln!(out, "sqrtf_instructions: {}", per_sample(t, STAGE_SAMPLES))?;

    // The core's square root (`supine_core::fpu::sqrt_f32`, the FPU's vsqrt.f32): as cheap
    // as a multiply and, being correctly rounded like libm's, bit-identical to it (checked
    // here on 4,096 values; the host's fallback is libm itself).
    let (t, ()) = counter.ticks(|| {
        let mut x = 1.234_f32;
        for _ in 0..STAGE_SAMPLES {
            x = sqrt_f32(black_box(x)) + 1.0;
        }
        black_box(x);
    });
    writeln!(out, "vsqrt_instructions: {}", per_sample(t, STAGE_SAMPLES))?;
    let mut bits = 0x3000_0000_u32;
    for index in 0..4096 {
        let x = f32::from_bits(bits);
        if sqrt_f32(x).to_bits() != libm::sqrtf(x).to_bits() {
            return Err(Failure::Golden {
                what: "fpu::sqrt_f32 (vsqrt) vs libm::sqrtf",
                index,
            });
        }
        bits = bits.wrapping_add(0x0004_0321);
    }
    writeln!(out, "vsqrt_matches_libm: 4096 ok")?;
    Ok(())
}
