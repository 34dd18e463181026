//! Addresses of cells, interface ports and the host on the skin network.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// A 16-bit network address.
///
/// `0` is a cell that has no ID yet, `1..=0xFEFF` are cell IDs,
/// `0xFF00 + k` is interface port `k` (`k < 0xFE`), `0xFFFE` is the host
/// (the destination of all upstream traffic) and `0xFFFF` is everybody.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, MaxSize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[serde(transparent)]
pub struct Address(pub u16);

impl Address {
    /// A cell that has not been given an ID.
    pub const UNASSIGNED: Address = Address(0);
    /// The robot PC: destination of every upstream frame.
    pub const HOST: Address = Address(0xFFFE);
    /// All cells.
    pub const BROADCAST: Address = Address(0xFFFF);
    /// The largest cell ID.
    pub const MAX_CELL: u16 = 0xFEFF;
    const INTERFACE_BASE: u16 = 0xFF00;
    /// The number of interface ports an address can name.
    pub const MAX_INTERFACES: u16 = 0xFE;

    /// The address of interface port `k`, if `k` is in range.
    pub fn interface(k: u8) -> Option<Address> {
        (u16::from(k) < Self::MAX_INTERFACES).then(|| Address(Self::INTERFACE_BASE + u16::from(k)))
    }

    /// The cell ID `id`, if it is in the cell range.
    pub fn cell(id: u16) -> Option<Address> {
        (1..=Self::MAX_CELL).contains(&id).then_some(Address(id))
    }

    /// True for a cell ID (not unassigned, not an interface, host or broadcast).
    pub fn is_cell(self) -> bool {
        (1..=Self::MAX_CELL).contains(&self.0)
    }

    /// The interface port number, if this is an interface address.
    pub fn interface_number(self) -> Option<u8> {
        let k = self.0.checked_sub(Self::INTERFACE_BASE)?;
        (k < Self::MAX_INTERFACES).then_some(k as u8)
    }
}

impl core::fmt::Display for Address {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Address::UNASSIGNED => f.write_str("unassigned"),
            Address::HOST => f.write_str("host"),
            Address::BROADCAST => f.write_str("broadcast"),
            a => match a.interface_number() {
                Some(k) => write!(f, "interface {k}"),
                None => write!(f, "cell {}", a.0),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_address_has_exactly_one_role() {
        for raw in 0..=u16::MAX {
            let a = Address(raw);
            let roles = [
                a == Address::UNASSIGNED,
                a.is_cell(),
                a.interface_number().is_some(),
                a == Address::HOST,
                a == Address::BROADCAST,
            ];
            assert_eq!(roles.iter().filter(|r| **r).count(), 1, "{raw:#x}");
        }
        assert_eq!(Address::interface(3).unwrap().interface_number(), Some(3));
        assert_eq!(Address::interface(0xFE), None);
        assert_eq!(Address::cell(0), None);
    }
}
