//! The running simulator: a thread that owns the pty, paces the link at the
//! baud rate, feeds the personality and carries out faults; and the handle
//! tests use to watch and disturb it.
//!
//! Tests should never sleep and hope. The handle offers waits on the device's
//! own state: [`Simulator::wait_received`] (the device has taken N bytes off
//! the wire), [`Simulator::wait_idle`] (nothing on the wire, nothing buffered,
//! nothing moving), [`Simulator::wait_until`] for anything else.

use crate::config::{Personality, SimConfig};
use crate::device::{Ctx, Device, DeviceStatus};
use crate::ebb::device::EbbDevice;
use crate::export;
use crate::grbl::Grbl;
use crate::hpgl::{self, Hp};
use crate::open_watch::OpenWatch;
use crate::pty::{self, Pty};
use crate::quirks::Quirk;
use crate::record::{FaultEvent, Record};
use crate::SimError;
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::fd::{AsFd, AsRawFd, OwnedFd, RawFd};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Longest the thread sleeps with nothing due (it is woken for faults and input anyway).
const IDLE_POLL: Duration = Duration::from_millis(100);
/// Fewest bytes read per wake-up at high baud rates, so pacing does not turn
/// into one wake-up per byte: about a millisecond's worth.
const MIN_BATCH: Duration = Duration::from_millis(1);
/// Bytes of link credit an idle line may bank (a UART's FIFO, roughly).
const BURST_BYTES: u32 = 16;
/// Replies queued for a host that is not reading, beyond which they are dropped.
const MAX_OUTQ: usize = 1 << 16;
/// How long `wait_idle` must see the device idle, across thread passes,
/// before it believes it (bytes a host just wrote may take a moment to
/// cross the pty).
const IDLE_SETTLE: Duration = Duration::from_millis(20);
/// Longest fault duration accepted (unplug, stall).
pub const MAX_FAULT: Duration = Duration::from_secs(3600);

/// A snapshot of the simulator for tests and the control socket.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Status {
    /// Current pty slave path; `None` while unplugged.
    pub slave_path: Option<PathBuf>,
    /// Bytes taken off the wire (real-time and device-control bytes included).
    pub bytes_received: u64,
    /// Bytes the device has read out of its input buffer since power-on.
    pub bytes_consumed: u64,
    /// Bytes the host has written that are still on the wire (in the pty).
    pub pending_input: usize,
    /// Bytes lost to overrun so far.
    pub overruns: u64,
    /// Replies the device has sent so far (answers to queries and markers,
    /// `ok`s, status reports; not banners or alarms): each one answers
    /// something the host sent.
    pub replies: u64,
    /// Errors in the record so far.
    pub errors: usize,
    /// Stalled by a fault.
    pub stalled: bool,
    /// Connected, not stalled, nothing on the wire, device idle.
    pub idle: bool,
    /// The personality's own state.
    pub device: DeviceStatus,
    /// Passes of the simulator thread so far (changes whenever it runs).
    pub passes: u64,
}

/// A fault that needs the thread (it owns the pty).
enum Request {
    Unplug(Duration),
    /// Discard what is on the wire and in the device's receive buffer.
    LoseInput,
}

struct Inner {
    device: Box<dyn Device>,
    record: Record,
    slave_path: Option<PathBuf>,
    master_fd: Option<RawFd>,
    requests: VecDeque<Request>,
    /// Replies produced outside the thread (power-cycle banner).
    outbox: Vec<u8>,
    garble_next: bool,
    stall_until: Option<Instant>,
    speed_scale: f64,
    shutdown: bool,
    stopped: bool,
    failure: Option<String>,
    passes: u64,
}

struct Shared {
    inner: Mutex<Inner>,
    /// Notified after every thread pass, so waits re-check their condition.
    changed: Condvar,
    /// Write end of the wake-up pipe the thread polls.
    wake_tx: OwnedFd,
}

