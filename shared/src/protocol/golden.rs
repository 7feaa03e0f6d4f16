//! Golden bytes: one example of every message and of a blob, with the exact bytes their
//! encoding must produce. Host tests and the firmware's self-test both check them, so an
//! encoding cannot change on either side without failing (and a version bump).

use heapless::{String, Vec};

use super::{
    DeviceFrame, DeviceToHost, Greeting, HostToDevice, InputBatch, PROTOCOL_VERSION, ParamAck,
    ParamBegin, ParamChunk, ParamsSource, ResetCause, SampleBatch, Status, Telemetry, UploadError,
};
use crate::alerts::{AlertEvent, Criterion, JointAlertConfig, JointCriterion, Level, SensorFault};
use crate::blob::{BlobError, DeviceParams, Patient};
use crate::calibration::{CalibrationDate, CalibrationMethod, SensorCalibration};
use crate::joint_exposure::JointValues;
use crate::model::{DiscreteModal, JointReadout, ModalBlock, ModalGroup};
use crate::sample_rate::SampleRate;

/// Example host-to-device messages, in [`HOST_TO_DEVICE`] order.
pub fn host_to_device_examples() -> [HostToDevice; 7] {
    let mut samples = Vec::new();
    let _ = samples.push([0.5, -0.25, 1.0]);
    let _ = samples.push([0.0, 0.125, -2.0]);
    let mut bytes = Vec::new();
    let _ = bytes.extend_from_slice(&[1, 2, 3, 4]);
    [
        HostToDevice::Hello,
        HostToDevice::Samples(SampleBatch {
            first_sample_index: 1000,
            accel_m_s2: samples,
        }),
        HostToDevice::GetStatus,
        HostToDevice::ParamBegin(ParamBegin {
            length_bytes: 1234,
            counter: 7,
            hmac_sha256: [0xAB; 32],
        }),
        HostToDevice::ParamChunk(ParamChunk {
            offset_bytes: 128,
            bytes,
        }),
        HostToDevice::ParamCommit,
        HostToDevice::StreamInput { enabled: true },
    ]
}

/// Example device-to-host frames, in [`DEVICE_TO_HOST`] order.
pub fn device_to_host_examples() -> [DeviceFrame; 15] {
    let mut firmware_version = String::new();
    let _ = firmware_version.push_str("0.1.0");
    let mut last_panic = String::new();
    let _ = last_panic.push_str("oops");
    let messages = [
        DeviceToHost::Greeting(Greeting {
            protocol_version: PROTOCOL_VERSION,
            firmware_version,
            params_identity: [0x11; 16],
            params_source: ParamsSource::BuiltInDefault {
                reason: BlobError::BadCrc,
            },
            sample_rate_hz: 500.0,
            height_m: 1.75,
            mass_kg: 70.5,
            reset_cause: ResetCause::Panic,
            last_panic,
            joint_outputs: 0b11_1111_1111,
            calibration: calibration_example(),
        }),
        DeviceToHost::Telemetry(Telemetry {
            sample_index: 123_456,
            head_acc_m_s2: [0.5, -1.0, 2.0],
            running_rms_m_s2: [0.25, 0.125, 1.5],
            vector_running_rms_m_s2: 1.75,
            vdv_m_s175: 3.5,
            alert_level: Level::Warning,
            fault_flags: SensorFault::NonFinite | SensorFault::Stuck,
            valid: true,
            joints: JointValues::from_slice(&[0.001, -0.0025, 0.0625]).unwrap_or_default(),
        }),
        DeviceToHost::Alert(AlertEvent::Level {
            from: Level::Normal,
            to: Level::Advisory,
            criterion: Criterion::RunningRms { value_m_s2: 0.5 },
            at_sample: 700,
        }),
        DeviceToHost::Alert(AlertEvent::Level {
            from: Level::Warning,
            to: Level::Alarm,
            criterion: Criterion::Vdv { value_m_s175: 21.0 },
            at_sample: 70_000,
        }),
        DeviceToHost::Alert(AlertEvent::Fault {
            fault: SensorFault::Stuck,
            active: true,
            at_sample: 9,
        }),
        DeviceToHost::Status(Status {
            frames_received: 10,
            bad_frames: 2,
            samples_processed: 80,
            samples_dropped: 1,
            telemetry_sent: 80,
            uploads_rejected: 0,
            busy_ticks: 1_000_000,
            stack_used_bytes: 2048,
            params_source: ParamsSource::Flash { slot: 1 },
            height_m: 1.5,
            mass_kg: 52.25,
            joint_running_rms: JointValues::from_slice(&[0.5]).unwrap_or_default(),
            joint_largest_excursion: JointValues::from_slice(&[-0.75]).unwrap_or_default(),
            calibration: calibration_example(),
        }),
        DeviceToHost::ParamAck(ParamAck::Committed {
            identity: [0x22; 16],
            slot: 1,
        }),
        DeviceToHost::ParamNack(UploadError::Blob(BlobError::Unstable)),
        DeviceToHost::ParamAck(ParamAck::Begun),
        DeviceToHost::ParamAck(ParamAck::Received { bytes: 300 }),
        DeviceToHost::ParamNack(UploadError::Replayed),
        DeviceToHost::ParamNack(UploadError::LengthMismatch),
        // Differences of one, two and three zigzag-varint bytes, and ones that wrap.
        DeviceToHost::Input(InputBatch::from_counts(
            1000,
            &[[1, -1, 64], [-3, 2, -8192], [32767, -32767, 0]],
        )),
        DeviceToHost::Alert(AlertEvent::Joint {
            output: 3,
            criterion: JointCriterion::RunningRms {
                value_m_or_rad: 0.015625,
            },
            raised: true,
            at_sample: 1500,
        }),
        DeviceToHost::Alert(AlertEvent::Joint {
            output: 7,
            criterion: JointCriterion::Excursion {
                value_m_or_rad: 0.0078125,
            },
            raised: true,
            at_sample: 2505,
        }),
    ];
    let mut seq = 0;
    messages.map(|message| {
        seq += 1;
        DeviceFrame {
            seq: seq - 1,
            message,
        }
    })
}

