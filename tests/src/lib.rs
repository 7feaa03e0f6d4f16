//! Helpers for the QEMU tests in `tests/tests/`: build an image once, parse what the
//! self-test prints, and compute the host's reference for the same inputs.
//!
//! The tests run the real device image in `qemu-system-arm -machine mps2-an386` through
//! `supine_host::device::{firmware, qemu}`, so the harness that CI uses is the one the `supine`
//! command uses.

use std::path::PathBuf;
use std::sync::Mutex;

use supine_core::model::{
    DeviceRealization, DiscreteModal, ModalState, Model, ModelParams, Output, Preset,
};
use supine_core::test_vector::TestVector;

/// Sample rate of the firmware's built-in realization, Hz: the device default, which
/// `firmware/build.rs` uses too.
pub const BUILTIN_SAMPLE_RATE_HZ: f64 = supine_core::model::DEFAULT_SAMPLE_RATE_HZ;

/// The product monitor's whole RAM budget (issue 16): its statics and its stack's
/// high-water mark together, bytes.
pub const RAM_BUDGET_BYTES: u64 = 16 * 1024;

/// The deepest the product monitor's stack may reach, boot, streaming and a committed
/// upload included: 14,964 B measured (BENCHMARKS.md) and a 396 B margin. The image's
/// statics and this stay within [`RAM_BUDGET_BYTES`] (`image_size.rs`).
pub const MONITOR_STACK_CEILING_BYTES: u32 = 15 * 1024;

/// One firmware build at a time: parallel tests would only queue on cargo's lock.
static BUILD: Mutex<()> = Mutex::new(());

/// Builds firmware binary `name` if stale and returns its ELF path; panics with the
/// builder's one-line error (what to install or fix) if it cannot.
pub fn firmware(name: &str) -> PathBuf {
    let _guard = BUILD
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    match supine_host::device::firmware::build_binary(name) {
        Ok(path) => path,
        Err(err) => panic!("{err}"),
    }
}

/// The realization the firmware bakes in, computed on the host the same way.
pub fn builtin_realization() -> DeviceRealization {
    let params = ModelParams::preset(Preset::PaperLitter);
    supine_core::model::device_realization(&params, BUILTIN_SAMPLE_RATE_HZ)
        .expect("the paper-litter preset discretizes")
}

/// The same realization in f64 (before rounding to f32): the accuracy reference.
pub fn builtin_realization_f64() -> DiscreteModal<f64, 3> {
    let params = ModelParams::preset(Preset::PaperLitter);
    Model::new(&params)
        .and_then(|model| model.realization(BUILTIN_SAMPLE_RATE_HZ, &Output::HEAD))
        .expect("the paper-litter preset discretizes")
}

/// Postcard bytes and CRC-32 (ISO-HDLC) of a realization: how the firmware names it.
pub fn identity(realization: &DeviceRealization) -> (usize, u32) {
    let mut buf = vec![0u8; 64 * 1024];
    let bytes = postcard::to_slice(realization, &mut buf).expect("the realization encodes");
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
    (bytes.len(), crc.checksum(bytes))
}

/// The host's f32 outputs for `samples` samples of `TestVector::new(seed)`.
pub fn host_outputs_f32(
    realization: &DeviceRealization,
    seed: u32,
    samples: usize,
) -> Vec<[f32; 3]> {
    let mut state = ModalState::<f32>::default();
    TestVector::new(seed)
        .take(samples)
        .map(|input| realization.step(&mut state, input))
        .collect()
}

/// The f64 outputs for the same inputs (each f32 input widened exactly).
pub fn host_outputs_f64(
    realization: &DiscreteModal<f64, 3>,
    seed: u32,
    samples: usize,
) -> Vec<[f64; 3]> {
    let mut state = ModalState::<f64>::default();
    TestVector::new(seed)
        .take(samples)
        .map(|input| realization.step(&mut state, input.map(f64::from)))
        .collect()
}

