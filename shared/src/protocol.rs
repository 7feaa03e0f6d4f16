//! The wire protocol between the device and the host: postcard messages in COBS frames
//! (each frame ends with a zero byte).
//!
//! Types are named by direction. The device speaks first ([`Greeting`]) and numbers every
//! frame it sends ([`DeviceFrame::seq`]) so the host can count lost frames. Units are in
//! field names. Changing any encoding requires bumping [`PROTOCOL_VERSION`]; the
//! golden-bytes table in [`golden`] fails otherwise.

pub mod framing;
pub mod golden;
pub mod input_frame;
pub mod telemetry_frame;

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

use crate::alerts::AlertEvent;
use crate::blob::BlobError;
use crate::calibration::SensorCalibration;
use crate::joint_exposure::JointValues;

pub use framing::{FrameAccumulator, FrameError, FrameEvent, encode_frame};
// What the messages carry, defined where it is made: the identity with the blob, the
// telemetry record with the pipeline.
pub use crate::blob::{IDENTITY_LEN, ParamsIdentity};
pub use crate::pipeline::Telemetry;

/// Version of this module's encodings; the host refuses a device that speaks another.
pub const PROTOCOL_VERSION: u16 = 7;
/// Largest encoded frame, including COBS overhead and the terminating zero, bytes.
pub const MAX_FRAME_LEN: usize = 256;
/// Samples carried by one [`HostToDevice::Samples`] frame at most.
pub const MAX_SAMPLES_PER_FRAME: usize = 8;
/// Samples carried by one [`DeviceToHost::Input`] frame at most: one pipeline block.
pub const MAX_INPUT_SAMPLES_PER_FRAME: usize = crate::pipeline::BLOCK_LEN;
/// Parameter-blob bytes carried by one upload chunk at most.
pub const PARAM_CHUNK_LEN: usize = 128;
/// Longest firmware version string, bytes.
pub const VERSION_LEN: usize = 24;
/// Longest panic message kept for the next greeting, bytes.
pub const PANIC_MESSAGE_LEN: usize = 96;

/// Messages from the host to the device.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostToDevice {
    /// Ask the device to greet again (it also greets unasked when it starts).
    Hello,
    /// Support acceleration samples for replay, in litter axes with gravity removed.
    Samples(SampleBatch),
    /// Ask for the status counters.
    GetStatus,
    /// Start a parameter upload.
    ParamBegin(ParamBegin),
    /// A piece of the parameter blob being uploaded.
    ParamChunk(ParamChunk),
    /// Verify the uploaded blob and switch to it.
    ParamCommit,
    /// Start or stop streaming the model's input ([`DeviceToHost::Input`]); off at boot
    /// and after a parameter switch.
    StreamInput {
        /// Whether to stream.
        enabled: bool,
    },
}

/// Consecutive samples starting at one sample index.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleBatch {
    /// Index of the first sample in the batch; the next ones follow without gaps.
    pub first_sample_index: u32,
    /// Litter-frame acceleration x, y, z per sample, m/s^2.
    pub accel_m_s2: Vec<[f32; 3], MAX_SAMPLES_PER_FRAME>,
}

/// Opens an authenticated upload of a parameter blob.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamBegin {
    /// Length of the whole blob, bytes.
    pub length_bytes: u32,
    /// Monotonic update counter; the device refuses one not above its last accepted.
    pub counter: u32,
    /// HMAC-SHA256 over the counter (little-endian) and the blob, with the device's key.
    pub hmac_sha256: [u8; 32],
}

/// A piece of the blob at a byte offset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamChunk {
    /// Offset of the first byte in the blob.
    pub offset_bytes: u32,
    /// The bytes.
    pub bytes: Vec<u8, PARAM_CHUNK_LEN>,
}

/// A numbered frame from the device.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeviceFrame {
    /// Increases by one with every frame the device sends, from 0 at start.
    pub seq: u32,
    /// The message.
    pub message: DeviceToHost,
}

