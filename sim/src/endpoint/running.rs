//! An endpoint serving on a thread of its own, with the experimenter's
//! side channel.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;

use super::rig::Side;
use super::{Endpoint, Truth};
use crate::network::NetworkError;
use crate::scene::operator::{Note, Order};

/// An endpoint serving on a thread of its own (the world is not `Send`, so
/// it is built there), with the experimenter's side channel to the person
/// at the robot ([`Running::order`], [`Running::notes`]).
#[derive(Debug)]
pub struct Running {
    /// The robot-link address.
    pub robot: SocketAddr,
    /// Each interface port's address, by port number.
    pub interfaces: Vec<SocketAddr>,
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Result<Truth, NetworkError>>,
    orders: mpsc::Sender<Order>,
    notes: mpsc::Receiver<Note>,
}

impl Running {
    /// Builds an endpoint with `build` on a new thread and serves until
    /// [`Running::stop`].
    pub fn spawn(
        build: impl FnOnce() -> Result<Endpoint, NetworkError> + Send + 'static,
    ) -> Result<Running, NetworkError> {
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = mpsc::channel();
        let (orders, orders_rx) = mpsc::channel();
        let (notes_tx, notes) = mpsc::channel();
        let flag = stop.clone();
        let thread = std::thread::Builder::new().name("simulated robot".into()).spawn(move || {
            let mut endpoint = match build().and_then(|e| Ok((e.robot_addr()?, e.interface_addrs()?, e))) {
                Ok((robot, interfaces, mut e)) => {
                    e.rig.side = Some(Side { orders: orders_rx, notes: notes_tx });
                    let _ = tx.send(Ok((robot, interfaces)));
                    e
                }
                Err(e) => {
                    let _ = tx.send(Err(e));
                    return Err(NetworkError::Stopped);
                }
            };
            endpoint.serve(&flag)?;
            Ok(endpoint.truth())
        })?;
        match rx.recv() {
            Ok(Ok((robot, interfaces))) => Ok(Running { robot, interfaces, stop, thread, orders, notes }),
            Ok(Err(e)) => Err(e),
            Err(_) => Err(NetworkError::Stopped),
        }
    }

    /// Gives the person an order, carried out at the start of the next
    /// control period (an endpoint without a person refuses it).
    pub fn order(&self, order: Order) -> Result<(), NetworkError> {
        self.orders.send(order).map_err(|_| NetworkError::Stopped)
    }

    /// What the person said since the last call, oldest first.
    pub fn notes(&self) -> impl Iterator<Item = Note> + '_ {
        self.notes.try_iter()
    }

    /// Whether serving ended on its own: an error or a panic, which
    /// [`Running::stop`] then returns.
    pub fn is_finished(&self) -> bool {
        self.thread.is_finished()
    }

    /// Stops serving and returns what the simulator knows.
    pub fn stop(self) -> Result<Truth, NetworkError> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().map_err(|_| NetworkError::Panicked)?
    }
}
