//! QEMU processes, one per cell, and the guard that ends them all.

use std::ffi::OsString;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use skin_protocol::message::Port;

use super::hex::Wiring;
use super::{Context, QemuError};

/// The QEMU program and the board every cell runs on.
pub const QEMU: &str = "qemu-system-arm";
const BOARD: [&str; 10] = [
    "-cpu",
    "cortex-m4",
    "-machine",
    "mps2-an386",
    "-display",
    "none",
    "-monitor",
    "none",
    "-semihosting-config",
    "enable=on,target=native",
];

/// What a cell's UART is joined to.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Uart {
    /// Nothing: bytes sent are lost.
    #[default]
    Free,
    /// Listens on this socket for the neighbour (the lower end of a link).
    Listen(PathBuf),
    /// Connects to this socket, retrying every second (the upper end of a
    /// link: the neighbour may not be up yet, or may restart).
    Dial(PathBuf),
    /// Connects at once to a socket the harness listens on.
    Harness(PathBuf),
}

impl Uart {
    fn chardev(&self, id: &str) -> Option<String> {
        let path = |p: &Path| p.display().to_string();
        match self {
            Uart::Free => None,
            Uart::Listen(p) => Some(format!("socket,id={id},path={},server=on,wait=off", path(p))),
            Uart::Dial(p) => Some(format!("socket,id={id},path={},reconnect=1", path(p))),
            Uart::Harness(p) => Some(format!("socket,id={id},path={}", path(p))),
        }
    }
}

/// The QEMU command line of one cell.
#[derive(Clone, Debug)]
pub struct CellCommand {
    args: Vec<OsString>,
}

impl CellCommand {
    /// A cell starting with `bootloader`, keeping its flash (store, boot
    /// record, image slots) in the file `flash`, with UART0..UART4 joined
    /// as given.
    pub fn new(bootloader: &Path, flash: &Path, uarts: [Uart; 5]) -> CellCommand {
        let mut args: Vec<OsString> = BOARD.iter().map(OsString::from).collect();
        args.extend([
            "-kernel".into(),
            bootloader.into(),
            "-append".into(),
            format!("flash={}", flash.display()).into(),
        ]);
        for (i, uart) in uarts.iter().enumerate() {
            let id = format!("uart{i}");
            match uart.chardev(&id) {
                Some(dev) => {
                    args.extend(["-chardev".into(), dev.into(), "-serial".into(), format!("chardev:{id}").into()])
                }
                None => args.extend(["-serial".into(), "null".into()]),
            }
        }
        CellCommand { args }
    }

    /// A program alone, its UARTs joined to nothing, with `extra` QEMU
    /// arguments (fault tests, `-icount` measurements).
    pub fn alone(elf: &Path, extra: &[&str]) -> CellCommand {
        let mut args: Vec<OsString> = BOARD.iter().map(OsString::from).collect();
        args.extend(["-kernel".into(), elf.into()]);
        args.extend((0..5).flat_map(|_| ["-serial".into(), "null".into()]));
        args.extend(extra.iter().map(OsString::from));
        CellCommand { args }
    }

    fn spawn(&self, stdout: File, stderr: File) -> Result<Child, QemuError> {
        Command::new(QEMU)
            .args(&self.args)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .map_err(|source| QemuError::Spawn { program: QEMU.into(), source })
    }
}

/// The UART plan of every cell of a wired patch: links as socket pairs in
/// `dir`, UART0 to the harness's stimulus socket, and the interface port
/// to the gateway's socket.
pub fn plan(wiring: &Wiring, interface: (usize, Port), dir: &Path) -> Vec<[Uart; 5]> {
    let mut uarts: Vec<[Uart; 5]> = (0..wiring.cells())
        .map(|i| {
            let mut u: [Uart; 5] = Default::default();
            u[0] = Uart::Harness(stimulus_socket(dir, i));
            u
        })
        .collect();
    for (k, (a, b)) in wiring.links().into_iter().enumerate() {
        let path = dir.join(format!("link{k}.sock"));
        uarts[a.0][1 + a.1.index()] = Uart::Listen(path.clone());
        uarts[b.0][1 + b.1.index()] = Uart::Dial(path);
    }
    uarts[interface.0][1 + interface.1.index()] = Uart::Harness(gateway_socket(dir));
    uarts
}