/// Messages from the device to the host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeviceToHost {
    /// Who the device is and what it runs; sent first.
    Greeting(Greeting),
    /// The prediction and exposure at one sample (every `decimation`-th sample).
    Telemetry(Telemetry),
    /// An alert was raised or cleared; sent at once.
    Alert(AlertEvent),
    /// Counters, on request and periodically.
    Status(Status),
    /// A parameter upload step was accepted.
    ParamAck(ParamAck),
    /// A parameter upload was refused; nothing changed.
    ParamNack(UploadError),
    /// The input the model got for consecutive samples, while [`HostToDevice::StreamInput`]
    /// has it on; sent after the samples' telemetry and alerts.
    Input(InputBatch),
}

/// The model's input for consecutive samples, in input-resolution counts
/// (`crate::input_resolution`), packed ([`input_frame`]: per axis the zigzag-varint
/// difference from the sample before, the first from zero) so that most samples take a
/// few bytes and every frame decodes on its own ([`InputBatch::samples`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputBatch {
    /// Index of the first sample; the next ones follow without gaps.
    pub first_sample_index: u32,
    /// The samples, packed ([`input_frame::pack`]).
    #[serde(serialize_with = "input_frame::serialize_packed")]
    pub packed: Vec<u8, { input_frame::MAX_PACKED_LEN }>,
}

/// The device introduces itself.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Greeting {
    /// [`PROTOCOL_VERSION`] of the firmware.
    pub protocol_version: u16,
    /// Firmware version and build, e.g. `0.1.0+qemu`.
    pub firmware_version: String<VERSION_LEN>,
    /// Identity of the parameters in use.
    pub params_identity: ParamsIdentity,
    /// Where those parameters came from.
    pub params_source: ParamsSource,
    /// Sample rate the parameters were built for, Hz.
    pub sample_rate_hz: f32,
    /// Height of the patient the parameters were scaled to, m.
    pub height_m: f32,
    /// Mass of the patient the parameters were scaled to, kg.
    pub mass_kg: f32,
    /// How the device last stopped.
    pub reset_cause: ResetCause,
    /// The last panic's message, if the last stop was a panic.
    pub last_panic: String<PANIC_MESSAGE_LEN>,
    /// The joint outputs the parameters read (bit `i` for
    /// [`JointOutput::ALL`](crate::model::JointOutput::ALL)`[i]`): the ones, in that
    /// order, that [`Telemetry::joints`] and the status's joint lists hold.
    pub joint_outputs: u16,
    /// The sensor's calibration record in the running parameters.
    pub calibration: SensorCalibration,
}

/// Where the running parameters came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ParamsSource {
    /// A valid blob in flash slot A or B (0 or 1).
    Flash {
        /// The slot.
        slot: u8,
    },
    /// The built-in paper litter-board preset, because flash held no valid blob.
    BuiltInDefault {
        /// Why the flash blob was refused.
        reason: BlobError,
    },
}

impl Default for ParamsSource {
    /// Nothing loaded yet: what a blank flash gives.
    fn default() -> Self {
        ParamsSource::BuiltInDefault {
            reason: BlobError::Empty,
        }
    }
}

/// How the device last stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ResetCause {
    /// Power applied (or no record).
    PowerOn,
    /// A panic; the message is in the greeting.
    Panic,
    /// The watchdog fired.
    Watchdog,
    /// Requested, e.g. after switching parameters.
    Software,
}

/// The device's counters, and the patient it predicts for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// Valid frames received.
    pub frames_received: u32,
    /// Frames dropped because COBS, postcard or a length check failed.
    pub bad_frames: u32,
    /// Samples run through the pipeline.
    pub samples_processed: u32,
    /// Samples lost: indices skipped by a jump forward of at most a minute of samples (a
    /// longer jump, or one back, is a new stream and counts nothing), or samples that
    /// arrived when the device was busy.
    pub samples_dropped: u32,
    /// Telemetry frames sent.
    pub telemetry_sent: u32,
    /// Parameter uploads refused.
    pub uploads_rejected: u32,
    /// Ticks of the board's SysTick (its core clock: 25 MHz on mps2-an386, 64 MHz on the
    /// Black Pill) spent in the pipeline (model, exposure, alerts, frame encoding), not
    /// waiting on the UART. Under QEMU `-icount shift=0` on mps2 one tick is 40
    /// instructions; on the Black Pill one tick is a CPU cycle.
    pub busy_ticks: u64,
    /// Deepest stack use since boot (painted stack), bytes.
    pub stack_used_bytes: u32,
    /// Where the running parameters came from now (after uploads too), and, for the
    /// built-in default, why the flash blob was refused.
    pub params_source: ParamsSource,
    /// Height of the patient the running parameters were scaled to, m.
    pub height_m: f32,
    /// Mass of the patient the running parameters were scaled to, kg.
    pub mass_kg: f32,
    /// Running rms (tau as the head's, 1 s by default) of each joint output the
    /// parameters read, m or rad, in [`Greeting::joint_outputs`] order.
    pub joint_running_rms: JointValues,
    /// Largest absolute value of each joint output read since the pipeline's warm-up
    /// ended (0 before), m or rad, in the same order.
    pub joint_largest_excursion: JointValues,
    /// The sensor's calibration record in the running parameters (after uploads too).
    pub calibration: SensorCalibration,
}