impl Inner {
    /// Acts on the device from outside the thread (a fault); its replies go
    /// out with the thread's next pass.
    fn with_device<R>(&mut self, now: Instant, f: impl FnOnce(&mut dyn Device, &mut Ctx<'_>) -> R) -> R {
        let Inner { device, record, outbox, garble_next, speed_scale, .. } = self;
        let mut ctx = Ctx { now, out: outbox, record, speed_scale: *speed_scale, garble_next };
        f(device.as_mut(), &mut ctx)
    }
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn wake(&self) {
        let _ = nix::unistd::write(&self.wake_tx, &[1]);
    }
}

/// A simulated plotter on a pty, running on its own thread until shut down
/// (or dropped).
pub struct Simulator {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    config: SimConfig,
}

impl Simulator {
    /// Opens the pty, makes the link, starts the device thread.
    ///
    /// # Errors
    /// [`SimError::Config`] for a bad configuration, [`SimError::Pty`] or
    /// [`SimError::Link`] when the pty or link cannot be made.
    pub fn start(config: SimConfig) -> Result<Simulator, SimError> {
        config.validate()?;
        let pty = Pty::open()?;
        if let Some(link) = &config.link {
            pty::make_link(link, &pty.slave_path)?;
        }
        let now = Instant::now();
        let mut outbox = Vec::new();
        let (device, record): (Box<dyn Device>, Record) = match config.personality {
            Personality::Hp7475a => {
                let hp = Hp::new(&config, now);
                let limits = Some(hp.limits());
                let model = config.model.clone().unwrap_or_else(|| "7475A".into());
                (Box::new(hp), Record::new("hp7475a", &model, hpgl::UNITS_PER_MM, limits))
            }
            Personality::Grbl => {
                let g = Grbl::new(&config, now, &mut outbox);
                let model = config.model.clone().unwrap_or_else(|| "grbl".into());
                (Box::new(g), Record::new("grbl", &model, 1.0, None))
            }
            Personality::Ebb => {
                let e = EbbDevice::new(&config, now);
                let model = config.model.clone().unwrap_or_else(|| "axidraw".into());
                // Millimetres from the home corner, x right, y up: the page lies below.
                let [w, h] = config.ebb_travel().expect("validated");
                (Box::new(e), Record::new("ebb", &model, 1.0, Some([0.0, -h, w, 0.0])))
            }
        };
        if config.has(Quirk::ResetOnOpen) {
            // No host has the port open yet: the power-up banner goes nowhere.
            outbox.clear();
        }
        let open_watch = if config.has(Quirk::ResetOnOpen) { Some(OpenWatch::new(&pty.slave_path)?) } else { None };
        let (wake_rx, wake_tx) = nix::unistd::pipe().map_err(|source| SimError::Pty { what: "pipe", source })?;
        for fd in [&wake_rx, &wake_tx] {
            set_nonblocking(fd.as_raw_fd())?;
        }
        let shared = Arc::new(Shared {
            inner: Mutex::new(Inner {
                device,
                record,
                slave_path: Some(pty.slave_path.clone()),
                master_fd: Some(pty.master.as_raw_fd()),
                requests: VecDeque::new(),
                outbox,
                garble_next: false,
                stall_until: None,
                speed_scale: config.speed_scale,
                shutdown: false,
                stopped: false,
                failure: None,
                passes: 0,
            }),
            changed: Condvar::new(),
            wake_tx,
        });
        let thread_shared = Arc::clone(&shared);
        let cfg = config.clone();
        let thread = std::thread::Builder::new()
            .name("plotsim".into())
            .spawn(move || device_thread(&thread_shared, &wake_rx, Some(pty), open_watch, &cfg))
            .map_err(|e| SimError::Unsupported(format!("cannot start the simulator thread: {e}")))?;
        Ok(Simulator { shared, thread: Some(thread), config })
    }

    /// The configuration it was started with.
    #[must_use]
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The pty slave path a host opens; `None` while unplugged.
    #[must_use]
    pub fn slave_path(&self) -> Option<PathBuf> {
        self.shared.lock().slave_path.clone()
    }

    /// A snapshot of the link and the device.
    #[must_use]
    pub fn status(&self) -> Status {
        status_of(&self.shared.lock())
    }

    /// A copy of the record so far.
    #[must_use]
    pub fn record(&self) -> Record {
        self.shared.lock().record.clone()
    }