#[rustfmt::skip]
/// COBS frames of [`host_to_device_examples`].
pub const HOST_TO_DEVICE: [&[u8]; 7] = [
    &[0x01, 0x01, 0x00],
    &[0x05, 0x01, 0xe8, 0x07, 0x02, 0x01, 0x01, 0x02, 0x3f, 0x01, 0x03, 0x80, 0xbe, 0x01, 0x03, 0x80, 0x3f, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x02, 0x3e, 0x01, 0x01, 0x02, 0xc0, 0x00],
    &[0x02, 0x02, 0x00],
    &[0x25, 0x03, 0xd2, 0x09, 0x07, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0xab, 0x00],
    &[0x09, 0x04, 0x80, 0x01, 0x04, 0x01, 0x02, 0x03, 0x04, 0x00],
    &[0x02, 0x05, 0x00],
    &[0x03, 0x06, 0x01, 0x00],
];

#[rustfmt::skip]
/// COBS frames of [`device_to_host_examples`].
pub const DEVICE_TO_HOST: [&[u8]; 15] = [
    &[0x01, 0x01, 0x1a, 0x07, 0x05, 0x30, 0x2e, 0x31, 0x2e, 0x30, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x01, 0x05, 0x01, 0x03, 0xfa, 0x43, 0x01, 0x03, 0xe0, 0x3f, 0x01, 0x0c, 0x8d, 0x42, 0x01, 0x04, 0x6f, 0x6f, 0x70, 0x73, 0xff, 0x07, 0x2e, 0x01, 0x03, 0x84, 0x3f, 0x01, 0x03, 0x78, 0x3f, 0x01, 0x03, 0x80, 0x3f, 0x01, 0x03, 0x80, 0x3e, 0x01, 0x01, 0x02, 0xbe, 0x01, 0x10, 0x80, 0x3d, 0xea, 0x07, 0x03, 0x0e, 0x02, 0x0c, 0x41, 0x2e, 0x20, 0x54, 0x65, 0x63, 0x68, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x00],
    &[0x06, 0x01, 0x01, 0xc0, 0xc4, 0x07, 0x01, 0x01, 0x02, 0x3f, 0x01, 0x03, 0x80, 0xbf, 0x01, 0x01, 0x02, 0x40, 0x01, 0x03, 0x80, 0x3e, 0x01, 0x01, 0x02, 0x3e, 0x01, 0x03, 0xc0, 0x3f, 0x01, 0x03, 0xe0, 0x3f, 0x01, 0x0f, 0x60, 0x40, 0x02, 0x05, 0x01, 0x03, 0x6f, 0x12, 0x83, 0x3a, 0x0a, 0xd7, 0x23, 0xbb, 0x01, 0x03, 0x80, 0x3d, 0x00],
    &[0x03, 0x02, 0x02, 0x01, 0x02, 0x01, 0x01, 0x01, 0x01, 0x04, 0x3f, 0xbc, 0x05, 0x00],
    &[0x03, 0x03, 0x02, 0x04, 0x02, 0x03, 0x01, 0x01, 0x06, 0xa8, 0x41, 0xf0, 0xa2, 0x04, 0x00],
    &[0x07, 0x04, 0x02, 0x01, 0x02, 0x01, 0x09, 0x00],
    &[0x08, 0x05, 0x03, 0x0a, 0x02, 0x50, 0x01, 0x50, 0x06, 0xc0, 0x84, 0x3d, 0x80, 0x10, 0x02, 0x01, 0x01, 0x03, 0xc0, 0x3f, 0x01, 0x04, 0x51, 0x42, 0x01, 0x01, 0x01, 0x03, 0x3f, 0x01, 0x01, 0x04, 0x40, 0xbf, 0x2e, 0x01, 0x03, 0x84, 0x3f, 0x01, 0x03, 0x78, 0x3f, 0x01, 0x03, 0x80, 0x3f, 0x01, 0x03, 0x80, 0x3e, 0x01, 0x01, 0x02, 0xbe, 0x01, 0x10, 0x80, 0x3d, 0xea, 0x07, 0x03, 0x0e, 0x02, 0x0c, 0x41, 0x2e, 0x20, 0x54, 0x65, 0x63, 0x68, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01, 0x00],
    &[0x15, 0x06, 0x04, 0x02, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x22, 0x01, 0x00],
    &[0x05, 0x07, 0x05, 0x06, 0x08, 0x00],
    &[0x03, 0x08, 0x04, 0x01, 0x00],
    &[0x06, 0x09, 0x04, 0x01, 0xac, 0x02, 0x00],
    &[0x04, 0x0a, 0x05, 0x04, 0x00],
    &[0x04, 0x0b, 0x05, 0x08, 0x00],
    &[0x18, 0x0c, 0x06, 0xe8, 0x07, 0x12, 0x02, 0x01, 0x80, 0x01, 0x07, 0x06, 0xff, 0x80, 0x01, 0xfb, 0xff, 0x03, 0xfe, 0xff, 0x03, 0x80, 0x80, 0x01, 0x00],
    &[0x05, 0x0d, 0x02, 0x02, 0x03, 0x01, 0x01, 0x06, 0x80, 0x3c, 0x01, 0xdc, 0x0b, 0x00],
    &[0x06, 0x0e, 0x02, 0x02, 0x07, 0x01, 0x01, 0x01, 0x05, 0x3c, 0x01, 0xc9, 0x13, 0x00],
];

