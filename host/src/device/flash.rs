//! Getting a parameter file onto a device: the blob for one sample rate, the PARAMS
//! region image a loader or programmer places (QEMU's `-device loader`, probe-rs), and the
//! authenticated upload over a running device's link (a serial port, or QEMU's UART), and
//! probe-rs for a board.
//!
//! A region image covers the whole 64 KiB region: slot A holds the blob and a commit
//! record, everything else is erased (0xFF). Writing the whole region matters: a stale
//! committed slot B left by an earlier upload would otherwise win the boot selection.

use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::{Result, anyhow, bail};
use supine_core::blob::DeviceParams;
use supine_core::protocol::{Greeting, HostToDevice};
use supine_core::upload::{
    COMMIT_LEN, KEY_LEN, ParamFlash, SLOT_COUNT, SLOT_LEN, commit_record, select,
};

use crate::device::device_params::{self, identity_hex};
use crate::device::link::{FrameReader, FrameWriter};
use crate::device::qemu::{Qemu, QemuConfig};
use crate::device::upload_client::{self, Uploaded};
use crate::io::params_file::ParamFile;

/// Bytes of the PARAMS region image: both slots.
pub const REGION_LEN: usize = SLOT_COUNT * SLOT_LEN;

/// Update counter of the commit record in a region image from [`qemu_region_image`].
/// Uploads over the link use larger counters (by default from [`choose_counter`]).
pub const REGION_IMAGE_COUNTER: u32 = 1;

/// The device parameters for `file` at `sample_rate_hz` and their blob bytes.
pub fn device_blob(file: &ParamFile, sample_rate_hz: f64) -> Result<(DeviceParams, Vec<u8>)> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        bail!("--fs: expected a positive sample rate in Hz, got {sample_rate_hz}");
    }
    let params = device_params::build(file, sample_rate_hz)?;
    let blob = device_params::encode(&params)?;
    Ok((params, blob))
}

/// Where the Black Pill's PARAMS region starts: flash sector 6 (slot A; sector 7 is B).
pub const BLACKPILL_PARAMS_ADDR: u32 = 0x0804_0000;
/// Distance between the Black Pill's slots: one 128 KiB flash sector each.
pub const BLACKPILL_SLOT_STRIDE: usize = 128 * 1024;

/// The PARAMS region (QEMU's layout: slots 32 KiB apart) with `blob` committed in slot A
/// under `counter`, the rest erased.
pub fn region_image(blob: &[u8], counter: u32) -> Result<Vec<u8>> {
    region_image_with_stride(blob, counter, SLOT_LEN)
}

/// The PARAMS region with slots `slot_stride` bytes apart, `blob` committed in slot A
/// under `counter`, everything else up to the end of slot B erased. Checked with the
/// device's own boot selection before it is returned.
pub fn region_image_with_stride(blob: &[u8], counter: u32, slot_stride: usize) -> Result<Vec<u8>> {
    if blob.len() + COMMIT_LEN > SLOT_LEN {
        bail!(
            "the blob has {} bytes; a slot holds {}",
            blob.len(),
            SLOT_LEN - COMMIT_LEN
        );
    }
    let mut image = vec![0xFF; slot_stride * (SLOT_COUNT - 1) + SLOT_LEN];
    image[..blob.len()].copy_from_slice(blob);
    image[blob.len()..blob.len() + COMMIT_LEN].copy_from_slice(&commit_record(blob, counter));
    let active = select(&RegionView::new(&image, slot_stride))
        .map_err(|e| anyhow!("the region image does not boot: {e}"))?;
    if active.slot != 0 || active.counter != counter {
        bail!(
            "the region image boots slot {} instead of slot 0",
            active.slot
        );
    }
    Ok(image)
}

/// The PARAMS region image that QEMU's `-device loader,file=...,addr=0x70000` places so
/// that the device boots `blob` (from [`device_blob`], whose parameters give the identity
/// the device will greet with), counter [`REGION_IMAGE_COUNTER`].
pub fn qemu_region_image(blob: &[u8]) -> Result<Vec<u8>> {
    region_image(blob, REGION_IMAGE_COUNTER)
}

/// A region image seen as the device's two slots (read only).
pub struct RegionView<'a> {
    bytes: &'a [u8],
    slot_stride: usize,
}

impl<'a> RegionView<'a> {
    /// The slots of `bytes`, `slot_stride` bytes apart.
    pub fn new(bytes: &'a [u8], slot_stride: usize) -> Self {
        Self { bytes, slot_stride }
    }
}

