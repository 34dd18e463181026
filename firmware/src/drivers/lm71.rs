//! TI LM71 temperature sensor on SPI (Table 1: 14 bit, -40 to 150 degC).
//!
//! The LM71 has one bidirectional data line: in each chip-select window the
//! MCU first reads the 16-bit temperature register (14-bit two's complement
//! in bits 15:2, 0.03125 degC per count, bits 1:0 read as ones) and may then
//! write 16 bits of configuration: all ones shut the converter down, all
//! zeros run it continuously. In shutdown the read returns the chip ID.

use embedded_hal::spi::{Operation, SpiDevice};

use super::Error;

/// The register read in shutdown.
pub const DEVICE_ID: u16 = 0x800F;
/// Configuration word: continuous conversion.
const CONTINUOUS: [u8; 2] = [0x00, 0x00];
/// Configuration word: shutdown.
const SHUTDOWN: [u8; 2] = [0xFF, 0xFF];
/// A conversion takes this long; reading faster returns the same value
/// (the sensor's 0-7 Hz bandwidth, Table 1).
pub const CONVERSION_US: u64 = 300_000;

/// The LM71 on an SPI device (bus plus its chip select).
#[derive(Debug)]
pub struct Lm71<S> {
    spi: S,
}

impl<S: SpiDevice> Lm71<S> {
    /// Puts the chip in shutdown to read its ID, then starts continuous
    /// conversion.
    pub fn new(mut spi: S) -> Result<Self, Error<S::Error>> {
        let mut word = [0; 2];
        spi.transaction(&mut [Operation::Read(&mut word), Operation::Write(&SHUTDOWN)])?;
        spi.transaction(&mut [Operation::Read(&mut word), Operation::Write(&CONTINUOUS)])?;
        let id = u16::from_be_bytes(word);
        if id != DEVICE_ID {
            return Err(Error::WrongChip(id));
        }
        Ok(Lm71 { spi })
    }

    /// The last converted temperature in counts of 0.03125 degC.
    pub fn temperature(&mut self) -> Result<i16, Error<S::Error>> {
        let mut word = [0; 2];
        self.spi.read(&mut word)?;
        Ok(i16::from_be_bytes(word) >> 2)
    }

    /// Gives the bus back.
    pub fn release(self) -> S {
        self.spi
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};

    fn init(id: [u8; 2]) -> Vec<T<u8>> {
        vec![
            T::transaction_start(),
            T::read_vec(vec![0x0C, 0x83]),
            T::write_vec(vec![0xFF, 0xFF]),
            T::transaction_end(),
            T::transaction_start(),
            T::read_vec(id.to_vec()),
            T::write_vec(vec![0x00, 0x00]),
            T::transaction_end(),
        ]
    }

    fn read(word: u16) -> [T<u8>; 3] {
        [T::transaction_start(), T::read_vec(word.to_be_bytes().to_vec()), T::transaction_end()]
    }

    #[test]
    fn checks_the_id_in_shutdown_and_reads_14_bit_counts() {
        let mut expect = init([0x80, 0x0F]);
        // Datasheet examples: +150 degC = 0x12C0 << 2 | 3, -40 degC = 0x3B00 << 2 | 3, 0.03125 = 1.
        expect.extend(read(0x4B03));
        expect.extend(read(0xEC03));
        expect.extend(read(0x0007));
        let mut chip = Lm71::new(Mock::new(&expect)).unwrap();
        assert_eq!(chip.temperature().unwrap(), 4800); // 150 degC
        assert_eq!(chip.temperature().unwrap(), -1280); // -40 degC
        assert_eq!(chip.temperature().unwrap(), 1);
        chip.release().done();
    }

    #[test]
    fn another_chip_is_refused() {
        let mut spi = Mock::new(&init([0x12, 0x34]));
        assert_eq!(Lm71::new(spi.clone()).unwrap_err(), Error::WrongChip(0x1234));
        spi.done();
    }
}
