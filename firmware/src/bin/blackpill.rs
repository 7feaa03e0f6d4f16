//! The monitor on a real board: WeAct STM32F411CE "Black Pill" (Cortex-M4F), an ST LIS3DH
//! on I2C1 (PB8 SCL, PB9 SDA, 400 kHz), the host on USART1 (PA9 TX, PA10 RX, 921,600 bd).
//!
//! Same main loop as under QEMU ([`App`]); samples come from the accelerometer
//! ([`Lis3dhSource`]: counts to m/s^2, rotated to litter axes, gravity removed with the
//! blob's mounting calibration) instead of the UART. The independent watchdog resets a
//! hung loop after 250 ms; defmt over RTT carries diagnostics, USART1 only protocol frames.
//! The blob in flash must be built for the sensor's 400 Hz output rate. Parameter slots A
//! and B are flash sectors 6 and 7; signed uploads over USART1 are written there.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use defmt_rtt as _;
use stm32f4xx_hal::i2c::{DutyCycle, I2c, Mode as I2cMode};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::serial::Serial;
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use supine_app::{App, Boot};
use supine_core::blob::BlobError;
use supine_core::protocol::{PANIC_MESSAGE_LEN, ParamsSource, ResetCause};
use supine_firmware::boards::blackpill::{BoardFlash, SYSCLK_HZ, Usart1Link};
use supine_firmware::cycles::SysTickCounter;
use supine_firmware::param_flash::{self, ParamRegion};
use supine_firmware::stack::PaintedStack;
use supine_firmware::{panic_record, params};
use supine_sensor::{Lis3dhSource, SampleSource};

#[entry]
fn main() -> ! {
    supine_firmware::reset_on_panic();
    let last_panic = panic_record::take();
    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        // Only reachable if something took the peripherals before main.
        cortex_m::peripheral::SCB::sys_reset()
    };
    // Why the last run ended, before the clock setup takes RCC: the watchdog's flag, then
    // cleared so a later power-on reads as one.
    let watchdog_reset = dp.RCC.csr().read().wdgrstf().bit_is_set();
    dp.RCC.csr().modify(|_, w| w.rmvf().set_bit());
    let mut watchdog = IndependentWatchdog::new(dp.IWDG);
    watchdog.start(250.millis());

    let mut rcc = dp.RCC.freeze(Config::hse(25.MHz()).sysclk(SYSCLK_HZ.Hz()));
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);

    let Some(flash) = ParamRegion::take().and_then(|region| BoardFlash::new(region, dp.FLASH))
    else {
        defmt::error!("the PARAMS region is not sectors 6 and 7: broken build");
        cortex_m::peripheral::SCB::sys_reset()
    };
    let Ok(serial) = Serial::new(dp.USART1, (gpioa.pa9, gpioa.pa10), 921_600.bps(), &mut rcc)
    else {
        defmt::error!("USART1 configuration refused");
        cortex_m::peripheral::SCB::sys_reset()
    };
    let link = Usart1Link::new(serial);

    let i2c = I2c::new(
        dp.I2C1,
        (gpiob.pb8, gpiob.pb9),
        I2cMode::fast(400.kHz(), DutyCycle::Ratio2to1),
        &mut rcc,
    );

    // SysTick counts the processor clock (HCLK): the monitor's waits are in its ticks.
    let counter = SysTickCounter::new(cp.SYST, rcc.clocks.hclk().raw());
    // A panic resets through software after recording its message; the watchdog flag
    // alone means the loop hung.
    let reset_cause = if last_panic.is_some() {
        ResetCause::Panic
    } else if watchdog_reset {
        ResetCause::Watchdog
    } else {
        ResetCause::PowerOn
    };
    let boot = BootState {
        reset_cause,
        last_panic: last_panic.unwrap_or_default(),
    };
    let mut app = monitor(link, counter, flash, boot);
    let mut sensor = match Lis3dhSource::new(i2c, app.sensor_frame()) {
        Ok(sensor) => Some(sensor),
        Err(_) => {
            // Keep serving the host (greeting, status); the missing samples show as none.
            defmt::error!("no LIS3DH on I2C1");
            None
        }
    };
    app.greet();
    loop {
        app.poll();
        if let Some(source) = sensor.as_mut() {
            // An upload may have brought another calibration or mounting.
            source.set_frame(app.sensor_frame());
            match source.poll() {
                Ok(Some((index, accel_m_s2))) => app.push_sample(index, accel_m_s2),
                Ok(None) => {}
                Err(_) => defmt::warn!("LIS3DH read failed"),
            }
        }
        watchdog.feed();
    }
}

/// How the last run ended, for the greeting.
struct BootState {
    reset_cause: ResetCause,
    last_panic: heapless::String<PANIC_MESSAGE_LEN>,
}

/// The monitor, with the parameters chosen at boot.
///
/// Out of line: choosing the slot decodes and validates every slot, and those temporaries
/// live in this frame, gone before the monitor runs. Inlined into `main`, whose frame
/// holds the monitor for good, they would stay under it (as in `src/main.rs`).
#[inline(never)]
fn monitor(
    link: Usart1Link,
    counter: SysTickCounter,
    flash: BoardFlash,
    state: BootState,
) -> App<Usart1Link, SysTickCounter, PaintedStack, BoardFlash> {
    let mut loaded = Err(BlobError::Empty);
    let source = params::load_to(&flash, &mut loaded);
    let Ok(params) = loaded else {
        defmt::error!("the built-in parameters are refused: broken build");
        cortex_m::peripheral::SCB::sys_reset()
    };
    match source {
        ParamsSource::Flash { slot } => defmt::info!("parameters from flash slot {}", slot),
        ParamsSource::BuiltInDefault { reason } => {
            defmt::warn!(
                "built-in default parameters: flash blob refused ({})",
                reason.code()
            )
        }
    }
    let boot = Boot {
        build: "+blackpill",
        params,
        source,
        reset_cause: state.reset_cause,
        last_panic: state.last_panic,
    };
    App::with_updates(
        link,
        counter,
        PaintedStack,
        boot,
        flash,
        param_flash::device_key(),
    )
}