/// What the self-test image printed, parsed.
#[derive(Debug, Clone, PartialEq)]
pub struct SelftestReport {
    /// Firmware version.
    pub version: String,
    /// Length of the built-in realization's encoding.
    pub realization_bytes: usize,
    /// Its CRC-32.
    pub realization_crc32: u32,
    /// Its sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Test vector seed.
    pub seed: u32,
    /// Outputs (head x, y, z, m/s^2), in sample order.
    pub outputs: Vec<[f32; 3]>,
    /// Multiply-adds per sample the realization reports.
    pub multiply_adds_per_sample: usize,
    /// Steps in the timing loop.
    pub timed_steps: u64,
    /// SysTick ticks of the timing loop with the step.
    pub step_ticks: u64,
    /// SysTick ticks of the same loop without it.
    pub baseline_ticks: u64,
    /// Instructions per step (QEMU `-icount`), rounded.
    pub instructions_per_step: u64,
    /// Deepest stack use after decoding the realization and running the model, bytes.
    pub stack_model_bytes: usize,
    /// Deepest stack use since reset (golden checks included), bytes.
    pub stack_high_water_bytes: usize,
    /// Golden examples checked on the device: host-to-device, device-to-host messages.
    pub golden_messages: [usize; 2],
    /// Length of the golden blob the device encoded and matched.
    pub golden_blob_bytes: usize,
    /// Stack reserved, bytes.
    pub stack_size_bytes: usize,
}

/// Parses the self-test's stdout; any missing, repeated, out-of-order or malformed item
/// is an error naming the line. Lines the self-test does not print (QEMU's own
/// messages) are ignored.
pub fn parse_selftest(stdout: &str) -> Result<SelftestReport, String> {
    let mut version = None;
    let mut fields: std::collections::HashMap<&str, &str> = std::collections::HashMap::new();
    let mut outputs: Vec<[f32; 3]> = Vec::new();
    let mut samples: Option<usize> = None;
    let mut ok = false;
    for (number, line) in stdout.lines().enumerate() {
        let at = |what: &str| format!("line {}: {what}: {line:?}", number + 1);
        if let Some(rest) = line.strip_prefix("y ") {
            let parts: Vec<&str> = rest.split(' ').collect();
            let [index, x, y, z] = parts[..] else {
                return Err(at("an output line needs an index and three values"));
            };
            let index: usize = index.parse().map_err(|_| at("bad index"))?;
            if index != outputs.len() {
                return Err(at(&format!("expected output {}", outputs.len())));
            }
            let bits = |hex: &str| {
                if hex.len() != 8 {
                    return Err(at("f32 bits must be 8 hex digits"));
                }
                u32::from_str_radix(hex, 16)
                    .map(f32::from_bits)
                    .map_err(|_| at("bad hex"))
            };
            outputs.push([bits(x)?, bits(y)?, bits(z)?]);
        } else if let Some(rest) = line.strip_prefix("selftest: ") {
            match rest {
                "ok" => ok = true,
                _ => match rest.strip_prefix("supine-firmware ") {
                    Some(v) => version = Some(v.to_owned()),
                    None => return Err(at("unknown selftest line")),
                },
            }
        } else if let Some((key, value)) = line.split_once(": ") {
            if key == "samples" {
                samples = Some(value.parse().map_err(|_| at("bad sample count"))?);
            } else if fields.insert(key, value).is_some() {
                return Err(at("repeated item"));
            }
        }
    }
    if !ok {
        return Err("the self-test did not print `selftest: ok`".to_owned());
    }
    let samples = samples.ok_or("no `samples:` line")?;
    if outputs.len() != samples {
        return Err(format!("{} outputs for {samples} samples", outputs.len()));
    }
    let get = |key: &str| fields.get(key).copied().ok_or(format!("no `{key}:` line"));
    let num = |key: &str| -> Result<u64, String> {
        get(key)?
            .parse()
            .map_err(|_| format!("`{key}:` is not a number"))
    };
    let size = |key: &str| num(key).map(|n| n as usize);
    let passed = |key: &str| -> Result<usize, String> {
        get(key)?
            .strip_suffix(" ok")
            .and_then(|n| n.parse().ok())
            .ok_or(format!("`{key}:` is not `<n> ok`"))
    };
    Ok(SelftestReport {
        version: version.ok_or("no version line")?,
        realization_bytes: size("realization_bytes")?,
        realization_crc32: u32::from_str_radix(get("realization_crc32")?, 16)
            .map_err(|_| "`realization_crc32:` is not hex".to_owned())?,
        sample_rate_hz: get("sample_rate_hz")?
            .parse()
            .map_err(|_| "`sample_rate_hz:` is not a number".to_owned())?,
        seed: u32::try_from(num("seed")?).map_err(|_| "`seed:` is not a u32".to_owned())?,
        outputs,
        multiply_adds_per_sample: size("multiply_adds_per_sample")?,
        timed_steps: num("timed_steps")?,
        step_ticks: num("step_ticks")?,
        baseline_ticks: num("baseline_ticks")?,
        instructions_per_step: num("instructions_per_step")?,
        stack_model_bytes: size("stack_model_bytes")?,
        stack_high_water_bytes: size("stack_high_water_bytes")?,
        golden_messages: [
            passed("golden_host_to_device")?,
            passed("golden_device_to_host")?,
        ],
        golden_blob_bytes: passed("golden_blob")?,
        stack_size_bytes: size("stack_size_bytes")?,
    })
}

