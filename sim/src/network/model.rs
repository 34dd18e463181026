//! The paper's network figures (section 2.2.3), derived from the link
//! model: a frame time, a round-robin router, a sampling period.
//!
//! A frame that reaches the head of its input queue waits at most for the
//! frame already on the wire and one frame of each other upstream input
//! (a cell has 4 ports, one of them the master: 3 child ports and its own
//! queue compete), then takes its own frame time; add the processing delay
//! and it has left the cell. A tree may be as deep as that bound fits into
//! one sampling period, and one interface link carries one frame time's
//! worth of cells per period. Our router also sends link-local frames
//! (keep-alive probe and its answer) first, which the paper's figure leaves
//! out, and every cell reports its neighbours upstream now and then; the
//! `_with_control` figures include them. A link busy with data needs no
//! keep-alive, so the interface link of a clock-driven tree carries only
//! the reports.

use serde::Serialize;

use skin_protocol::organize::Config;

use super::link::LinkTiming;

/// Upstream inputs that compete with a frame for its master port.
const OTHER_INPUTS: u64 = 3;
/// Link-local frames that can go before it: a probe and a probe answer.
const LINK_LOCAL_AHEAD: u64 = 2;

/// The figures of section 2.2.3 from the link model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Model {
    /// One frame on a cell-2-cell link.
    pub frame_us: f64,
    /// Worst-case per-cell forwarding delay with round robin (paper: 275 us).
    pub forwarding_us: f64,
    /// The same with the link-local control frames that go first.
    pub forwarding_with_control_us: f64,
    /// Deepest tree whose worst case fits one sampling period (paper: 14).
    pub max_depth: u64,
    /// The same with control frames.
    pub max_depth_with_control: u64,
    /// Cells one interface link carries, clock-driven (paper: 80).
    pub cells_per_interface: u64,
    /// The same less the neighbour-report heartbeat of every cell.
    pub cells_per_interface_with_control: u64,
    /// One frame in its own datagram on the 1 Gbit/s interface (paper: 688 ns).
    pub datagram_ns: u64,
}

impl Model {
    /// The figures for `timing`, sampling at `rate_hz`, with the cells'
    /// self-organization timing `organize`.
    pub fn new(timing: &LinkTiming, rate_hz: f64, organize: &Config) -> Model {
        let frame = timing.frame_ns();
        let forwarding = timing.processing_ns + frame * (1 + OTHER_INPUTS + 1);
        let with_control = forwarding + frame * LINK_LOCAL_AHEAD;
        let period_ns = 1e9 / rate_hz;
        let per_link = timing.frames_per_s();
        let reports_hz = 1e6 / organize.report_period_us as f64;
        Model {
            frame_us: frame as f64 / 1e3,
            forwarding_us: forwarding as f64 / 1e3,
            forwarding_with_control_us: with_control as f64 / 1e3,
            max_depth: (period_ns / forwarding as f64).floor() as u64,
            max_depth_with_control: (period_ns / with_control as f64).floor() as u64,
            cells_per_interface: (per_link / rate_hz).floor() as u64,
            cells_per_interface_with_control: (per_link / (rate_hz + reports_hz)).floor() as u64,
            datagram_ns: timing.datagram_ns(1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_papers_figures_follow_from_table_2() {
        let m = Model::new(&LinkTiming::default(), 250.0, &Config::default());
        assert_eq!((m.frame_us, m.forwarding_us, m.max_depth, m.cells_per_interface), (50.0, 275.0, 14, 80));
        assert_eq!((m.forwarding_with_control_us, m.max_depth_with_control), (375.0, 10));
        assert_eq!(m.cells_per_interface_with_control, 79);
    }
}
