//! What a cell needs from its hardware, and the main loop that glues the
//! board to the [`Node`].

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use embedded_storage::nor_flash::NorFlash;
use skin_protocol::frame::FRAME_LEN;
use skin_protocol::message::{Port, Setting};
use skin_protocol::organize::Config;
use skin_protocol::update::Updater;

use crate::boot_control::{BootControl, Then};
use crate::flash_slot::FlashSlot;
use crate::node::Node;
use crate::sensors::Sensors;
use crate::store::Store;

/// Timings of self-organization for cells on QEMU: beacons and the parent's
/// link timeout about 10 times the defaults of [`Config::default`], every
/// link kept alive every 100 ms as by default (so every wave goes on every
/// link).
///
/// QEMU cells exchange frames through host sockets in wall time, and on a
/// two-core machine running several QEMU processes, the test harness and
/// maybe a build, a process can be descheduled for tens of milliseconds.
/// The default 35 ms link timeout would then see links flap; 400 ms outlasts
/// such stalls while a killed neighbour is still noticed within half a
/// second. QEMU moves UART bytes one at a time, an interrupt each, so the
/// probes and beacons of idle links are what an idle patch costs the host:
/// they are sent every 100 ms. The harness's interface port uses the same
/// timings.
pub const QEMU_CONFIG: Config = Config {
    keepalive_period_us: 100_000,
    keepalive_timeout_us: 400_000,
    link_timeout_us: 400_000,
    beacon_period_us: 100_000,
    wave_timeout_us: 150_000,
    route_timeout_us: 400_000,
    id_retry_us: 250_000,
    report_period_us: 4_000_000,
};

/// The trial limit of QEMU cells instead of a real cell's
/// ([`skin_protocol::update::TRIAL_US`]): every cell of a patch restarts
/// into its trial at once, re-checks its image in its bootloader, and a
/// QEMU patch takes seconds to organize again (its timings are ten times
/// [`Config::default`]'s: [`QEMU_CONFIG`]; 7 cells take about 2 s, more
/// on a loaded machine), so 10 s.
pub const QEMU_TRIAL_US: u64 = 10_000_000;

/// Received bytes taken from a port at a time: a few frames.
const RX_CHUNK: usize = 64;
/// Frames one chunk of bytes can end (with a frame's start already in).
const RX_FRAMES: usize = RX_CHUNK.div_ceil(FRAME_LEN);
// Every update message a chunk can end waits in the node.
const _: () = assert!(RX_FRAMES <= crate::node::PENDING_UPDATES);

/// One cell-2-cell port: bytes in, whole frames out.
pub trait SerialPort {
    /// Moves received bytes into `buf`; returns how many (0: none waiting).
    fn read(&mut self, buf: &mut [u8]) -> usize;
    /// True when the transmitter takes another frame now. A port that
    /// feeds its UART a byte at a time moves on with the frame it is
    /// sending first.
    fn can_send(&mut self) -> bool;
    /// Sends a frame; call only after [`SerialPort::can_send`].
    fn send(&mut self, frame: &[u8; FRAME_LEN]);
}

/// A cell's hardware: four ports, the sensors, a clock, and a way to sleep.
/// The persistent store's flash is handed to the [`Node`] at boot.
pub trait Board {
    /// The UART type of the ports (a trait object when they differ).
    type Port: SerialPort + ?Sized;
    /// The sensor set.
    type Sensors: Sensors;
    /// Microseconds since boot.
    fn now_us(&mut self) -> u64;
    /// A port.
    fn port(&mut self, port: Port) -> &mut Self::Port;
    /// The sensors.
    fn sensors(&mut self) -> &mut Self::Sensors;
    /// Sleeps until the next interrupt (a received byte or the tick timer),
    /// unless a byte is already waiting. Board background work (the QEMU
    /// board reads its stimulus channel) is done here.
    fn sleep(&mut self);
    /// Feeds the hardware watchdog the bootloader armed: a program that
    /// stops calling this (a hang, not a crash) is reset, and a trial
    /// image that hangs is thus rolled back.
    fn feed_watchdog(&mut self);
    /// Restarts the cell into its bootloader, as a power cycle would.
    fn restart(&mut self) -> !;
}

/// What a program that takes updates was given at start
/// ([`crate::boot_control::start`]).
pub type Updates<F> = (BootControl<F>, Updater, FlashSlot<F>);

/// A board and a node, run together; `F` is the flash of the store, the
/// boot record and the slots.
#[derive(Debug)]
pub struct Firmware<B, F> {
    board: B,
    node: Node<F, FlashSlot<F>>,
    control: Option<BootControl<F>>,
    next_sample_us: u64,
    /// The port read first in the next step.
    first_port: usize,
}

