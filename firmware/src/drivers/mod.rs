//! Sensor drivers of a cell (Table 1), generic over the embedded-hal 1.0
//! bus traits and tested against the register sequences of their datasheets.

pub mod bma250;
pub mod force;
pub mod lm71;
pub mod vcnl4010;

/// What can go wrong with a sensor chip.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Error<E> {
    /// The bus (I2C or SPI) failed.
    Bus(E),
    /// The chip's identification did not read as the chip the driver is
    /// for; what it read.
    WrongChip(u16),
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::Bus(e)
    }
}
