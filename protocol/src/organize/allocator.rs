//! The host's ID allocator: unique IDs for the cells that ask.

use std::collections::{BTreeSet, HashMap};

use crate::address::Address;
use crate::frame::Frame;
use crate::message::{IdAssign, IdRequest, Message};

/// The host's side of phase 3: hands out unique cell IDs.
///
/// IDs seen on the network (stored IDs) are never handed out, and a
/// repeated request from the same place gets the same answer until the
/// new ID shows up as a frame source.
#[derive(Clone, Debug)]
pub struct Allocator {
    /// Seen on the network or handed out.
    used: BTreeSet<u16>,
    pending: HashMap<IdRequest, Address>,
    pending_by_id: HashMap<Address, IdRequest>,
    next: u16,
}

impl Default for Allocator {
    fn default() -> Self {
        Allocator::new()
    }
}

impl Allocator {
    /// An allocator that knows of no IDs yet.
    pub fn new() -> Allocator {
        Allocator { used: BTreeSet::new(), pending: HashMap::new(), pending_by_id: HashMap::new(), next: 1 }
    }

    /// Notes an address seen as a frame source.
    pub fn observe(&mut self, src: Address) {
        if !src.is_cell() {
            return;
        }
        self.used.insert(src.0);
        if let Some(request) = self.pending_by_id.remove(&src) {
            self.pending.remove(&request);
        }
    }

    /// The ID already handed out for this request and not yet seen on
    /// the network: a repeated request (the cell retried).
    pub fn pending(&self, request: &IdRequest) -> Option<Address> {
        self.pending.get(request).copied()
    }

    /// The answer to an ID request: a frame to send down the interface
    /// the request came from. `None` when all cell IDs are taken.
    pub fn request(&mut self, request: IdRequest) -> Option<Frame> {
        let id = match self.pending.get(&request) {
            Some(id) => *id,
            None => {
                let id = self.fresh()?;
                self.pending.insert(request, id);
                self.pending_by_id.insert(id, request);
                id
            }
        };
        let assign = Message::IdAssign(IdAssign { port: request.port, id });
        Some(Frame::new(Address::HOST, request.parent, &assign))
    }

    /// Takes back an ID handed out that no frame has come from: a cell
    /// that never used it, or a request someone made up. It goes back to
    /// the pool behind every ID not yet handed out (the allocator moves on
    /// round the ID space), so a slow cell that speaks up later is almost
    /// surely still alone with it. False when `id` was seen on the network
    /// or is not pending.
    pub fn release(&mut self, id: Address) -> bool {
        let Some(request) = self.pending_by_id.remove(&id) else { return false };
        self.pending.remove(&request);
        self.used.remove(&id.0);
        true
    }

    fn fresh(&mut self) -> Option<Address> {
        for _ in 0..Address::MAX_CELL {
            let candidate = self.next;
            self.next = if self.next >= Address::MAX_CELL { 1 } else { self.next + 1 };
            if self.used.insert(candidate) {
                return Address::cell(candidate);
            }
        }
        None
    }

    /// Cell IDs in use.
    pub fn used(&self) -> usize {
        self.used.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::Port;

    fn assigned(frame: Option<Frame>) -> Address {
        match frame.and_then(|f| f.message().ok()) {
            Some(Message::IdAssign(a)) => a.id,
            other => panic!("not an ID assignment: {other:?}"),
        }
    }

    #[test]
    fn only_ids_never_seen_are_released_and_they_come_back_last() {
        let mut a = Allocator::new();
        let request = |parent| IdRequest { parent: Address(parent), port: Port::P1 };
        let (first, second) = (assigned(a.request(request(0xFF00))), assigned(a.request(request(1))));
        a.observe(second);
        assert!(!a.release(second), "seen on the network");
        assert!(!a.release(Address(77)), "never handed out");
        assert!(a.release(first));
        assert!(!a.release(first), "already released");
        assert_eq!(a.pending(&request(0xFF00)), None);
        assert_eq!(a.used(), 1);
        // The same place asking again gets a fresh ID, not the released one.
        assert_eq!(assigned(a.request(request(0xFF00))), Address(3));
    }
}
