//! Where the monitor's samples come from: one trait, two sources.
//!
//! [`SampleSource`] yields samples as the pipeline wants them: an index and the
//! litter-frame support acceleration with gravity removed, m/s^2. Two implementations:
//! - [`Lis3dhSource`]: the real litter-frame accelerometer, an ST LIS3DH on I2C through
//!   the `lis3dh` driver crate (embedded-hal 1.0). Generic over `embedded_hal::i2c::I2c`,
//!   so it runs on any board's HAL and is tested here with embedded-hal-mock transactions.
//! - [`ReplaySource`]: samples the host streams over the UART as protocol frames (what
//!   runs in QEMU), each batch with the index of its first sample, already in litter axes
//!   with gravity removed (a recording's platform columns).
//!
//! Gravity, consistently with the model: the accelerometer measures specific force
//! (at rest +g along the litter's up axis); the model's input is the kinematic
//! acceleration, so a reading f (sensor axes) is first corrected for the sensor's
//! calibrated sensitivity and offset, then becomes a = R f - (0, 0, g) with the mounting
//! calibration's rotation R and its measured g (`SensorFrame::to_litter_m_s2`, the host's
//! reference of a recording makes the same calls). Raw counts stay raw until this edge
//! ([`AccelCounts`]).
#![cfg_attr(not(test), no_std)]

use core::convert::Infallible;

use embedded_hal::i2c::I2c;
use heapless::Deque;
use lis3dh::accelerometer::RawAccelerometer;
use lis3dh::{Configuration, DataRate, Lis3dh, Lis3dhI2C, Mode, Range, SlaveAddr};
use supine_core::calibration::SensorFrame;
use supine_core::mounting::STANDARD_GRAVITY_M_S2;

/// A source of samples for the pipeline.
pub trait SampleSource {
    /// Why a sample could not be read.
    type Error;
    /// The next sample (index, litter-frame acceleration with gravity removed, m/s^2), or
    /// `None` if none is ready yet.
    fn poll(&mut self) -> Result<Option<(u32, [f32; 3])>, Self::Error>;
}

/// Raw LIS3DH output: 16-bit left-justified counts per axis (sensor axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccelCounts(pub [i16; 3]);

impl AccelCounts {
    /// m/s^2 per count of the left-justified 16-bit value in high-resolution mode at
    /// +-4 g: 2 mg per 12-bit digit (datasheet table 4), a digit being 16 counts.
    pub const M_S2_PER_LSB: f32 = (0.002 * STANDARD_GRAVITY_M_S2 / 16.0) as f32;

    /// The reading in m/s^2, sensor axes.
    pub fn to_m_s2(self) -> [f32; 3] {
        self.0.map(|c| f32::from(c) * Self::M_S2_PER_LSB)
    }
}

/// The sensor's output data rate, Hz: the parameter blob must be built for this rate.
pub const LIS3DH_RATE_HZ: f32 = 400.0;

/// Why the accelerometer failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorError<E> {
    /// The I2C bus failed.
    Bus(E),
    /// No LIS3DH answered (WHO_AM_I was not 0x33) or it refused the configuration.
    NotFound,
}

/// The LIS3DH on I2C, configured for high resolution, +-4 g, 400 Hz, block data update.
pub struct Lis3dhSource<I2C> {
    sensor: Lis3dh<Lis3dhI2C<I2C>>,
    frame: SensorFrame,
    next_index: u32,
}

impl<I2C, E> Lis3dhSource<I2C>
where
    I2C: I2c<Error = E>,
    E: core::fmt::Debug,
{
    /// Finds and configures the sensor at the default address (0x18); its readings go
    /// through `frame` (calibration, then mounting).
    pub fn new(i2c: I2C, frame: impl Into<SensorFrame>) -> Result<Self, SensorError<E>> {
        let config = Configuration {
            mode: Mode::HighResolution,
            datarate: DataRate::Hz_400,
            ..Configuration::default()
        };
        let mut sensor =
            Lis3dh::new_i2c_with_config(i2c, SlaveAddr::Default, config).map_err(map_error)?;
        sensor.set_range(Range::G4).map_err(map_error)?;
        Ok(Self {
            sensor,
            frame: frame.into(),
            next_index: 0,
        })
    }

    /// One reading in sensor axes, m/s^2, as the datasheet scales it (for the mounting and
    /// tumble calibrations at rest).
    pub fn read_sensor_m_s2(&mut self) -> Result<[f32; 3], SensorError<E>> {
        let raw = self
            .sensor
            .accel_raw()
            .map_err(|e| map_error(e.into_cause()))?;
        Ok(AccelCounts([raw.x, raw.y, raw.z]).to_m_s2())
    }
}

impl<I2C, E> SampleSource for Lis3dhSource<I2C>
where
    I2C: I2c<Error = E>,
    E: core::fmt::Debug,
{
    type Error = SensorError<E>;

    fn poll(&mut self) -> Result<Option<(u32, [f32; 3])>, Self::Error> {
        if !self.sensor.is_data_ready().map_err(map_error)? {
            return Ok(None);
        }
        // A sample exists from here on: if reading it fails, its index is used up, so the
        // next good sample arrives after a gap and the pipeline raises the gap fault.
        let index = self.next_index;
        self.next_index = index.wrapping_add(1);
        let sensor_m_s2 = self.read_sensor_m_s2()?;
        Ok(Some((index, self.frame.to_litter_m_s2(sensor_m_s2))))
    }
}

impl<I2C> Lis3dhSource<I2C> {
    /// Uses `frame` (calibration and mounting) from the next sample on (after new
    /// parameters were uploaded).
    pub fn set_frame(&mut self, frame: impl Into<SensorFrame>) {
        self.frame = frame.into();
    }
}

/// Replay: the samples of `Samples` frames from the host, queued in arrival order with
/// their indices. Holding a whole frame's worth (`N`) is enough, since the firmware drains
/// the queue after each frame.
#[derive(Debug, Default)]
pub struct ReplaySource<const N: usize> {
    queue: Deque<(u32, [f32; 3]), N>,
}

impl<const N: usize> ReplaySource<N> {
    /// An empty queue.
    pub const fn new() -> Self {
        Self {
            queue: Deque::new(),
        }
    }

    /// Queues `accel_m_s2` (litter axes, gravity removed, m/s^2) as the samples numbered
    /// from `first_sample_index`; returns how many did not fit and were dropped.
    pub fn push_batch(&mut self, first_sample_index: u32, accel_m_s2: &[[f32; 3]]) -> usize {
        let mut dropped = 0;
        for (offset, &sample) in (0u32..).zip(accel_m_s2) {
            let index = first_sample_index.wrapping_add(offset);
            if self.queue.push_back((index, sample)).is_err() {
                dropped += 1;
            }
        }
        dropped
    }
}

impl<const N: usize> SampleSource for ReplaySource<N> {
    type Error = Infallible;

    fn poll(&mut self) -> Result<Option<(u32, [f32; 3])>, Self::Error> {
        Ok(self.queue.pop_front())
    }
}

fn map_error<E>(e: lis3dh::Error<E, core::convert::Infallible>) -> SensorError<E> {
    match e {
        lis3dh::Error::Bus(e) => SensorError::Bus(e),
        _ => SensorError::NotFound,
    }
}

#[cfg(test)]
mod tests;