/// A tumble-test calibration record with numbers exact in f32 (greeting, status, blob).
pub fn calibration_example() -> SensorCalibration {
    SensorCalibration {
        sensitivity: [1.03125, 0.96875, 1.0],
        offset_m_s2: [0.25, -0.125, 0.0625],
        date: CalibrationDate {
            year: 2026,
            month: 3,
            day: 14,
        },
        method: CalibrationMethod::Tumble,
        by: *b"A. Tech\0\0\0\0\0\0\0\0\0",
        interval_months: 12,
    }
}

/// A blob built from fixed numbers only (no eigen-solver in the loop), so its bytes
/// depend on nothing but the encoding and the documented filter designs.
pub fn blob_example() -> Result<DeviceParams, BlobError> {
    // One z-driven block feeding head x and head z (rows packed in that order).
    let block = ModalBlock {
        transition_minus_identity: [[-0.01, -0.05], [0.05, -0.01]],
        output: [[0.5, 0.25], [1.0, -0.5], [0.0, 0.0]],
    };
    let mut blocks = [ModalBlock {
        transition_minus_identity: [[0.0; 2]; 2],
        output: [[0.0; 2]; 3],
    }; crate::model::discrete::MAX_BLOCKS];
    blocks[0] = block;
    let empty = ModalGroup {
        block_count: 0,
        output_count: 0,
        outputs: [0; 3],
        feedthrough: [0.0; 3],
    };
    let z_group = ModalGroup {
        block_count: 1,
        output_count: 2,
        outputs: [0, 2, 0],
        feedthrough: [0.002, 0.003, 0.0],
    };
    let realization = DiscreteModal {
        groups: [empty, empty, z_group],
        blocks,
        block_count: 1,
    };
    let sample_rate = SampleRate::new(500.0).map_err(|_| BlobError::SampleRate)?;
    let patient = Patient {
        height_m: 1.6,
        mass_kg: 52.0,
    };
    // One joint output, neck_z (driven by z), read from the one block.
    let mut joints = JointReadout::NONE;
    joints.groups[2].row_count = 1;
    joints.groups[2].outputs[0] = 2;
    joints.groups[2].feedthrough[0] = 0.001;
    joints.rows[0][0] = [0.25, -0.125];
    // Its joint-motion alerts: a running-rms and an excursion threshold, m; no dwell, so
    // that a test may change the telemetry rate (the dwell is counted in readings, at
    // least one) and the blob stay valid.
    let joint_alerts = JointAlertConfig {
        running_rms_m_or_rad: [0.001, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        excursion_m_or_rad: [0.004, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        hysteresis: 0.25,
        raise_dwell_s: 0.0,
        clear_dwell_s: 0.0,
    };
    DeviceParams::with_defaults([0x5A; 16], patient, sample_rate, realization, joints)?
        .with_joint_alerts(joint_alerts)?
        .with_calibration(calibration_example())
}

/// The bytes of [`blob_example`]: header and payload (recorded with `cargo test -p supine-core
/// --test core golden_bytes::`, which writes the file when `SUPINE_RECORD_GOLDEN=1`).
pub const BLOB: &[u8] = include_bytes!("../../fixtures/golden_blob.bin");
