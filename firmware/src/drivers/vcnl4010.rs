//! Vishay VCNL4010 proximity sensor on I2C (Table 1: pre-touch, 16 bit).
//!
//! The sensor measures the infrared light of its own LED reflected by an
//! approaching object. It runs in self-timed mode at 250 measurements/s, the
//! cell's sampling rate, so a read is one register access and never waits
//! for a conversion.

use embedded_hal::i2c::I2c;

use super::Error;

/// 7-bit I2C address (fixed).
pub const ADDRESS: u8 = 0x13;

/// Registers used by this driver (datasheet, "Register functions").
pub mod reg {
    /// Command register: enables and status flags.
    pub const COMMAND: u8 = 0x80;
    /// Product ID (high nibble) and revision (low nibble).
    pub const PRODUCT_ID: u8 = 0x81;
    /// Rate of self-timed proximity measurements.
    pub const PROXIMITY_RATE: u8 = 0x82;
    /// IR LED current in 10 mA steps.
    pub const LED_CURRENT: u8 = 0x83;
    /// Proximity result, high byte; the low byte follows at 0x88.
    pub const PROXIMITY_RESULT: u8 = 0x87;
}

/// Command register bits.
const SELFTIMED_EN: u8 = 1 << 0;
const PROX_EN: u8 = 1 << 1;
/// Product ID nibble of the VCNL4010 (the revision nibble may vary).
const PRODUCT: u8 = 0x2;
/// Proximity rate code 7: 250 measurements/s.
const RATE_250_HZ: u8 = 7;
/// Largest LED current code (200 mA).
pub const MAX_LED_CURRENT: u8 = 20;

/// The VCNL4010 on an I2C bus.
#[derive(Debug)]
pub struct Vcnl4010<I> {
    i2c: I,
}

impl<I: I2c> Vcnl4010<I> {
    /// Checks the product ID, sets the LED current (`led_current` x 10 mA,
    /// clamped to 200 mA) and starts self-timed measurements at 250/s.
    pub fn new(mut i2c: I, led_current: u8) -> Result<Self, Error<I::Error>> {
        let mut id = [0];
        i2c.write_read(ADDRESS, &[reg::PRODUCT_ID], &mut id)?;
        if id[0] >> 4 != PRODUCT {
            return Err(Error::WrongChip(id[0].into()));
        }
        i2c.write(ADDRESS, &[reg::LED_CURRENT, led_current.min(MAX_LED_CURRENT)])?;
        i2c.write(ADDRESS, &[reg::PROXIMITY_RATE, RATE_250_HZ])?;
        i2c.write(ADDRESS, &[reg::COMMAND, SELFTIMED_EN | PROX_EN])?;
        Ok(Vcnl4010 { i2c })
    }

    /// The latest proximity count (larger is closer), 16 bit.
    pub fn proximity(&mut self) -> Result<u16, Error<I::Error>> {
        let mut raw = [0; 2];
        self.i2c.write_read(ADDRESS, &[reg::PROXIMITY_RESULT], &mut raw)?;
        Ok(u16::from_be_bytes(raw))
    }

    /// Gives the bus back.
    pub fn release(self) -> I {
        self.i2c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

    fn init() -> [T; 4] {
        [
            T::write_read(ADDRESS, vec![0x81], vec![0x21]),
            T::write(ADDRESS, vec![0x83, 10]),
            T::write(ADDRESS, vec![0x82, 7]),
            T::write(ADDRESS, vec![0x80, 0x03]),
        ]
    }

    #[test]
    fn starts_self_timed_250_hz_and_reads_big_endian() {
        let mut expect = init().to_vec();
        expect.push(T::write_read(ADDRESS, vec![0x87], vec![0x12, 0x34]));
        let mut s = Vcnl4010::new(Mock::new(&expect), 10).unwrap();
        assert_eq!(s.proximity().unwrap(), 0x1234);
        s.release().done();
    }

    #[test]
    fn led_current_is_clamped_to_200_ma() {
        let mut expect = init().to_vec();
        expect[1] = T::write(ADDRESS, vec![0x83, 20]);
        Vcnl4010::new(Mock::new(&expect), 99).unwrap().release().done();
    }

    #[test]
    fn another_chip_is_refused() {
        let mut i2c = Mock::new(&[T::write_read(ADDRESS, vec![0x81], vec![0x11])]);
        assert_eq!(Vcnl4010::new(i2c.clone(), 10).unwrap_err(), Error::WrongChip(0x11));
        i2c.done();
    }
}