/// The socket the harness sends cell `i`'s stimulus on.
pub fn stimulus_socket(dir: &Path, i: usize) -> PathBuf {
    dir.join(format!("stimulus{i}.sock"))
}

/// The socket of the interface port.
pub fn gateway_socket(dir: &Path) -> PathBuf {
    dir.join("gateway.sock")
}

/// The stack use a cell measured: its cortex-m-rt-painted stack's
/// high-water mark, and what the memory layout reserves for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct StackUse {
    /// The deepest the stack has been, in bytes.
    pub peak_bytes: usize,
    /// Bytes the memory layout reserves for the stack.
    pub reserved_bytes: usize,
}

impl StackUse {
    /// The largest peak in a cell's QEMU log, where the firmware writes
    /// `stack peak N bytes of R reserved` whenever its peak grows.
    pub fn parse(log: &str) -> Option<StackUse> {
        log.lines()
            .filter_map(|line| {
                let rest = line.strip_prefix("stack peak ")?;
                let (peak, rest) = rest.split_once(" bytes of ")?;
                let reserved = rest.strip_suffix(" reserved")?;
                Some(StackUse { peak_bytes: peak.parse().ok()?, reserved_bytes: reserved.parse().ok()? })
            })
            .max_by_key(|s| s.peak_bytes)
    }
}

/// Processor time of QEMU processes, from the scheduler's statistics of
/// each of their threads (Linux `/proc/PID/task/TID/schedstat`).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CpuUse {
    /// Seconds on a CPU.
    pub run_s: f64,
    /// Seconds runnable but waiting for a CPU: the cells' clocks ran on
    /// while their code did not.
    pub wait_s: f64,
}

impl CpuUse {
    /// The use of process `pid` so far; `None` where `/proc` does not tell.
    fn of(pid: u32) -> Option<CpuUse> {
        let mut total = CpuUse::default();
        for task in std::fs::read_dir(format!("/proc/{pid}/task")).ok()?.flatten() {
            let stat = std::fs::read_to_string(task.path().join("schedstat")).ok()?;
            let mut fields = stat.split_whitespace().map(|f| f.parse::<u64>().ok());
            let (Some(Some(run_ns)), Some(Some(wait_ns))) = (fields.next(), fields.next()) else { return None };
            total.run_s += run_ns as f64 * 1e-9;
            total.wait_s += wait_ns as f64 * 1e-9;
        }
        Some(total)
    }
}

/// Running cells. Dropping this kills every QEMU it started, so no process
/// outlives the harness, whether it ends by success, error or panic.
#[derive(Debug)]
pub struct Cells {
    dir: PathBuf,
    commands: Vec<CellCommand>,
    children: Vec<Option<Child>>,
    /// Processor time of the cells killed so far.
    cpu: CpuUse,
}

impl Cells {
    /// Cells not yet started; their logs go to `dir`.
    pub fn new(dir: &Path, commands: Vec<CellCommand>) -> Cells {
        let children = commands.iter().map(|_| None).collect();
        Cells { dir: dir.to_owned(), commands, children, cpu: CpuUse::default() }
    }

    /// The defmt log (QEMU's stdout) of cell `i`, appended across restarts.
    pub fn defmt_log(&self, i: usize) -> PathBuf {
        self.dir.join(format!("cell{i}.defmt"))
    }

    /// QEMU's own messages for cell `i`.
    pub fn qemu_log(&self, i: usize) -> PathBuf {
        self.dir.join(format!("cell{i}.log"))
    }

    /// The stack use cell `i` reported in its QEMU log so far (across restarts).
    pub fn stack_use(&self, i: usize) -> Option<StackUse> {
        std::fs::read_to_string(self.qemu_log(i)).ok().as_deref().and_then(StackUse::parse)
    }