impl ParamFlash for RegionView<'_> {
    fn slot(&self, slot: usize) -> &[u8] {
        let start = slot * self.slot_stride;
        self.bytes.get(start..start + SLOT_LEN).unwrap_or(&[])
    }
    fn erase(&mut self, _slot: usize) -> Result<(), supine_core::upload::FlashError> {
        Err(supine_core::upload::FlashError)
    }
    fn write(
        &mut self,
        _slot: usize,
        _offset: usize,
        _bytes: &[u8],
    ) -> Result<(), supine_core::upload::FlashError> {
        Err(supine_core::upload::FlashError)
    }
}

/// The Unix time in seconds as an update counter.
pub fn unix_seconds() -> Result<u32> {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_err(|_| anyhow!("the clock is before 1970: give --counter"))?
        .as_secs();
    u32::try_from(secs).map_err(|_| anyhow!("the Unix time no longer fits 32 bits: give --counter"))
}

/// Overrides where [`CounterState`] keeps the last counter (tests, several users).
pub const STATE_DIR_ENV: &str = "SUPINE_STATE_DIR";

/// The last update counter this host used, kept in a file so that the next one is above
/// it even within the same second.
///
/// The wire counter is a u32 (Unix seconds fit until 2106; milliseconds would not), and
/// the device reports no counter of its own, so the host remembers: the next counter is
/// max(Unix seconds, last + 1). Two flashes within one second then get t and t + 1
/// instead of colliding as a replay.
#[derive(Clone, Debug)]
pub struct CounterState {
    path: std::path::PathBuf,
}

impl CounterState {
    /// `$SUPINE_STATE_DIR/upload-counter`, else under `$XDG_STATE_HOME/supine` or
    /// `~/.local/state/supine`; `None` when none of those is set.
    pub fn default_location() -> Option<Self> {
        let env = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        let dir = env(STATE_DIR_ENV)
            .map(std::path::PathBuf::from)
            .or_else(|| env("XDG_STATE_HOME").map(|d| Path::new(&d).join("supine")))
            .or_else(|| env("HOME").map(|h| Path::new(&h).join(".local/state/supine")))?;
        Some(Self::at(dir.join("upload-counter")))
    }

    /// The state in the file `path`.
    pub fn at(path: impl Into<std::path::PathBuf>) -> Self {
        Self { path: path.into() }
    }

    /// The last counter recorded (0 if none yet).
    pub fn last(&self) -> Result<u32> {
        if let Err(e) = std::fs::metadata(&self.path)
            && e.kind() == std::io::ErrorKind::NotFound
        {
            return Ok(0);
        }
        // A counter is ten digits: a larger file is not this host's.
        let text = crate::io::small_file::read_text(&self.path, "counter file", 1024)?;
        text.trim().parse().map_err(|_| {
            anyhow!(
                "{}: expected the last update counter, found {}: delete the file or give --counter",
                self.path.display(),
                crate::io::excerpt::excerpt(text.trim())
            )
        })
    }

    /// Records `counter` as used if it is above the last one.
    pub fn record(&self, counter: u32) -> Result<()> {
        if counter <= self.last()? {
            return Ok(());
        }
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| anyhow!("{}: cannot create: {e}", dir.display()))?;
        }
        crate::io::output::write_atomically(&self.path, |w| Ok(writeln!(w, "{counter}")?))
    }

    /// The next counter, max(`now_s`, last + 1), recorded before it is returned.
    pub fn next(&self, now_s: u32) -> Result<u32> {
        let last = self.last()?;
        let next = now_s.max(last.checked_add(1).ok_or_else(|| {
            anyhow!(
                "{}: the last update counter is {last}, the largest there is: reprovision the device",
                self.path.display()
            )
        })?);
        self.record(next)?;
        Ok(next)
    }
}

/// The counter for an upload: `given` (recorded, so later defaults exceed it) or the next
/// one from [`CounterState`]; the Unix time alone (with a warning) when there is no place
/// to keep the state.
pub fn choose_counter(given: Option<u32>) -> Result<u32> {
    let state = CounterState::default_location();
    match (given, state) {
        (Some(counter), Some(state)) => {
            state.record(counter)?;
            Ok(counter)
        }
        (Some(counter), None) => Ok(counter),
        (None, Some(state)) => state.next(unix_seconds()?),
        (None, None) => {
            eprintln!(
                "supine flash: no HOME, XDG_STATE_HOME or {STATE_DIR_ENV} to remember the last \
                 counter: using the Unix time (two updates within a second collide)"
            );
            unix_seconds()
        }
    }
}