    /// Waits until `pred` holds for a status snapshot, re-checking after every
    /// pass of the simulator thread.
    ///
    /// # Errors
    /// [`SimError::Timeout`] if it does not hold within `timeout`;
    /// [`SimError::ShutDown`] if the simulator stopped.
    pub fn wait_until(&self, timeout: Duration, mut pred: impl FnMut(&Status) -> bool) -> Result<Status, SimError> {
        let deadline = Instant::now() + timeout;
        let mut g = self.shared.lock();
        loop {
            let s = status_of(&g);
            if pred(&s) {
                return Ok(s);
            }
            if g.stopped {
                return Err(SimError::ShutDown);
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(SimError::Timeout(timeout));
            }
            g = self.shared.changed.wait_timeout(g, deadline - now).unwrap_or_else(|e| e.into_inner()).0;
        }
    }

    /// Waits until the device has taken at least `n` bytes off the wire.
    ///
    /// # Errors
    /// As [`Simulator::wait_until`].
    pub fn wait_received(&self, n: u64, timeout: Duration) -> Result<Status, SimError> {
        self.wait_until(timeout, |s| s.bytes_received >= n)
    }

    /// Waits until nothing is on the wire, the buffer is empty and nothing
    /// moves, and stays so for a short settle time over several thread passes
    /// (bytes just written by a host take a moment to cross the pty; when the
    /// count is known, [`Simulator::wait_received`] first is exact).
    ///
    /// # Errors
    /// As [`Simulator::wait_until`].
    pub fn wait_idle(&self, timeout: Duration) -> Result<Status, SimError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let s = self.wait_until(left, |s| s.idle)?;
            self.shared.wake();
            std::thread::sleep(IDLE_SETTLE);
            let again = self.status();
            if again.idle && again.bytes_received == s.bytes_received && again.passes > s.passes {
                return Ok(again);
            }
            if Instant::now() >= deadline {
                return Err(SimError::Timeout(timeout));
            }
        }
    }

    /// Waits until the pty exists (after an unplug) and returns its path.
    ///
    /// # Errors
    /// As [`Simulator::wait_until`].
    pub fn wait_connected(&self, timeout: Duration) -> Result<PathBuf, SimError> {
        let s = self.wait_until(timeout, |s| s.slave_path.is_some())?;
        Ok(s.slave_path.expect("checked"))
    }

    fn fault(&self, kind: &str, ms: Option<u64>, f: impl FnOnce(&mut Inner, Instant)) {
        let mut g = self.shared.lock();
        let at_byte = g.record.bytes_received;
        g.record.faults.push(FaultEvent { kind: kind.into(), ms, at_byte });
        f(&mut g, Instant::now());
        drop(g);
        self.shared.wake();
    }

    /// Pulls the USB adapter: the pty is closed (the host's port hangs up, the
    /// link disappears) and re-created at the same link after `down`. The
    /// plotter itself keeps its buffer and keeps plotting. Returns once the
    /// pty is closed.
    ///
    /// # Errors
    /// [`SimError::Config`] for a duration over [`MAX_FAULT`]; as
    /// [`Simulator::wait_until`] if the thread does not act.
    pub fn unplug(&self, down: Duration) -> Result<(), SimError> {
        check_duration(down)?;
        self.fault("unplug", Some(down.as_millis() as u64), |g, _| g.requests.push_back(Request::Unplug(down)));
        self.wait_until(Duration::from_secs(10), |s| s.slave_path.is_none() || down.is_zero()).map(|_| ())
    }

    /// Stops draining the buffer for `d` (bytes still arrive, and overflow).
    ///
    /// # Errors
    /// [`SimError::Config`] for a duration over [`MAX_FAULT`].
    pub fn stall(&self, d: Duration) -> Result<(), SimError> {
        check_duration(d)?;
        self.fault("stall", Some(d.as_millis() as u64), |g, now| g.stall_until = Some(now + d));
        Ok(())
    }

    /// Power off and on: buffer, handshake and modal state lost; a GRBL board
    /// prints its banner at once, with its default `$` settings, and takes
    /// its carriage to be back at the paper's origin (unlike
    /// [`Simulator::reset`]); an EBB resets (keeping its nickname) and its
    /// USB port goes and comes back new. The paper (the record) stays.
    pub fn power_cycle(&self) {
        self.fault("power-cycle", None, |g, now| {
            g.stall_until = None;
            g.with_device(now, |device, ctx| device.power_cycle(ctx));
        });
    }

    /// The device's reset. GRBL: its reset line (the reset button, or the
    /// DTR pulse of a port opening, see [`Quirk::ResetOnOpen`]): the chip
    /// restarts where the carriage stands, which becomes its zero, so what
    /// it draws after lands shifted on the paper; the `$` settings stay;
    /// input is lost for a second while the bootloader runs, then the banner
    /// (and with `$22=1` the alarm lock). HP: a plotter's only reset is its
    /// power switch, so this is [`Simulator::power_cycle`].
    pub fn reset(&self) {
        self.fault("reset", None, |g, now| {
            g.stall_until = None;
            g.with_device(now, |device, ctx| device.reset(ctx));
        });
    }

    /// GRBL: a person moves the carriage by hand to the paper's origin, the
    /// pen up; the board is not told (after a reset, its zero is then where
    /// the host means it again).
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for an HP plotter (its motors hold the
    /// carriage) or while the carriage moves.
    pub fn park(&self) -> Result<(), SimError> {
        let mut res = Ok(());
        self.fault("park", None, |g, now| {
            res = g.with_device(now, |device, ctx| device.park(ctx)).map_err(SimError::Unsupported);
        });
        res
    }

    /// Raises or lowers the paper lever (HP): raised, plotting pauses and
    /// `ESC.O` reports 32.
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for a GRBL board.
    pub fn lever(&self, up: bool) -> Result<(), SimError> {
        let mut res = Ok(());
        self.fault(if up { "lever up" } else { "lever down" }, None, |g, _| {
            res = g.device.set_lever(up).map_err(SimError::Unsupported);
        });
        res
    }

    /// GRBL: raises `ALARM:code` (1: hard limit) mid-job: motion stops,
    /// everything received and planned is dropped, the pen lifts, and the
    /// board is locked until `$X`.
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for an HP plotter or an alarm number GRBL
    /// does not have.
    pub fn alarm(&self, code: u32) -> Result<(), SimError> {
        let mut res = Ok(());
        self.fault("alarm", Some(u64::from(code)), |g, now| {
            res = g.with_device(now, |device, ctx| device.alarm(code, ctx)).map_err(SimError::Unsupported);
        });
        res
    }

    /// GRBL: the lines in the receive buffer and those still on the wire are
    /// lost unanswered; the board finishes what it planned and reports
    /// `Idle` with the host's lines in flight (a stall).
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for an HP plotter.
    pub fn lose_input(&self) -> Result<(), SimError> {
        if self.config().personality != crate::Personality::Grbl {
            return Err(SimError::Unsupported("losing lines unanswered is a GRBL fault".into()));
        }
        self.fault("lose-input", None, |g, _| g.requests.push_back(Request::LoseInput));
        Ok(())
    }

    /// EBB: the motor supply (V+) fails, for `lasting` or until
    /// [`Simulator::power_restore`]. The board stays on USB and answers; the
    /// motors hold nothing and lose the steps they are sent, the pen servo
    /// goes limp, `QC` reads 0 and 3.x sets bit 6 of `QG` (with `CU,60`).
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for other personalities; [`SimError::Config`]
    /// for a duration over [`MAX_FAULT`].
    pub fn power_loss(&self, lasting: Option<Duration>) -> Result<(), SimError> {
        if let Some(d) = lasting {
            check_duration(d)?;
        }
        let mut res = Ok(());
        self.fault("power-loss", lasting.map(|d| d.as_millis() as u64), |g, now| {
            let Inner { device, record, outbox, garble_next, speed_scale, .. } = g;
            let mut ctx = Ctx { now, out: outbox, record, speed_scale: *speed_scale, garble_next };
            res = device.power_loss(lasting, &mut ctx).map_err(SimError::Unsupported);
        });
        res
    }

    /// EBB: the motor supply comes back (each motor jumps to its driver's phase).
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for other personalities.
    pub fn power_restore(&self) -> Result<(), SimError> {
        let mut res = Ok(());
        self.fault("power-restore", None, |g, now| {
            let Inner { device, record, outbox, garble_next, speed_scale, .. } = g;
            let mut ctx = Ctx { now, out: outbox, record, speed_scale: *speed_scale, garble_next };
            res = device.power_restore(&mut ctx).map_err(SimError::Unsupported);
        });
        res
    }

    /// EBB: someone presses the PRG button (`QB` and bit 5 of `QG` latch it).
    ///
    /// # Errors
    /// [`SimError::Unsupported`] for other personalities.
    pub fn button(&self) -> Result<(), SimError> {
        let mut res = Ok(());
        self.fault("button", None, |g, _| res = g.device.press_button().map_err(SimError::Unsupported));
        res
    }

    /// The next reply (answer to a query, `ok`, status report) is noise.
    pub fn garbage(&self) {
        self.fault("garbage", None, |g, _| g.garble_next = true);
    }

    /// The next instruction of the job fails with `code` (HP-GL OE number or
    /// GRBL `error:N`), or with the personality's usual one; HP output
    /// instructions (the host's own `OI`, `OE`, `OA`) pass it by.
    pub fn fail_next(&self, code: Option<u32>) {
        self.fault("error", code.map(u64::from), |g, _| g.device.fail_next(code));
    }

    /// Writes the record as JSON and/or the SVG and/or PNG picture.
    ///
    /// # Errors
    /// [`SimError::Write`] or [`SimError::Png`] naming the file.
    pub fn save(&self, json: Option<&Path>, svg: Option<&Path>, png: Option<&Path>) -> Result<(), SimError> {
        let r = self.record();
        if let Some(p) = json {
            export::save_json(&r, p)?;
        }
        if let Some(p) = svg {
            export::save_svg(&r, p)?;
        }
        if let Some(p) = png {
            export::save_png(&r, p, 1600)?;
        }
        Ok(())
    }

    /// Stops the thread, closes the pty, removes the link; returns the record.
    ///
    /// # Errors
    /// [`SimError::Unsupported`] carrying the thread's failure if it died.
    pub fn shutdown(mut self) -> Result<Record, SimError> {
        self.stop();
        let g = self.shared.lock();
        match &g.failure {
            Some(f) => Err(SimError::Unsupported(f.clone())),
            None => Ok(g.record.clone()),
        }
    }

    fn stop(&mut self) {
        self.shared.lock().shutdown = true;
        self.shared.wake();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Simulator {
    fn drop(&mut self) {
        self.stop();
    }
}

fn check_duration(d: Duration) -> Result<(), SimError> {
    if d > MAX_FAULT {
        return Err(SimError::Config { field: "duration", why: format!("{d:?} is longer than {MAX_FAULT:?}") });
    }
    Ok(())
}

fn set_nonblocking(fd: RawFd) -> Result<(), SimError> {
    use nix::fcntl::{fcntl, FcntlArg, OFlag};
    let flags = fcntl(fd, FcntlArg::F_GETFL).map_err(|source| SimError::Pty { what: "fcntl", source })?;
    fcntl(fd, FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK))
        .map_err(|source| SimError::Pty { what: "fcntl", source })?;
    Ok(())
}

fn status_of(g: &Inner) -> Status {
    let now = Instant::now();
    // The fd is the live master: the thread clears `master_fd` under the
    // lock before it closes it.
    let pending_input = g.master_fd.map_or(0, pty::pending_on);
    let stalled = g.stall_until.is_some_and(|t| t > now);
    let device = g.device.status();
    Status {
        slave_path: g.slave_path.clone(),
        bytes_received: g.record.bytes_received,
        bytes_consumed: g.device.consumed(),
        pending_input,
        overruns: g.record.overruns,
        replies: g.record.replies,
        errors: g.record.errors.len(),
        stalled,
        idle: g.slave_path.is_some() && !stalled && pending_input == 0 && g.outbox.is_empty() && device.idle,
        device,
        passes: g.passes,
    }
}

/// What holds back the bytes the host has written, and so what the device
/// thread waits for before it reads again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Holdup {
    /// Nothing is pending: wait for the host to write.
    Input,
    /// The link's baud rate: wait for the next batch the wire carries.
    Wire,
    /// The device has no room: wait for it to make some (its next event).
    /// Polling the pty here would wake at once, since it stays readable.
    Room,
}