    /// Starts cell `i`.
    pub fn start(&mut self, i: usize) -> Result<(), QemuError> {
        let append = |p: PathBuf| {
            OpenOptions::new().create(true).append(true).open(&p).context(|| format!("opening {}", p.display()))
        };
        let child = self.commands[i].spawn(append(self.defmt_log(i))?, append(self.qemu_log(i))?)?;
        tracing::debug!(cell = i, pid = child.id(), "started");
        self.children[i] = Some(child);
        Ok(())
    }

    /// Kills cell `i` (a power cut: no goodbye on any wire).
    pub fn kill(&mut self, i: usize) {
        if let Some(mut child) = self.children[i].take() {
            if let Some(cpu) = CpuUse::of(child.id()) {
                self.cpu.run_s += cpu.run_s;
                self.cpu.wait_s += cpu.wait_s;
            }
            let _ = child.kill();
            let _ = child.wait();
            tracing::debug!(cell = i, "killed");
        }
    }

    /// Kills every cell; returns the processor time they all took since
    /// they were started.
    pub fn stop(mut self) -> CpuUse {
        for i in 0..self.children.len() {
            self.kill(i);
        }
        self.cpu
    }

    /// An error for the first running cell that exited on its own.
    pub fn check_alive(&mut self) -> Result<(), QemuError> {
        for (i, slot) in self.children.iter_mut().enumerate() {
            if let Some(child) = slot {
                if let Ok(Some(status)) = child.try_wait() {
                    *slot = None;
                    return Err(QemuError::CellExited { cell: i, status, log: self.dir.join(format!("cell{i}.log")) });
                }
            }
        }
        Ok(())
    }
}

impl Drop for Cells {
    fn drop(&mut self) {
        for i in 0..self.children.len() {
            self.kill(i);
        }
    }
}

/// How a program run alone ended.
#[derive(Debug)]
pub struct Alone {
    /// Its exit status; `None` when it outlived the limit and was killed.
    pub status: Option<ExitStatus>,
    /// What it wrote to semihosting's stdout (QEMU's stdout).
    pub stdout: Vec<u8>,
}

/// Runs a program alone, with `extra` QEMU arguments, until it exits or
/// `limit` passes (then it is killed).
pub fn run_alone(elf: &Path, extra: &[&str], limit: Duration) -> Result<Alone, QemuError> {
    if !elf.is_file() {
        return Err(QemuError::MissingElf(elf.to_owned()));
    }
    let stdout = tempfile()?;
    let mut child = CellCommand::alone(elf, extra).spawn(
        stdout.try_clone().context(|| "duplicating the output file".into())?,
        File::create("/dev/null").context(|| "opening /dev/null".into())?,
    )?;
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().context(|| "waiting for QEMU".into())? {
            break Some(status);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut out = Vec::new();
    let mut stdout = stdout;
    stdout
        .seek(SeekFrom::Start(0))
        .and_then(|_| stdout.read_to_end(&mut out))
        .context(|| "reading QEMU's output".into())?;
    Ok(Alone { status, stdout: out })
}

/// A temporary file for a program's output, its name removed at once.
fn tempfile() -> Result<File, QemuError> {
    let stamp = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let path = std::env::temp_dir().join(format!("skin-qemu-alone-{}-{stamp}.out", std::process::id()));
    let file = OpenOptions::new()
        .create_new(true)
        .read(true)
        .write(true)
        .open(&path)
        .context(|| format!("creating {}", path.display()))?;
    let _ = std::fs::remove_file(&path);
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_stack_peak_of_a_log_is_found() {
        let log = "qemu-system-arm: terminating\nstack peak 1200 bytes of 4096 reserved\nstack peak 2400 bytes of 4096 reserved\nstack peak x bytes of 4096 reserved\n";
        assert_eq!(StackUse::parse(log), Some(StackUse { peak_bytes: 2400, reserved_bytes: 4096 }));
        assert_eq!(StackUse::parse("no report"), None);
    }
}
