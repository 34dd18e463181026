//! The three capacitive normal-force cells (Table 1: 12 bit, 0-10 N).
//!
//! A force compresses a metal spring over a pad and raises the capacitance
//! between them; the cell's MCU measures that capacitance itself (Figure 3).
//! [`ForceCells`] is what the sampling loop needs; [`RcTiming`] measures
//! without extra electronics: it discharges each pad through an open-drain
//! pin, releases it to charge through a pull-up resistor, and counts polls of
//! the pin until it reads high. The count grows with the capacitance, and
//! stopping it at [`FORCE_MAX`] makes it the cell's 12-bit reading.

use embedded_hal::digital::{InputPin, OutputPin};
use skin_protocol::sample::FORCE_MAX;

/// A measurement of the three force cells in raw 12-bit counts.
pub trait ForceCells {
    /// Why a measurement failed.
    type Error;
    /// Measures all three cells.
    fn measure(&mut self) -> Result<[u16; 3], Self::Error>;
}

/// Charge-time measurement of three pads on open-drain pins that can be
/// read back (a pad pin is driven low to discharge and released to charge).
#[derive(Debug)]
pub struct RcTiming<P> {
    pads: [P; 3],
}

impl<P: InputPin + OutputPin> RcTiming<P> {
    /// The three pad pins.
    pub fn new(pads: [P; 3]) -> Self {
        RcTiming { pads }
    }

    /// Gives the pins back.
    pub fn release(self) -> [P; 3] {
        self.pads
    }

    fn charge_time(pad: &mut P) -> Result<u16, P::Error> {
        pad.set_low()?;
        pad.set_high()?;
        let mut count = 0;
        while count < FORCE_MAX && pad.is_low()? {
            count += 1;
        }
        // Leave the pad discharged, so the next measurement starts from 0 V.
        pad.set_low()?;
        Ok(count)
    }
}

impl<P: InputPin + OutputPin> ForceCells for RcTiming<P> {
    type Error = P::Error;

    fn measure(&mut self) -> Result<[u16; 3], P::Error> {
        let mut counts = [0; 3];
        for (count, pad) in counts.iter_mut().zip(&mut self.pads) {
            *count = Self::charge_time(pad)?;
        }
        Ok(counts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction as T};

    /// A pad that reads low `polls` times before it reads high.
    fn pad(polls: usize) -> Mock {
        let mut t = vec![T::set(State::Low), T::set(State::High)];
        t.extend((0..polls).map(|_| T::get(State::Low)));
        if polls < usize::from(FORCE_MAX) {
            t.push(T::get(State::High));
        }
        t.push(T::set(State::Low));
        Mock::new(&t)
    }

    #[test]
    fn counts_polls_until_the_pad_is_charged_and_saturates_at_12_bits() {
        let mut cells = RcTiming::new([pad(0), pad(37), pad(usize::from(FORCE_MAX))]);
        assert_eq!(cells.measure().unwrap(), [0, 37, FORCE_MAX]);
        for mut p in cells.release() {
            p.done();
        }
    }
}
