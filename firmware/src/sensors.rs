//! The sensors of a cell as the sampling loop sees them: one raw
//! [`Sample`] per period, whatever the chips or the stand-in behind it.

use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::i2c::I2c;
use embedded_hal::spi::SpiDevice;
use skin_protocol::message::AccelRange;
use skin_protocol::Sample;

use crate::drivers::force::{ForceCells, RcTiming};
use crate::drivers::{bma250::Bma250, lm71, lm71::Lm71, vcnl4010::Vcnl4010};

/// Which sensor failed; the sample of that period is skipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SensorError {
    /// The VCNL4010 did not answer.
    Proximity,
    /// The BMA250 did not answer.
    Accelerometer,
    /// The LM71 did not answer.
    Temperature,
    /// A force-cell measurement failed.
    Force,
    /// The stand-in sensors of the QEMU board have had no stimulus yet.
    NoStimulus,
}

/// A cell's sensor set.
pub trait Sensors {
    /// Reads every sensor once, in raw counts (the sequence number is left
    /// to the processing).
    fn read(&mut self, now_us: u64) -> Result<Sample, SensorError>;
    /// Applies an accelerometer range written by the host.
    fn set_accel_range(&mut self, range: AccelRange) -> Result<(), SensorError>;
}

/// The chips of a real cell: VCNL4010 on I2C, BMA250 and LM71 on SPI, and
/// the force pads measured by the MCU.
#[derive(Debug)]
pub struct Chips<I, A, T, P> {
    proximity: Vcnl4010<I>,
    accel: Bma250<A>,
    thermometer: Lm71<T>,
    force: RcTiming<P>,
    temperature: i16,
    next_temperature_us: u64,
}

impl<I: I2c, A: SpiDevice, T: SpiDevice, P: InputPin + OutputPin> Chips<I, A, T, P> {
    /// The initialized drivers.
    pub fn new(proximity: Vcnl4010<I>, accel: Bma250<A>, thermometer: Lm71<T>, force: RcTiming<P>) -> Self {
        Chips { proximity, accel, thermometer, force, temperature: 0, next_temperature_us: 0 }
    }
}

impl<I: I2c, A: SpiDevice, T: SpiDevice, P: InputPin + OutputPin> Sensors for Chips<I, A, T, P> {
    fn read(&mut self, now_us: u64) -> Result<Sample, SensorError> {
        let proximity = self.proximity.proximity().map_err(|_| SensorError::Proximity)?;
        let accel = self.accel.accel().map_err(|_| SensorError::Accelerometer)?;
        // The LM71 converts slowly: read it once per conversion.
        if now_us >= self.next_temperature_us {
            self.temperature = self.thermometer.temperature().map_err(|_| SensorError::Temperature)?;
            self.next_temperature_us = now_us + lm71::CONVERSION_US;
        }
        let force = self.force.measure().map_err(|_| SensorError::Force)?;
        Ok(Sample::saturating(proximity, force, accel, self.temperature, 0))
    }

    fn set_accel_range(&mut self, range: AccelRange) -> Result<(), SensorError> {
        self.accel.set_range(range).map_err(|_| SensorError::Accelerometer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drivers::bma250;
    use embedded_hal_mock::eh1::delay::NoopDelay;
    use embedded_hal_mock::eh1::digital::{Mock as Pin, State, Transaction as P};
    use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I};
    use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as S};

    fn spi_read(first: Option<u8>, data: &[u8]) -> Vec<S<u8>> {
        let mut t = vec![S::transaction_start()];
        t.extend(first.map(|r| S::write_vec(vec![r])));
        t.push(S::read_vec(data.to_vec()));
        t.push(S::transaction_end());
        t
    }

    fn spi_write(bytes: &[u8]) -> Vec<S<u8>> {
        vec![S::transaction_start(), S::write_vec(bytes.to_vec()), S::transaction_end()]
    }

    fn pad(reads: usize) -> Vec<P> {
        let mut t = vec![P::set(State::Low), P::set(State::High)];
        t.extend((0..reads).map(|_| P::get(State::Low)));
        t.extend([P::get(State::High), P::set(State::Low)]);
        t
    }

    /// Two periods 4 ms apart: the LM71 is read in the first only, and the
    /// sample carries every chip's value.
    #[test]
    fn reads_every_chip_and_the_thermometer_once_per_conversion() {
        let i2c = I2cMock::new(&[
            I::write_read(0x13, vec![0x81], vec![0x21]),
            I::write(0x13, vec![0x83, 10]),
            I::write(0x13, vec![0x82, 7]),
            I::write(0x13, vec![0x80, 0x03]),
            I::write_read(0x13, vec![0x87], vec![0x01, 0x00]),
            I::write_read(0x13, vec![0x87], vec![0x01, 0x01]),
        ]);
        let bma = [
            spi_write(&[0x14, 0xB6]),
            spi_read(Some(0x80), &[bma250::CHIP_ID]),
            spi_write(&[0x10, 0x0C]),
            spi_write(&[0x0F, 0x03]),
            spi_read(Some(0x82), &[0x40, 0, 0, 0, 0, 0x40]),
            spi_write(&[0x0F, 0x08]),
            spi_read(Some(0x82), &[0, 0, 0, 0, 0, 0x10]),
        ]
        .concat();
        let mut lm = vec![S::transaction_start(), S::read_vec(vec![0, 3]), S::write_vec(vec![0xFF; 2])];
        lm.extend([S::transaction_end(), S::transaction_start(), S::read_vec(vec![0x80, 0x0F])]);
        lm.extend([S::write_vec(vec![0, 0]), S::transaction_end()]);
        lm.extend(spi_read(None, &[0x0C, 0x83])); // 25 degC = 800 counts
        let pads = [[pad(5), pad(5)].concat(), [pad(6), pad(6)].concat(), [pad(7), pad(7)].concat()];
        let mut chips = Chips::new(
            Vcnl4010::new(i2c, 10).unwrap(),
            Bma250::new(SpiMock::new(&bma), &mut NoopDelay, AccelRange::G2).unwrap(),
            Lm71::new(SpiMock::new(&lm)).unwrap(),
            RcTiming::new(pads.map(|t| Pin::new(&t))),
        );
        let a = chips.read(0).unwrap();
        assert_eq!((a.proximity(), a.force(), a.accel(), a.temperature()), (256, [5, 6, 7], [1, 0, 256], 800));
        chips.set_accel_range(AccelRange::G8).unwrap();
        let b = chips.read(4_000).unwrap();
        assert_eq!((b.proximity(), b.accel(), b.temperature()), (257, [0, 0, 64], 800));
        let Chips { proximity, accel, thermometer, force, .. } = chips;
        proximity.release().done();
        accel.release().done();
        thermometer.release().done();
        for mut p in force.release() {
            p.done();
        }
    }
}