/// A step of a parameter upload that the device accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ParamAck {
    /// Ready for chunks.
    Begun,
    /// Bytes received so far.
    Received {
        /// Contiguous bytes from offset 0, bytes.
        bytes: u32,
    },
    /// Verified, stored and now running.
    Committed {
        /// The new parameters' identity.
        identity: ParamsIdentity,
        /// The flash slot it went to.
        slot: u8,
    },
}

/// Why an upload was refused: one variant per cause, so that the code a host shows names
/// the cause itself (see the error table in `docs/protocol.md`). New variants go last:
/// the codes of the others are stable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum UploadError {
    /// A chunk or commit arrived without an open upload.
    NotStarted,
    /// The length announced by `ParamBegin` is zero or larger than a blob can be.
    BadLength,
    /// A chunk did not continue where the last one ended.
    OutOfOrder,
    /// Commit before all bytes arrived.
    Incomplete,
    /// The counter is not above the last accepted one (a replayed update).
    Replayed,
    /// The HMAC does not match: not from a holder of the device key, or altered.
    BadSignature,
    /// The blob itself is invalid.
    Blob(BlobError),
    /// Erasing, writing or reading back flash failed; the slot written is left
    /// unbootable, so what boots next is what ran before.
    Flash,
    /// The length announced by `ParamBegin` differs from the length in the blob's own
    /// header (for example a valid blob followed by padding).
    LengthMismatch,
    /// A chunk would pass the length announced by `ParamBegin`.
    ChunkPastEnd,
    /// This device image takes no parameter updates over the link.
    UpdatesUnsupported,
}

impl UploadError {
    /// A stable numeric code for logs and the host's messages.
    pub const fn code(self) -> u8 {
        match self {
            UploadError::NotStarted => 1,
            UploadError::BadLength => 2,
            UploadError::OutOfOrder => 3,
            UploadError::Incomplete => 4,
            UploadError::Replayed => 5,
            UploadError::BadSignature => 6,
            UploadError::Flash => 7,
            UploadError::LengthMismatch => 8,
            UploadError::ChunkPastEnd => 9,
            UploadError::UpdatesUnsupported => 10,
            UploadError::Blob(e) => 0x40 | e.code(),
        }
    }
}

impl core::fmt::Display for UploadError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            UploadError::NotStarted => f.write_str("upload not started"),
            UploadError::BadLength => f.write_str("announced length is zero or too large"),
            UploadError::LengthMismatch => {
                f.write_str("announced length differs from the blob header's")
            }
            UploadError::ChunkPastEnd => f.write_str("chunk passes the announced length"),
            UploadError::OutOfOrder => f.write_str("chunk out of order"),
            UploadError::Incomplete => f.write_str("commit before all bytes arrived"),
            UploadError::Replayed => f.write_str("update counter not above the last accepted one"),
            UploadError::BadSignature => f.write_str("HMAC does not match"),
            UploadError::Blob(e) => write!(f, "invalid blob: {e}"),
            UploadError::Flash => f.write_str("flash erase, write or read-back failed"),
            UploadError::UpdatesUnsupported => {
                f.write_str("this device takes no updates over the link")
            }
        }?;
        write!(f, " (code {})", self.code())
    }
}
