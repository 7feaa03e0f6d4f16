use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use supine_core::mounting::Mounting;

use super::*;

const ADDR: u8 = 0x18;

/// What the driver says to a LIS3DH at power-on (CTRL1 = 0x07, other registers 0) when
/// configured for high resolution, 400 Hz, +-4 g.
fn init() -> Vec<Transaction> {
    vec![
        Transaction::write_read(ADDR, vec![0x0F], vec![0x33]), // WHO_AM_I
        Transaction::write(ADDR, vec![0x23, 0x80]),            // CTRL4: block data update
        Transaction::write_read(ADDR, vec![0x20], vec![0x07]), // CTRL1: clear LP_EN
        Transaction::write(ADDR, vec![0x20, 0x07]),
        Transaction::write_read(ADDR, vec![0x23], vec![0x80]), // CTRL4: set HR
        Transaction::write(ADDR, vec![0x23, 0x88]),
        Transaction::write_read(ADDR, vec![0x20], vec![0x07]), // CTRL1: ODR 400 Hz
        Transaction::write(ADDR, vec![0x20, 0x77]),
        Transaction::write_read(ADDR, vec![0x20], vec![0x77]), // CTRL1: x, y, z on
        Transaction::write(ADDR, vec![0x20, 0x77]),
        Transaction::write_read(ADDR, vec![0x1F], vec![0x00]), // TEMP_CFG: ADC on
        Transaction::write(ADDR, vec![0x1F, 0x80]),
        Transaction::write_read(ADDR, vec![0x23], vec![0x88]), // CTRL4: +-4 g
        Transaction::write(ADDR, vec![0x23, 0x98]),
    ]
}

