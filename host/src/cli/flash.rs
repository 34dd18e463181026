//! `skin flash`: a signed image into every cell of the skin, through the
//! interface ports (see [`skin_protocol::update`]), with a progress bar per
//! interface port and a result table; exit 1 unless every cell ends on the
//! image's version.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use skin_host::config::InterfaceConfig;
use skin_host::interface::{EventKind, Interface};
use skin_protocol::update::{Distributor, Outcome, Outgoing};
use skin_protocol::Address;

use super::seconds;

/// Arguments of `skin flash`.
#[derive(clap::Args)]
pub struct Args {
    /// The signed image (`skin sign`, `cargo xtask image`).
    #[arg(long, value_name = "FILE")]
    image: PathBuf,
    /// Address to listen on for the skin's interface ports.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7700")]
    interface: SocketAddr,
    /// Interface ports of the skin (numbered 0..N).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(1..=254))]
    ports: u8,
    /// Cells to update: wait until that many are heard [default: those heard within --listen].
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=super::MAX_CELLS))]
    cells: Option<usize>,
    /// Time to listen for cells before starting, s.
    #[arg(long, default_value_t = 2.0)]
    listen: f64,
    /// Longest time the update may take, s.
    #[arg(long, default_value_t = 60.0)]
    timeout: f64,
    /// Frames sent into each interface port per millisecond.
    #[arg(long, default_value_t = 16, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    rate: usize,
    /// Print the result table as JSON.
    #[arg(long)]
    json: bool,
}

/// A cell's outcome as the result table says it.
fn outcome_name(o: Outcome) -> String {
    match o {
        Outcome::Updated => "updated".into(),
        Outcome::RolledBack => "rolled back".into(),
        Outcome::Refused(why) => format!("refused: {}", refusal_name(why)),
        Outcome::NotHeard => "not heard".into(),
        Outcome::Unfinished(state) => format!("unfinished: {state:?}").to_lowercase(),
    }
}

fn refusal_name(r: skin_protocol::message::Refusal) -> &'static str {
    use skin_protocol::message::Refusal::*;
    match r {
        BadHeader => "bad header",
        BadSignature => "bad signature",
        WrongBoard => "wrong board",
        TooLong => "too long",
        BadBody => "bad body",
        SlotFailed => "slot failed",
    }
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let listen = seconds::duration("--listen", args.listen)?;
    let timeout = seconds::duration("--timeout", args.timeout)?;
    let image = skin_host::update::read(&args.image)?;
    let config = InterfaceConfig {
        listen: args.interface,
        ports: (0..args.ports).map(|number| skin_host::config::PortConfig { number, address: None }).collect(),
        ..InterfaceConfig::default()
    };
    let mut interface = Interface::bind(&config)?;
    let mut events = Vec::new();

    // Who is there: the cells heard while listening.
    let start = Instant::now();
    while start.elapsed() < listen
        || args.cells.is_some_and(|n| interface.registry().len() < n && start.elapsed() < timeout)
    {
        interface.poll(Duration::from_millis(5), &mut events)?;
        events.clear();
    }
    let cells: BTreeMap<Address, u8> = interface.registry().cells().map(|c| (c.id(), c.interface())).collect();
    if cells.is_empty() {
        return Err(format!(
            "no cell heard on {} within {} s: is the skin on and sending there?",
            args.interface, args.listen
        )
        .into());
    }
    let mut distributor = Distributor::new(&image, cells.keys().copied())
        .map_err(|source| skin_host::update::Error::Image { path: args.image.clone(), source })?;

    let bars = MultiProgress::new();
    let style = ProgressStyle::with_template("port {prefix}: [{bar:30}] {pos}/{len} cells {msg}")
        .map_err(|e| e.to_string())?
        .progress_chars("=> ");
    let port_bars: BTreeMap<u8, ProgressBar> = (0..args.ports)
        .map(|k| {
            let n = cells.values().filter(|p| **p == k).count() as u64;
            let bar = bars.add(ProgressBar::new(n).with_style(style.clone()).with_prefix(k.to_string()));
            (k, bar)
        })
        .collect();

    let started = Instant::now();
    let mut last_send = Instant::now();
    while started.elapsed() < timeout && !distributor.finished() {
        let now_us = started.elapsed().as_micros() as u64;
        // The rate per millisecond, for the time since the last send.
        let budget = (last_send.elapsed().as_micros() as usize * args.rate / 1000).clamp(1, 72);
        last_send = Instant::now();
        let batch: Vec<Outgoing> = std::iter::from_fn(|| distributor.next(now_us)).take(budget).collect();
        // Consecutive frames one way to one destination go in one datagram.
        for group in batch.chunk_by(|a, b| (a.via, a.to) == (b.via, b.to)) {
            let messages: Vec<_> = group.iter().map(|o| o.message).collect();
            interface.send_update(group[0].via, group[0].to, &messages)?;
        }
        interface.poll(Duration::from_millis(1), &mut events)?;
        for e in events.drain(..) {
            if let EventKind::UpdateReport(r) = e.kind {
                distributor.handle(e.cell, e.interface, r);
            }
        }
        let outcomes: Vec<(Address, Outcome)> = distributor.outcomes().collect();
        for (k, bar) in &port_bars {
            let done = outcomes.iter().filter(|(a, o)| cells.get(a) == Some(k) && o.is_final()).count();
            bar.set_position(done as u64);
            bar.set_message(format!(
                "({} of {} chunks broadcast)",
                distributor.broadcast_sent(),
                distributor.chunk_count()
            ));
        }
    }
    port_bars.values().for_each(ProgressBar::finish);

    let outcomes: Vec<(Address, Outcome)> = distributor.outcomes().collect();
    let all_updated = outcomes.iter().all(|(_, o)| o.is_updated()) && args.cells.is_none_or(|n| outcomes.len() >= n);
    if args.json {
        let rows: Vec<serde_json::Value> = outcomes
            .iter()
            .map(|(a, o)| serde_json::json!({ "cell": a.0, "port": cells.get(a), "result": outcome_name(*o) }))
            .collect();
        println!("{}", serde_json::json!({ "version": distributor.version(), "cells": rows }));
    } else {
        println!("cell  port  result (version {})", distributor.version());
        for (a, o) in &outcomes {
            println!("{:>4}  {:>4}  {}", a.0, cells.get(a).map_or("-".into(), |p| p.to_string()), outcome_name(*o));
        }
        let mut tally: BTreeMap<String, usize> = BTreeMap::new();
        outcomes.iter().for_each(|(_, o)| *tally.entry(outcome_name(*o)).or_default() += 1);
        let summary: Vec<String> = tally.iter().map(|(k, n)| format!("{n} {k}")).collect();
        println!("{} cells: {} in {:.1} s", outcomes.len(), summary.join(", "), started.elapsed().as_secs_f64());
    }
    Ok(if all_updated { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}
