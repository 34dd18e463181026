//! Bosch BMA250 three-axis accelerometer on SPI (Table 1: 10 bit, +-2/8/16 g).
//!
//! SPI mode 0 or 3; the first byte of a transfer is the register address,
//! with bit 7 set to read. Reads of several registers auto-increment, so the
//! three axes come in one six-byte burst: each axis is an LSB register
//! (data bits 1:0 in bits 7:6) followed by an MSB register (data bits 9:2).

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};
use skin_protocol::message::AccelRange;

use super::Error;

/// Registers used by this driver (datasheet, "Register map").
pub mod reg {
    /// Chip ID.
    pub const CHIP_ID: u8 = 0x00;
    /// X axis LSB; Y and Z follow up to 0x07.
    pub const ACC_X_LSB: u8 = 0x02;
    /// Measurement range.
    pub const RANGE: u8 = 0x0F;
    /// Filter bandwidth.
    pub const BANDWIDTH: u8 = 0x10;
    /// Soft reset.
    pub const SOFT_RESET: u8 = 0x14;
}

/// Chip ID of the BMA250.
pub const CHIP_ID: u8 = 0x03;
const READ: u8 = 0x80;
const RESET_COMMAND: u8 = 0xB6;
/// Start-up time after a soft reset.
const RESET_US: u32 = 2_000;
/// Bandwidth code 0x0C: 125 Hz, so data update at 250 Hz, the sampling rate.
const BANDWIDTH_125_HZ: u8 = 0x0C;

/// The range register code of a range.
pub fn range_code(range: AccelRange) -> u8 {
    match range {
        AccelRange::G2 => 0x03,
        AccelRange::G8 => 0x08,
        AccelRange::G16 => 0x0C,
    }
}

/// The BMA250 on an SPI device (bus plus its chip select).
#[derive(Debug)]
pub struct Bma250<S> {
    spi: S,
    range: AccelRange,
}

impl<S: SpiDevice> Bma250<S> {
    /// Resets the chip, checks its ID, and sets `range` and a 125 Hz bandwidth.
    pub fn new(mut spi: S, delay: &mut impl DelayNs, range: AccelRange) -> Result<Self, Error<S::Error>> {
        spi.write(&[reg::SOFT_RESET, RESET_COMMAND])?;
        delay.delay_us(RESET_US);
        let mut id = [0];
        spi.transaction(&mut [Operation::Write(&[READ | reg::CHIP_ID]), Operation::Read(&mut id)])?;
        if id[0] != CHIP_ID {
            return Err(Error::WrongChip(id[0].into()));
        }
        spi.write(&[reg::BANDWIDTH, BANDWIDTH_125_HZ])?;
        let mut chip = Bma250 { spi, range };
        chip.set_range(range)?;
        Ok(chip)
    }

    /// Sets the measurement range.
    pub fn set_range(&mut self, range: AccelRange) -> Result<(), Error<S::Error>> {
        self.spi.write(&[reg::RANGE, range_code(range)])?;
        self.range = range;
        Ok(())
    }

    /// The range in use.
    pub fn range(&self) -> AccelRange {
        self.range
    }

    /// The latest acceleration x, y, z in 10-bit counts of the range.
    pub fn accel(&mut self) -> Result<[i16; 3], Error<S::Error>> {
        let mut raw = [0u8; 6];
        self.spi.transaction(&mut [Operation::Write(&[READ | reg::ACC_X_LSB]), Operation::Read(&mut raw)])?;
        Ok(core::array::from_fn(|i| decode(raw[2 * i], raw[2 * i + 1])))
    }

    /// Gives the bus back.
    pub fn release(self) -> S {
        self.spi
    }
}

/// A 10-bit two's complement axis from its LSB and MSB registers.
fn decode(lsb: u8, msb: u8) -> i16 {
    (i16::from(msb as i8) << 2) | i16::from(lsb >> 6)
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::delay::NoopDelay;
    use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};

    fn write(bytes: &[u8]) -> [T<u8>; 3] {
        [T::transaction_start(), T::write_vec(bytes.to_vec()), T::transaction_end()]
    }

    fn read(reg: u8, data: &[u8]) -> [T<u8>; 4] {
        [T::transaction_start(), T::write_vec(vec![0x80 | reg]), T::read_vec(data.to_vec()), T::transaction_end()]
    }

    fn init(range: u8) -> Vec<T<u8>> {
        [&write(&[0x14, 0xB6])[..], &read(0x00, &[0x03]), &write(&[0x10, 0x0C]), &write(&[0x0F, range])].concat()
    }

    #[test]
    fn resets_checks_id_and_sets_every_range() {
        for (range, code) in [(AccelRange::G2, 0x03), (AccelRange::G8, 0x08), (AccelRange::G16, 0x0C)] {
            let chip = Bma250::new(Mock::new(&init(code)), &mut NoopDelay, range).unwrap();
            assert_eq!(chip.range(), range);
            chip.release().done();
        }
    }

    #[test]
    fn reads_three_10_bit_axes_in_one_burst() {
        let mut expect = init(0x03);
        expect.extend(write(&[0x0F, 0x0C]));
        // x = +511 (0x7F, 0b11), y = -512 (0x80, 0b00), z = -1 (0xFF, 0b11).
        expect.extend(read(0x02, &[0xC1, 0x7F, 0x01, 0x80, 0xC0, 0xFF]));
        let mut chip = Bma250::new(Mock::new(&expect), &mut NoopDelay, AccelRange::G2).unwrap();
        chip.set_range(AccelRange::G16).unwrap();
        assert_eq!(chip.accel().unwrap(), [511, -512, -1]);
        chip.release().done();
    }

    #[test]
    fn another_chip_is_refused() {
        let expect = [&write(&[0x14, 0xB6])[..], &read(0x00, &[0xF9])].concat();
        let mut spi = Mock::new(&expect);
        let e = Bma250::new(spi.clone(), &mut NoopDelay, AccelRange::G2).unwrap_err();
        assert_eq!(e, Error::WrongChip(0xF9));
        spi.done();
    }

    #[test]
    fn decoding_covers_the_10_bit_range() {
        for v in -512i16..512 {
            let bits = (v as u16) & 0x3FF;
            let (lsb, msb) = (((bits & 3) << 6) as u8, (bits >> 2) as u8);
            assert_eq!(decode(lsb | 0x01, msb), v, "new-data flag in bit 0 is ignored");
        }
    }
}