/// Link pacing: when the next byte may come off the wire.
struct Wire {
    byte_time: Option<Duration>,
    clock: Instant,
}

impl Wire {
    /// Bytes that may be read now (at most `max`).
    fn credit(&mut self, now: Instant, max: usize) -> usize {
        let Some(bt) = self.byte_time else { return max };
        let floor = now.checked_sub(bt * BURST_BYTES).unwrap_or(now);
        if self.clock < floor {
            self.clock = floor;
        }
        let n = now.saturating_duration_since(self.clock).as_nanos() / bt.as_nanos().max(1);
        (n as usize).min(max)
    }

    fn took(&mut self, n: usize) {
        if let Some(bt) = self.byte_time {
            self.clock += bt * n as u32;
        }
    }

    /// When a worthwhile batch of bytes may be read.
    fn next_batch(&self) -> Instant {
        let bt = self.byte_time.unwrap_or(Duration::ZERO);
        let batch = if bt.is_zero() { 1 } else { (MIN_BATCH.as_nanos() / bt.as_nanos()).max(1) as u32 };
        self.clock + bt * batch
    }
}

fn device_thread(shared: &Shared, wake_rx: &OwnedFd, mut pty: Option<Pty>, mut open_watch: Option<OpenWatch>, cfg: &SimConfig) {
    let mut wire = Wire { byte_time: (cfg.baud > 0).then(|| Duration::from_secs_f64(10.0 / f64::from(cfg.baud))), clock: Instant::now() };
    let mut buf = vec![0u8; 4096];
    let mut out = Vec::new();
    let mut outq: VecDeque<u8> = VecDeque::new();
    let mut replug_at: Option<Instant> = None;
    let mut next_due: Option<Instant> = None;
    let mut holdup = Holdup::Input;
    loop {
        // Sleep until input, a wake-up, or the next thing due.
        let now = Instant::now();
        let mut deadline = now + IDLE_POLL;
        for t in [next_due, replug_at].into_iter().flatten() {
            deadline = deadline.min(t);
        }
        if !outq.is_empty() {
            deadline = deadline.min(now + Duration::from_millis(5));
        }
        if holdup == Holdup::Wire {
            deadline = deadline.min(wire.next_batch());
        }
        // poll counts whole milliseconds: rounding a wait of 0.9 ms down to
        // 0 would spin until it is due (the board comes back every 1 ms).
        let wait_ms = deadline.saturating_duration_since(now).as_micros().div_ceil(1000);
        let timeout = PollTimeout::try_from(wait_ms).unwrap_or(PollTimeout::MAX);
        {
            let mut fds = vec![PollFd::new(wake_rx.as_fd(), PollFlags::POLLIN)];
            if let Some(w) = &open_watch {
                fds.push(PollFd::new(w.fd(), PollFlags::POLLIN));
            }
            if let (Some(p), Holdup::Input) = (&pty, holdup) {
                fds.push(PollFd::new(p.master.as_fd(), PollFlags::POLLIN));
            }
            let _ = poll(&mut fds, timeout);
        }
        let mut sink = [0u8; 64];
        while matches!(nix::unistd::read(wake_rx.as_raw_fd(), &mut sink), Ok(n) if n > 0) {}

        let mut g = shared.lock();
        if g.shutdown {
            g.master_fd = None;
            drop(pty.take());
            if let Some(link) = &cfg.link {
                pty::remove_link(link);
            }
            g.stopped = true;
            drop(g);
            shared.changed.notify_all();
            return;
        }
        let now = Instant::now();
        // A USB device that reset leaves the bus and comes back.
        if let Some(d) = g.device.take_reenumeration() {
            g.requests.push_back(Request::Unplug(d));
        }
        while let Some(req) = g.requests.pop_front() {
            match req {
                Request::Unplug(d) if !d.is_zero() => {
                    g.master_fd = None;
                    g.slave_path = None;
                    drop(pty.take());
                    outq.clear();
                    if let Some(link) = &cfg.link {
                        pty::remove_link(link);
                    }
                    replug_at = Some(now + d);
                }
                Request::Unplug(_) => {}
                Request::LoseInput => {
                    // The bytes on their way are lost with the buffer. A
                    // pty may still hand over the rest of a line later; the
                    // device drops it as part of the line it lost.
                    if let Some(p) = pty.as_mut() {
                        let mut sink = [0u8; 4096];
                        while matches!(p.master.read(&mut sink), Ok(n) if n > 0) {}
                    }
                    if let Err(e) = g.device.lose_input() {
                        g.failure = Some(e);
                    }
                }
            }
        }
        if replug_at.is_some_and(|t| t <= now) {
            match Pty::open().and_then(|p| {
                if let Some(link) = &cfg.link {
                    pty::make_link(link, &p.slave_path)?;
                }
                Ok(p)
            }) {
                Ok(p) => {
                    if let Some(Err(e)) = open_watch.as_mut().map(|w| w.watch(&p.slave_path)) {
                        g.failure = Some(e.to_string());
                    }
                    g.slave_path = Some(p.slave_path.clone());
                    g.master_fd = Some(p.master.as_raw_fd());
                    pty = Some(p);
                    replug_at = None;
                    wire.clock = now;
                }
                Err(e) => {
                    // Try again shortly; the failure is visible in the status.
                    g.failure = Some(e.to_string());
                    replug_at = Some(now + Duration::from_millis(100));
                }
            }
        }

        let inner = &mut *g;
        let mut ctx =
            Ctx { now, out: &mut out, record: &mut inner.record, speed_scale: inner.speed_scale, garble_next: &mut inner.garble_next };
        // Take the bytes the wire has carried since the last pass.
        let mut got = 0;
        let mut held_back = false;
        if let Some(p) = pty.as_mut() {
            // A USB device takes no more than it has room for; the rest waits in the pty.
            let allowed = wire.credit(now, buf.len()).min(inner.device.rx_space());
            if allowed > 0 {
                match p.master.read(&mut buf[..allowed]) {
                    Ok(n) => {
                        wire.took(n);
                        got = n;
                    }
                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                    // EIO when no host has the slave open on some kernels: nothing to read.
                    Err(_) => {}
                }
            }
            held_back = got == allowed && p.pending() > 0;
        }
        // A host opened the port: the board resets. The open came before any
        // byte it wrote, so the bytes just read follow it (checked after the
        // read so that none slips in between).
        // (Read the events even while unplugged: the old slave's watch
        // reports its end.)
        let opened = open_watch.as_mut().is_some_and(OpenWatch::opened);
        if let (true, Some(p)) = (opened, pty.as_ref()) {
            // What the board said while the port was closed is lost.
            p.discard_unread();
            outq.clear();
            inner.outbox.clear();
            ctx.out.clear();
            inner.stall_until = None;
            ctx.record.faults.push(FaultEvent { kind: "reset-on-open".into(), ms: None, at_byte: ctx.record.bytes_received });
            inner.device.reset(&mut ctx);
        }
        for &b in &buf[..got] {
            ctx.record.bytes_received += 1;
            inner.device.receive(b, &mut ctx);
        }
        let stalled = inner.stall_until.is_some_and(|t| t > now);
        next_due = if stalled { inner.stall_until } else { inner.device.run(&mut ctx) };
        if !stalled {
            inner.stall_until = None;
        }
        // (Room is judged after the device ran: running may have made some.)
        holdup = match (held_back, inner.device.rx_space()) {
            (false, _) => Holdup::Input,
            (true, 0) => Holdup::Room,
            (true, _) => Holdup::Wire,
        };
        outq.extend(inner.outbox.drain(..));
        outq.extend(out.drain(..));
        if let Some(p) = pty.as_mut() {
            while !outq.is_empty() {
                let (a, _) = outq.as_slices();
                match p.master.write(a) {
                    Ok(0) => break,
                    Ok(n) => {
                        outq.drain(..n);
                    }
                    Err(_) => break,
                }
            }
        } else {
            // Unplugged: replies go nowhere.
            outq.clear();
        }
        if outq.len() > MAX_OUTQ {
            let excess = outq.len() - MAX_OUTQ;
            outq.drain(..excess);
        }
        inner.passes += 1;
        drop(g);
        shared.changed.notify_all();
    }
}