impl<B: Board, F: NorFlash> Firmware<B, F> {
    /// Boots a node on `board` into `slot`, in place: the state (kilobytes
    /// of queues and buffers) lives in a static, where the memory layout
    /// accounts for it, and never passes through the stack. Without
    /// `updates`, update messages are ignored.
    pub fn boot(
        slot: &mut MaybeUninit<Self>,
        mut board: B,
        config: Config,
        store: Store<F>,
        updates: Option<Updates<F>>,
    ) -> &mut Self {
        let now_us = board.now_us();
        let firmware = slot.as_mut_ptr();
        // SAFETY: each field is written once through a pointer into `slot`,
        // and the firmware is only referred to once all are written.
        let firmware = unsafe {
            Node::<F, FlashSlot<F>>::boot(&mut *addr_of_mut!((*firmware).node).cast(), config, store, now_us);
            addr_of_mut!((*firmware).board).write(board);
            addr_of_mut!((*firmware).control).write(None);
            addr_of_mut!((*firmware).next_sample_us).write(now_us);
            addr_of_mut!((*firmware).first_port).write(0);
            slot.assume_init_mut()
        };
        if let Some((control, updater, spare)) = updates {
            firmware.node.take_updates(updater, spare);
            firmware.control = Some(control);
        }
        firmware
    }

    /// The node.
    pub fn node(&self) -> &Node<F, FlashSlot<F>> {
        &self.node
    }

    /// Does what the updater asked of the bootloader, and restarts a trial
    /// out of time.
    fn boot_actions(&mut self, now_us: u64) {
        let Some(control) = self.control.as_mut() else { return };
        if let Some(action) = self.node.take_boot_action() {
            let ready = self.node.updates().map_or(0, |(u, _)| u.report().version);
            match control.act(action, ready) {
                Ok(Then::Restart) => {
                    #[cfg(feature = "defmt")]
                    defmt::info!("{}: restarting into the bootloader", action);
                    self.board.restart()
                }
                Ok(Then::Run) => {}
                Err(_e) => {
                    #[cfg(feature = "defmt")]
                    defmt::warn!("boot record not kept ({}): {} waits for the host to ask again", _e, action);
                }
            }
        }
        if control.expired(now_us) {
            #[cfg(feature = "defmt")]
            defmt::warn!("trial not confirmed in time: restarting into the old image");
            self.board.restart()
        }
    }

    /// Does everything that is due; false when there was nothing to do.
    /// Out of line, so that [`Firmware::run`]'s frame, under the update
    /// checks, stays small.
    #[inline(never)]
    pub fn step(&mut self) -> bool {
        let now = self.board.now_us();
        let mut busy = false;
        // One chunk per port and step, so a flooded port starves no other
        // work; a chunk that brought update messages ends the reading, they
        // are handled first, and the next step starts at the next port.
        let mut chunk = [0u8; RX_CHUNK];
        for k in 0..Port::ALL.len() {
            let p = Port::ALL[(self.first_port + k) % Port::ALL.len()];
            if !self.node.can_take(p, RX_FRAMES) {
                continue;
            }
            let n = self.board.port(p).read(&mut chunk);
            busy |= n > 0;
            for byte in &chunk[..n] {
                if let Some(Setting::AccelRange(r)) = self.node.receive(p, *byte, now) {
                    if let Err(_e) = self.board.sensors().set_accel_range(r) {
                        #[cfg(feature = "defmt")]
                        defmt::warn!("accelerometer range not set: {}", _e);
                    }
                }
            }
            if self.node.has_updates() {
                self.first_port = (p.index() + 1) % Port::ALL.len();
                break;
            }
        }
        self.boot_actions(now);
        if self.node.poll_at() <= now {
            self.node.poll(now);
            busy = true;
        }
        if now >= self.next_sample_us {
            match self.board.sensors().read(now) {
                Ok(raw) => self.node.sample(&raw),
                Err(_e) => {
                    #[cfg(feature = "defmt")]
                    defmt::warn!("sample skipped: {}", _e);
                }
            }
            let period = self.node.period_us();
            // After a stall, start afresh instead of sampling in a burst.
            self.next_sample_us = (self.next_sample_us + period).max(now + period / 2);
            busy = true;
        }
        for p in Port::ALL {
            let port = self.board.port(p);
            while port.can_send() {
                let Some(frame) = self.node.transmit(p) else { break };
                port.send(frame.as_bytes());
                busy = true;
            }
        }
        busy
    }

    /// The main loop: work while there is work, sleep otherwise. Update
    /// messages are handled here, at the top of the stack: the signature
    /// check needs about 4 KiB of it, which the byte path (in
    /// [`Firmware::step`]) must not add to its own. Every pass feeds the
    /// watchdog: the clock's tick (1 ms; 4 ms on QEMU) wakes the loop.
    pub fn run(&mut self) -> ! {
        loop {
            self.board.feed_watchdog();
            if self.node.has_updates() {
                let now = self.board.now_us();
                self.node.handle_updates(now);
                self.boot_actions(now);
            }
            if !self.step() {
                self.board.sleep();
            }
        }
    }
}