/// What an upload over a link achieved.
#[derive(Clone, Debug, PartialEq)]
pub struct UploadOutcome {
    /// The device's acknowledgement of the commit.
    pub uploaded: Uploaded,
    /// The greeting the device sent afterwards, naming the parameters it now runs.
    pub greeting: Greeting,
}

/// Uploads `blob` (whose identity is `params.identity`) over a running device's link,
/// signed with `key` under `counter`, then reads the greeting the device sends after the
/// commit and checks that it names the new identity. Each step waits at most `timeout`.
pub fn upload_over_link<R: Read, W: Write>(
    reader: &mut FrameReader<R>,
    writer: &mut FrameWriter<W>,
    params: &DeviceParams,
    blob: &[u8],
    key: &[u8; KEY_LEN],
    counter: u32,
    timeout: Duration,
) -> Result<UploadOutcome> {
    let uploaded =
        upload_client::upload(reader, writer, blob, params.identity, key, counter, timeout)?;
    // The device greets after a commit, naming what it now runs.
    let greeting = reader.greeting(timeout)?;
    if greeting.params_identity != params.identity {
        bail!(
            "the device acknowledged {} but greets with {}",
            identity_hex(&params.identity),
            identity_hex(&greeting.params_identity)
        );
    }
    let p = params.patient;
    if (greeting.height_m, greeting.mass_kg) != (p.height_m, p.mass_kg) {
        bail!(
            "the device acknowledged parameters for a {} m, {} kg patient but greets with {} m, {} kg",
            p.height_m,
            p.mass_kg,
            greeting.height_m,
            greeting.mass_kg
        );
    }
    Ok(UploadOutcome { uploaded, greeting })
}

/// The key in `path`, or the public development key built into the tool when `path` is
/// `None` (the caller says so: [`crate::device::image::DEVELOPMENT_KEY_NOTICE`]).
pub fn load_key(path: Option<&Path>) -> Result<[u8; KEY_LEN]> {
    match path {
        Some(p) => upload_client::read_key(p),
        None => crate::device::image::development_key(),
    }
}

/// Opens `port` at `baud`, waits for the device's greeting (asking with `Hello`), then
/// [`upload_over_link`].
pub fn upload_serial(
    port: &str,
    baud: u32,
    params: &DeviceParams,
    blob: &[u8],
    key: &[u8; KEY_LEN],
    counter: u32,
    timeout: Duration,
) -> Result<UploadOutcome> {
    let serial = serialport::new(port, baud)
        .timeout(Duration::from_millis(50))
        .open()
        .map_err(|e| anyhow!("{port}: cannot open the serial port: {e}"))?;
    let tx = serial
        .try_clone()
        .map_err(|e| anyhow!("{port}: cannot use the serial port: {e}"))?;
    let mut reader = FrameReader::new(serial);
    let mut writer = FrameWriter::new(tx);
    writer.send(&HostToDevice::Hello)?;
    writer.flush()?;
    reader
        .greeting(timeout)
        .map_err(|e| anyhow!("{port}: {e}"))?;
    upload_over_link(
        &mut reader,
        &mut writer,
        params,
        blob,
        key,
        counter,
        timeout,
    )
    .map_err(|e| anyhow!("{port}: {e}"))
}

/// Starts `kernel` in QEMU (built-in parameters), uploads `blob` over its UART and checks
/// the greeting that follows: the upload path end to end, without hardware.
pub fn upload_qemu(
    kernel: &crate::device::image::ProductImage,
    params: &DeviceParams,
    blob: &[u8],
    key: &[u8; KEY_LEN],
    counter: u32,
    timeout: Duration,
) -> Result<UploadOutcome> {
    let config = QemuConfig::new(kernel.path())
        .uart()
        .timeout(timeout + Duration::from_secs(30));
    let mut qemu = Qemu::start(&config)?;
    // Nothing here polls a stop flag: a signal kills QEMU, which ends the blocked read,
    // and the guard removes the socket folder. Declared after `qemu`, so dropped first.
    let _kill_on_signal = crate::device::signals::KillOnSignal::new(qemu.id());
    let uart = qemu.uart().ok_or_else(|| anyhow!("QEMU has no UART"))?;
    uart.set_read_timeout(Some(Duration::from_millis(50)))?;
    let mut reader = FrameReader::new(uart.try_clone()?);
    let mut writer = FrameWriter::new(uart.try_clone()?);
    let result = reader.greeting(timeout).and_then(|_| {
        upload_over_link(
            &mut reader,
            &mut writer,
            params,
            blob,
            key,
            counter,
            timeout,
        )
    });
    if crate::device::signals::stop_requested() {
        bail!("interrupted: QEMU stopped and its folder removed");
    }
    result
}