fn sample(counts: [i16; 3]) -> Vec<Transaction> {
    let mut bytes = Vec::new();
    for c in counts {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    vec![
        Transaction::write_read(ADDR, vec![0x27], vec![0x08]), // STATUS: ZYXDA
        Transaction::write_read(ADDR, vec![0x28 | 0x80], bytes), // OUT_X_L.., auto-increment
    ]
}

#[test]
fn a_level_sensor_at_rest_gives_zero_litter_acceleration() {
    // 1 g on z: 500 digits of 2 mg, left-justified (x16).
    let one_g = 500 * 16;
    let mut expected = init();
    expected.extend(sample([0, 0, one_g]));
    expected.push(Transaction::write_read(ADDR, vec![0x27], vec![0x00])); // not ready
    let mut i2c = Mock::new(&expected);
    let mounting = Mounting {
        gravity_m_s2: 500.0 * 0.002 * STANDARD_GRAVITY_M_S2 as f32,
        ..Mounting::LEVEL
    };
    let mut source = Lis3dhSource::new(i2c.clone(), mounting).expect("sensor found");
    let (index, a) = source.poll().expect("bus ok").expect("a sample");
    assert_eq!(index, 0);
    assert!(a.iter().all(|v| v.abs() < 1e-6), "{a:?}");
    assert_eq!(source.poll().expect("bus ok"), None);
    i2c.done();
}

#[test]
fn readings_are_scaled_rotated_and_indexed() {
    let mut expected = init();
    expected.extend(sample([1000 * 16, -250 * 16, 500 * 16]));
    expected.extend(sample([0, 0, 500 * 16]));
    let mut i2c = Mock::new(&expected);
    // Sensor mounted on its side: sensor z is litter x, sensor x is litter z.
    let mounting = Mounting {
        sensor_to_litter: [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
        gravity_m_s2: 9.806_65,
    };
    let mut source = Lis3dhSource::new(i2c.clone(), mounting).expect("sensor found");
    let (i0, a0) = source.poll().expect("bus").expect("sample");
    let (i1, _) = source.poll().expect("bus").expect("sample");
    assert_eq!((i0, i1), (0, 1));
    let g = STANDARD_GRAVITY_M_S2 as f32;
    let want = [g, -0.5 * g, -3.0 * g];
    for (got, want) in a0.iter().zip(want) {
        assert!((got - want).abs() < 1e-4, "{a0:?} vs {want:?}");
    }
    i2c.done();
}

#[test]
fn a_missing_sensor_is_reported_not_panicked() {
    let expected = [Transaction::write_read(ADDR, vec![0x0F], vec![0x00])];
    let mut i2c = Mock::new(&expected);
    let result = Lis3dhSource::new(i2c.clone(), Mounting::LEVEL);
    assert!(matches!(result, Err(SensorError::NotFound)));
    i2c.done();
}

#[test]
fn one_count_is_2_mg_over_16() {
    let a = AccelCounts([16, -16, 0]).to_m_s2();
    assert!((a[0] - 0.002 * 9.806_65).abs() < 1e-7);
    assert!((a[1] + 0.002 * 9.806_65).abs() < 1e-7);
}

#[test]
fn a_failed_read_uses_up_its_index_so_the_pipeline_sees_a_gap() {
    let mut expected = init();
    expected.push(Transaction::write_read(ADDR, vec![0x27], vec![0x08])); // ready
    expected.push(
        Transaction::write_read(ADDR, vec![0x28 | 0x80], vec![0; 6])
            .with_error(embedded_hal::i2c::ErrorKind::Other),
    );
    expected.extend(sample([0, 0, 500 * 16]));
    let mut i2c = Mock::new(&expected);
    let mut source = Lis3dhSource::new(i2c.clone(), Mounting::LEVEL).expect("sensor found");
    assert!(matches!(source.poll(), Err(SensorError::Bus(_))));
    let (index, _) = source.poll().expect("bus ok").expect("a sample");
    assert_eq!(index, 1, "the lost sample's index 0 is not reused");
    i2c.done();
}

#[test]
fn new_mounting_applies_from_the_next_sample() {
    let mut expected = init();
    expected.extend(sample([1000 * 16, 0, 0]));
    expected.extend(sample([1000 * 16, 0, 0]));
    let mut i2c = Mock::new(&expected);
    let no_gravity = Mounting {
        gravity_m_s2: 0.0,
        ..Mounting::LEVEL
    };
    let mut source = Lis3dhSource::new(i2c.clone(), no_gravity).expect("sensor found");
    let (_, level) = source.poll().expect("bus").expect("sample");
    // Turned a quarter about z: sensor x is litter y.
    source.set_frame(Mounting {
        sensor_to_litter: [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        gravity_m_s2: 0.0,
    });
    let (_, turned) = source.poll().expect("bus").expect("sample");
    let two_g = 2.0 * STANDARD_GRAVITY_M_S2 as f32;
    assert!(
        (level[0] - two_g).abs() < 1e-4 && level[1].abs() < 1e-6,
        "{level:?}"
    );
    assert!(
        (turned[1] - two_g).abs() < 1e-4 && turned[0].abs() < 1e-6,
        "{turned:?}"
    );
    i2c.done();
}

#[test]
fn replay_yields_each_batch_in_order_with_its_indices_and_counts_what_does_not_fit() {
    let mut replay = ReplaySource::<4>::new();
    assert_eq!(replay.poll(), Ok(None));
    assert_eq!(
        replay.push_batch(10, &[[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]),
        0
    );
    assert_eq!(replay.poll(), Ok(Some((10, [1.0, 0.0, 0.0]))));
    assert_eq!(
        replay.push_batch(u32::MAX, &[[3.0; 3], [4.0; 3], [5.0; 3], [6.0; 3]]),
        1
    );
    let rest: Vec<_> = core::iter::from_fn(|| replay.poll().unwrap()).collect();
    assert_eq!(
        rest,
        vec![
            (11, [2.0, 0.0, 0.0]),
            (u32::MAX, [3.0; 3]),
            (0, [4.0; 3]),
            (1, [5.0; 3]),
        ]
    );
}

#[test]
fn readings_are_corrected_for_the_calibration_before_the_mounting() {
    use supine_core::calibration::SensorCalibration;
    let mut expected = init();
    expected.extend(sample([100 * 16, -50 * 16, 520 * 16]));
    let mut i2c = Mock::new(&expected);
    let frame = SensorFrame {
        calibration: SensorCalibration {
            sensitivity: [1.04, 1.0, 1.02],
            offset_m_s2: [0.2, -0.1, 0.3],
            ..SensorCalibration::DATASHEET
        },
        mounting: Mounting {
            sensor_to_litter: [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]],
            gravity_m_s2: 9.806_65,
        },
    };
    let mut source = Lis3dhSource::new(i2c.clone(), frame).expect("sensor found");
    let (_, a) = source.poll().expect("bus").expect("sample");
    // The host's reference makes the same call on the same reading: the same bits.
    let reading = AccelCounts([100 * 16, -50 * 16, 520 * 16]).to_m_s2();
    assert_eq!(a, frame.to_litter_m_s2(reading));
    // And against f64 arithmetic of the definition: corrected, then rotated.
    let corrected: Vec<f64> = (0..3)
        .map(|i| {
            (f64::from(reading[i]) - f64::from(frame.calibration.offset_m_s2[i]))
                / f64::from(frame.calibration.sensitivity[i])
        })
        .collect();
    let want = [corrected[2], corrected[1], -corrected[0] - 9.806_65];
    for (got, want) in a.iter().zip(want) {
        assert!((f64::from(*got) - want).abs() < 1e-5, "{a:?} vs {want:?}");
    }
    i2c.done();
}
