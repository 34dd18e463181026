//! Sensor drivers of a cell (Table 1), generic over the embedded-hal 1.0
//! bus traits and tested against the register sequences of their datasheets.

pub mod bma250;
pub mod force;
pub mod lm71;
pub mod vcnl4010;