/// Programs a region image into a board's flash at `base_address` with probe-rs.
pub fn probe_download(chip: &str, base_address: u32, image: &[u8]) -> Result<()> {
    let dir = crate::device::scratch::ScratchDir::new("flash")?;
    let path = dir.path().join("params-region.bin");
    std::fs::write(&path, image)?;
    let output = std::process::Command::new(PROBE_RS)
        .args(["download", "--chip", chip, "--binary-format", "bin", "--base-address"])
        .arg(format!("{base_address:#010x}"))
        .arg(&path)
        .output()
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => anyhow!(
                "probe-rs is not installed: install it with `cargo install probe-rs-tools --locked` \
                 (or see https://probe.rs/docs/getting-started/installation/)"
            ),
            _ => anyhow!("cannot run probe-rs: {e}"),
        })?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let last = stderr
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no message");
        bail!(
            "probe-rs download failed ({}): {}",
            output.status,
            last.trim()
        );
    }
    Ok(())
}

/// The probe-rs program.
const PROBE_RS: &str = "probe-rs";

#[cfg(test)]
mod tests {
    use super::*;
    use supine_core::model::Preset;

    #[test]
    fn a_region_image_boots_slot_a_with_its_counter_and_blob() {
        let file = ParamFile::preset(Preset::PaperLitter);
        let (params, blob) = device_blob(&file, 500.0).unwrap();
        let image = qemu_region_image(&blob).unwrap();
        assert_eq!(image.len(), 64 * 1024);
        assert_eq!(&image[..blob.len()], &blob[..]);
        assert_eq!(&image[blob.len()..blob.len() + 4], b"CMIT");
        assert!(image[blob.len() + COMMIT_LEN..].iter().all(|&b| b == 0xFF));
        let active = select(&RegionView::new(&image, SLOT_LEN)).unwrap();
        assert_eq!((active.slot, active.counter), (0, REGION_IMAGE_COUNTER));
        assert_eq!(active.params, params);
        assert_eq!(active.params.sample_rate_hz(), 500.0);
    }

    #[test]
    fn the_board_image_spans_both_sectors_with_slot_b_erased() {
        let (_, blob) = device_blob(&ParamFile::preset(Preset::PaperLitter), 400.0).unwrap();
        let image = region_image_with_stride(&blob, 77, BLACKPILL_SLOT_STRIDE).unwrap();
        assert_eq!(image.len(), 128 * 1024 + SLOT_LEN);
        assert!(image[BLACKPILL_SLOT_STRIDE..].iter().all(|&b| b == 0xFF));
        let active = select(&RegionView::new(&image, BLACKPILL_SLOT_STRIDE)).unwrap();
        assert_eq!((active.slot, active.counter), (0, 77));
    }

    #[test]
    fn counters_within_one_second_still_increase_and_survive_a_restart() {
        let dir = tempfile::tempdir().unwrap();
        let state = CounterState::at(dir.path().join("state/upload-counter"));
        assert_eq!(state.last().unwrap(), 0);
        let now_s = 1_800_000_000;
        assert_eq!(state.next(now_s).unwrap(), now_s);
        assert_eq!(state.next(now_s).unwrap(), now_s + 1);
        // Another process (a new CounterState on the same file) continues from there.
        let again = CounterState::at(dir.path().join("state/upload-counter"));
        assert_eq!(again.next(now_s).unwrap(), now_s + 2);
        // The clock moving on takes over again; a given counter above it is remembered.
        assert_eq!(again.next(now_s + 10).unwrap(), now_s + 10);
        again.record(now_s + 100).unwrap();
        again.record(5).unwrap();
        assert_eq!(again.next(now_s + 11).unwrap(), now_s + 101);
        // A damaged state file is named, with what to do.
        std::fs::write(dir.path().join("state/upload-counter"), "soon\n").unwrap();
        let err = again.next(now_s).unwrap_err().to_string();
        assert!(
            err.contains("upload-counter: expected the last update counter"),
            "{err}"
        );
        assert!(err.contains("delete the file or give --counter"), "{err}");
        std::fs::write(
            dir.path().join("state/upload-counter"),
            format!("{}", u32::MAX),
        )
        .unwrap();
        assert!(again.next(now_s).is_err());
    }

    #[test]
    fn a_bad_rate_is_refused_with_the_option_named() {
        let file = ParamFile::preset(Preset::PaperLitter);
        let err = device_blob(&file, 0.0).unwrap_err().to_string();
        assert!(err.contains("--fs"), "{err}");
        assert!(device_blob(&file, f64::NAN).is_err());
    }
}