/// The `supine` binary next to the running test's target dir, built or brought up to date
/// first (an older binary may lack a command under test), in the test's own profile.
pub fn supine_binary() -> PathBuf {
    static BUILD: Mutex<()> = Mutex::new(());
    let _guard = BUILD.lock().unwrap_or_else(|p| p.into_inner());
    let exe = std::env::current_exe().expect("test executable path");
    // target/<dir>/<profile>/deps/<test>-<hash> -> target/<dir>/<profile>/supine
    let profile_dir = exe
        .parent()
        .and_then(std::path::Path::parent)
        .expect("deps/ inside the profile dir");
    let target_dir = profile_dir.parent().expect("target dir");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut build = std::process::Command::new(cargo);
    build.args([
        "build",
        "-p",
        "supine-host",
        "--bin",
        "supine",
        "--target-dir",
    ]);
    build.arg(target_dir);
    if profile_dir.file_name().is_some_and(|n| n == "release") {
        build.arg("--release");
    }
    let status = build
        .current_dir(supine_host::device::firmware::repository_root())
        .status()
        .expect("cargo runs");
    assert!(status.success(), "building supine failed");
    profile_dir.join("supine")
}

/// Runs `command` to its end: (success, stdout, stderr), decoded lossily.
pub fn run_to_end(command: &mut std::process::Command) -> (bool, String, String) {
    let output = command.output().expect("the command runs");
    (
        output.status.success(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Runs `supine ARGS`: (success, stdout, stderr).
pub fn run_supine(args: &[&str]) -> (bool, String, String) {
    run_to_end(std::process::Command::new(supine_binary()).args(args))
}

/// 20 s of rough road from `supine ride` (seed 3), with one shock (one per 20 s window)
/// to drive alert events, written to `dir/ride.csv`.
pub fn rough_ride(dir: &std::path::Path) -> PathBuf {
    let ride = dir.join("ride.csv");
    let path = ride.to_str().expect("utf-8 path");
    let (ok, _, stderr) = run_supine(&[
        "ride",
        "--profile",
        "rough-road",
        "--duration-s",
        "20",
        "--seed",
        "3",
        "--out",
        path,
    ]);
    assert!(ok, "{stderr}");
    assert!(stderr.contains(", 1 shock\n"), "{stderr}");
    ride
}

/// `supine monitor --qemu` of `ride` with the paper-litter preset, logging to `log`: the
/// session the monitor and re-analysis tests read back. Returns `run_supine`'s result.
pub fn monitor_to_log(ride: &std::path::Path, log: &std::path::Path) -> (bool, String, String) {
    let s = |p: &std::path::Path| p.to_str().expect("utf-8 path").to_owned();
    run_supine(&[
        "monitor",
        "--qemu",
        "--preset",
        "paper-litter",
        "--input",
        &s(ride),
        "--log",
        &s(log),
    ])
}

/// The process ids of `pid`'s children (Linux `/proc`).
pub fn child_pids(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for task in tasks.flatten() {
            if let Ok(text) = std::fs::read_to_string(task.path().join("children")) {
                out.extend(
                    text.split_whitespace()
                        .filter_map(|p| p.parse::<u32>().ok()),
                );
            }
        }
    }
    out
}

/// The command line of process `pid` (arguments joined by spaces) if it is a running
/// `qemu-system-arm`.
pub fn qemu_cmdline(pid: u32) -> Option<String> {
    let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
    let text = String::from_utf8_lossy(&cmdline).replace('\0', " ");
    text.contains("qemu-system-arm").then_some(text)
}

/// Sends signal `name` (`INT`, `TERM`, `HUP`) to `child` and waits for it to exit.
pub fn signal_and_wait(child: std::process::Child, name: &str) -> std::process::Output {
    let status = std::process::Command::new("kill")
        .args([format!("-{name}"), child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success(), "kill -{name} failed");
    child.wait_with_output().expect("the child exits")
}

/// Waits (up to 2 minutes, else panics) until process `parent` has a `qemu-system-arm`
/// child; returns its pid and command line.
pub fn wait_for_qemu_child(parent: u32) -> (u32, String) {
    let start = std::time::Instant::now();
    loop {
        if let Some(found) = child_pids(parent)
            .into_iter()
            .find_map(|p| qemu_cmdline(p).map(|c| (p, c)))
        {
            return found;
        }
        assert!(
            start.elapsed() < std::time::Duration::from_secs(120),
            "no QEMU started"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

/// Running `qemu-system-arm` processes whose command line mentions `path` (e.g. the
/// private TMPDIR a test gave `supine`, where each run's socket folder lives).
pub fn qemu_processes_mentioning(path: &std::path::Path) -> Vec<u32> {
    let needle = path.to_string_lossy().into_owned();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|&pid| qemu_cmdline(pid).is_some_and(|c| c.contains(&needle)))
        .collect()
}

/// What is left in folder `dir` (names), for checks that a run cleaned up after itself.
pub fn entries(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// A stand-in for `qemu-system-arm` (for `SUPINE_QEMU`): a shell script in `dir` that runs
/// the real QEMU as `body` says, e.g. `exec qemu-system-arm -S "$@"` (never starts the
/// guest) or `exec timeout -s KILL 2 qemu-system-arm "$@"` (dies mid-run).
pub fn qemu_wrapper(dir: &std::path::Path, name: &str, body: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt as _;
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).expect("write the wrapper");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755))
        .expect("make the wrapper executable");
    path
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "selftest: supine-firmware 0.1.0\n\
        realization_bytes: 825\n\
        realization_crc32: 21a218b7\n\
        sample_rate_hz: 500\n\
        seed: 1\n\
        samples: 2\n\
        y 0 3f800000 bf800000 00000000\n\
        y 1 40000000 00000001 7f800000\n\
        stack_model_bytes: 1200\n\
        golden_host_to_device: 6 ok\n\
        golden_device_to_host: 7 ok\n\
        golden_blob: 1269 ok\n\
        multiply_adds_per_sample: 189\n\
        timed_steps: 4096\n\
        step_ticks: 75787\n\
        baseline_ticks: 1034\n\
        instructions_per_step: 730\n\
        stack_high_water_bytes: 5548\n\
        stack_size_bytes: 131068\n\
        selftest: ok\n";

    #[test]
    fn a_complete_report_parses_to_exact_bits() {
        let report = parse_selftest(GOOD).expect("parses");
        assert_eq!(report.version, "0.1.0");
        assert_eq!(report.realization_crc32, 0x21a2_18b7);
        assert_eq!(report.outputs[0], [1.0, -1.0, 0.0]);
        assert_eq!(report.outputs[1][1].to_bits(), 1);
        assert_eq!(report.outputs[1][2], f32::INFINITY);
        assert_eq!(report.instructions_per_step, 730);
        assert_eq!(report.stack_high_water_bytes, 5548);
        assert_eq!(report.stack_model_bytes, 1200);
        assert_eq!(report.golden_messages, [6, 7]);
        assert_eq!(report.golden_blob_bytes, 1269);
    }

    #[test]
    fn a_golden_line_without_ok_is_refused() {
        let failed = GOOD.replace("golden_blob: 1269 ok", "golden_blob: 1269");
        assert!(parse_selftest(&failed).unwrap_err().contains("golden_blob"));
    }

    #[test]
    fn a_report_without_ok_is_refused() {
        let cut = GOOD.replace("selftest: ok\n", "");
        assert!(parse_selftest(&cut).unwrap_err().contains("selftest: ok"));
    }

    #[test]
    fn a_missing_or_reordered_output_is_refused() {
        let missing = GOOD.replace("y 1 40000000 00000001 7f800000\n", "");
        assert!(
            parse_selftest(&missing)
                .unwrap_err()
                .contains("1 outputs for 2")
        );
        let swapped = GOOD.replace("y 0 ", "y 9 ");
        assert!(
            parse_selftest(&swapped)
                .unwrap_err()
                .contains("expected output 0")
        );
    }

    #[test]
    fn short_or_non_hex_bits_are_refused() {
        let short = GOOD.replace("3f800000", "3f8000");
        assert!(parse_selftest(&short).unwrap_err().contains("8 hex digits"));
        let bad = GOOD.replace("3f800000", "3f80000g");
        assert!(parse_selftest(&bad).unwrap_err().contains("bad hex"));
    }

    #[test]
    fn the_host_reference_is_deterministic_and_close_to_f64() {
        let device = builtin_realization();
        let a = host_outputs_f32(&device, 1, 200);
        let b = host_outputs_f32(&device, 1, 200);
        assert_eq!(a, b);
        let reference = host_outputs_f64(&builtin_realization_f64(), 1, 200);
        let worst = a
            .iter()
            .zip(&reference)
            .flat_map(|(y, r)| y.iter().zip(r).map(|(&y, &r)| (f64::from(y) - r).abs()))
            .fold(0.0, f64::max);
        assert!(worst < 1e-4, "f32 vs f64 worst {worst:e} m/s^2");
    }
}
