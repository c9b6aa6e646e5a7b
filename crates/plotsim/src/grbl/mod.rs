//! The GRBL 1.1 personality: a 128-byte receive buffer that loses bytes when
//! overrun, real-time bytes picked off on arrival, 80-byte lines, a planner of
//! 16 blocks drained at feed rate, `ok` / `error:N` per line.
//!
//! Reference: GRBL 1.1 `doc/markdown/interface.md` (streaming with character
//! counting: `ok` is sent once a line has left the receive buffer and been
//! planned; real-time `?`, `!`, `~`, 0x18 never enter the buffer; extended
//! bytes 0x80-0xFF are real-time or dropped), `protocol.c` (line cleaning:
//! whitespace and control bytes dropped, `(...)` and `;` comments removed,
//! lower case upper-cased, a line of 80 or more characters answers
//! `error:11`, an empty line answers `ok`), `serial.c` (a full receive buffer
//! drops the byte). Spindle changes synchronise the planner (non-laser mode).
//! Homing and the power-up lock: `main.c` (HOMING_INIT_LOCK: with `$22=1`
//! the board powers up, or comes back from its reset line, in the alarm
//! state, and `protocol.c` says `[MSG:'$H'|'$X' to unlock]` after the
//! banner), `system.c` (`$H` in the idle or alarm state, error 5 without
//! `$22`, error 8 otherwise; `$X` answers `[MSG:Caution: Unlocked]`),
//! `limits.c` (the machine position after homing).
//!
//! The record is in the paper's frame: the machine frame the board had at
//! its first power-up, which is also its homed frame. A reset zeroes the
//! board where the carriage stands, so what it draws after lands shifted on
//! the paper, as on the real machine, until `$H` finds the switches again.

pub(crate) mod gcode;
pub(crate) mod reports;

use crate::config::{GrblPen, SimConfig};
use crate::device::{Ctx, Device, DeviceStatus};
use crate::quirks::Quirk;
use gcode::{Modal, Planned};
use reports::Settings;
use std::collections::VecDeque;
use std::time::{Duration, Instant};
use strokes::MotionModel;

/// GRBL's line buffer: lines of this many characters or more are refused.
pub const LINE_BUFFER: usize = 80;
/// How far behind "now" a new block may start (see the HP personality).
const CATCH_UP: Duration = Duration::from_millis(5);
const CRLF: &[u8] = b"\r\n";

/// A planned motion (or a dwell, which has no motion).
#[derive(Clone, Debug, PartialEq)]
struct Block {
    from: [f64; 3],
    to: [f64; 3],
    pen_down: bool,
    tool: u32,
    feed: f64,
    sim_seconds: f64,
    /// The homing cycle: at its end the machine position is set to the home
    /// position (see [`Grbl::home_position`]).
    homing: bool,
}

/// The block being executed.
#[derive(Clone, Debug)]
struct Exec {
    block: Block,
    total: Duration,
    /// Wall time left as of `resumed` (a feed hold stops the clock).
    remaining: Duration,
    resumed: Instant,
}

/// What a line still has to do, in order.
#[derive(Clone, Debug, PartialEq)]
enum Action {
    Block(Block),
    Spindle {
        on: bool,
        s: f64,
    },
    Dwell(f64),
    /// M0: hold once the planner is empty, as a feed hold, until `~`.
    Pause,
    Reply(String),
    /// `$C` leaving check mode and `0x18`: a soft reset after the reply.
    Reset,
    /// `$H`: the homing cycle, once the planner is empty; nothing after it
    /// runs (or is answered) until it is done.
    Home,
}

/// Comment state while assembling a line.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Comment {
    None,
    Paren,
    Semicolon,
}

/// A simulated GRBL board.
/// Time the board ignores serial input after power comes back (the
/// bootloader's wait; longer on real Arduinos, enough here for the bytes that
/// were on the wire at the cut to arrive and be lost).
const BOOT: std::time::Duration = std::time::Duration::from_millis(100);
/// Time an Arduino's bootloader (optiboot) waits after its reset line was
/// pulled, before GRBL starts and prints its banner; serial input meanwhile
/// goes to the bootloader and is lost. (At power-up optiboot starts the
/// application at once.)
pub(crate) const RESET_BOOT: Duration = Duration::from_secs(1);

pub(crate) struct Grbl {
    /// After a power loss the board's bootloader runs and serial input is
    /// lost until then: bytes that were on the way do not run.
    booting_until: Option<std::time::Instant>,
    model: String,
    capacity: usize,
    rx: VecDeque<u8>,
    line: Vec<u8>,
    line_overflow: bool,
    comment: Comment,
    pending: VecDeque<Action>,
    planner: VecDeque<Block>,
    planner_cap: usize,
    exec: Option<Exec>,
    /// When the last block ended (so back-to-back blocks do not drift).
    last_end: Instant,
    modal: Modal,
    spindle: (bool, f64),
    hold: bool,
    alarm: bool,
    check: bool,
    settings: Settings,
    pen_mode: GrblPen,
    motion: MotionModel,
    fail_next: Option<u32>,
    overflowing: bool,
    /// The last byte put in the receive buffer did not end a line: a line is
    /// on its way, and its rest may still be on the wire.
    line_open: bool,
    /// Input was lost in the middle of a line: the rest of that line, as it
    /// arrives, is lost with it.
    losing_rest_of_line: bool,
    consumed: u64,
    /// Position where execution is (end of the last finished block).
    at: [f64; 3],
    /// Where the machine's zero is on the paper (the record's frame): zero
    /// until a reset zeroes the board where the carriage stands; homing
    /// brings it back to zero in x and y.
    origin: [f64; 3],
    /// Homing is enabled at power-up (`$22=1` among the defaults,
    /// [`Quirk::HomingRequired`]).
    homing_required: bool,
    /// In the alarm state because homing is enabled and the board has not
    /// homed since it powered up or was reset; `$X` now unlocks it unhomed.
    homing_lock: bool,
    /// After a reset: the banner is said once the bootloader is done.
    banner_due: bool,
}

impl Grbl {
    pub fn new(cfg: &SimConfig, now: Instant, out: &mut Vec<u8>) -> Grbl {
        let mut g = Grbl {
            model: cfg.model.clone().unwrap_or_default(),
            capacity: cfg.effective_buffer_size(),
            rx: VecDeque::new(),
            line: Vec::with_capacity(LINE_BUFFER),
            line_overflow: false,
            comment: Comment::None,
            pending: VecDeque::new(),
            planner: VecDeque::new(),
            planner_cap: cfg.planner_blocks,
            exec: None,
            last_end: now,
            modal: Modal::default(),
            spindle: (false, 0.0),
            hold: false,
            alarm: false,
            check: false,
            settings: Settings::new(&cfg.motion, cfg.has(Quirk::HomingRequired)),
            pen_mode: cfg.grbl_pen,
            motion: cfg.motion,
            fail_next: None,
            overflowing: false,
            line_open: false,
            losing_rest_of_line: false,
            consumed: 0,
            at: [0.0; 3],
            booting_until: None,
            origin: [0.0; 3],
            homing_required: cfg.has(Quirk::HomingRequired),
            homing_lock: false,
            banner_due: false,
        };
        g.start_up(out);
        g
    }

    /// GRBL starting: locked if homing is enabled (HOMING_INIT_LOCK), then
    /// the banner, and the unlock hint when locked.
    fn start_up(&mut self, out: &mut Vec<u8>) {
        self.alarm = self.settings.get(22) != 0.0;
        self.homing_lock = self.alarm;
        self.greet(out);
    }

    /// The banner, and the unlock hint in the alarm state.
    fn greet(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(reports::BANNER.as_bytes());
        if self.alarm {
            out.extend_from_slice(reports::UNLOCK_HINT.as_bytes());
            out.extend_from_slice(CRLF);
        }
    }

    /// The homing cycle is running or planned.
    fn homing(&self) -> bool {
        self.exec.as_ref().is_some_and(|e| e.block.homing) || self.planner.iter().any(|b| b.homing)
    }

    fn moving(&self) -> bool {
        self.exec.is_some() || !self.planner.is_empty()
    }

    fn state_name(&self) -> &'static str {
        if self.banner_due {
            // Not a GRBL state: GRBL is not running yet.
            "Boot"
        } else if self.homing() {
            "Home"
        } else if self.alarm {
            "Alarm"
        } else if self.hold {
            "Hold:0"
        } else if self.check {
            "Check"
        } else if self.moving() || self.pending.iter().any(|a| matches!(a, Action::Block(_) | Action::Dwell(_))) {
            "Run"
        } else {
            "Idle"
        }
    }

    /// Where the tool is now, between the ends of the executing block.
    fn position(&self, now: Instant) -> [f64; 3] {
        let Some(e) = &self.exec else { return self.at };
        let left = if self.hold { e.remaining } else { e.remaining.saturating_sub(now.saturating_duration_since(e.resumed)) };
        let done = if e.total.is_zero() { 1.0 } else { 1.0 - left.as_secs_f64() / e.total.as_secs_f64() };
        let (a, b) = (e.block.from, e.block.to);
        [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * done)
    }

    fn status_report(&self, now: Instant) -> String {
        let p = self.position(now);
        let mask = self.settings.get(10) as u32;
        let mut s = format!("<{}|{}:{:.3},{:.3},{:.3}", self.state_name(), if mask & 1 != 0 { "MPos" } else { "WPos" }, p[0], p[1], p[2]);
        if mask & 2 != 0 {
            let rx_free = self.capacity - self.rx.len();
            s.push_str(&format!("|Bf:{},{}", self.planner_cap - self.planner.len(), rx_free));
        }
        let feed = self.exec.as_ref().map_or(0.0, |e| e.block.feed);
        s.push_str(&format!("|FS:{},{}>", feed.round() as i64, self.spindle.1.round() as i64));
        s
    }

    fn reply_line(&self, ctx: &mut Ctx<'_>, text: &str) {
        ctx.reply(text.as_bytes(), CRLF);
    }

    fn error(&mut self, code: u32, ctx: &mut Ctx<'_>) -> Action {
        ctx.record.error("grbl", code, reports::error_message(code));
        Action::Reply(format!("error:{code}"))
    }

    fn soft_reset(&mut self, ctx: &mut Ctx<'_>) {
        // GRBL's `mc_reset` alarms in a cycle, or a hold still
        // decelerating; plotsim's hold stops the tool at once, so a reset in
        // a hold keeps the position, as after a completed one.
        let moving = self.moving() && !self.check && !self.hold;
        let homing = self.homing();
        let here = self.stop_here(ctx);
        if matches!(self.pen_mode, GrblPen::Spindle) {
            // The reset switches the spindle off: a servo pen lifts.
            ctx.record.lift();
        }
        if moving {
            // GRBL cannot vouch for the position after stopping mid-move.
            let code = if homing { 6 } else { 3 };
            ctx.out.extend_from_slice(format!("ALARM:{code}\r\n").as_bytes());
            ctx.record.error("alarm", code, reports::alarm_message(code).unwrap_or("alarm"));
            self.alarm = true;
        }
        self.at = here;
        self.clear_buffers();
        self.modal = Modal { pos: here, ..Modal::default() };
        self.spindle = (false, 0.0);
        self.greet(ctx.out);
    }

    /// Motion stops where it is: the executing block was cut short, the pen
    /// drew up to here. Returns where that is.
    fn stop_here(&mut self, ctx: &mut Ctx<'_>) -> [f64; 3] {
        let here = self.position(ctx.now);
        if let Some(e) = &self.exec {
            let b = &e.block;
            if b.pen_down && (b.from[0] != here[0] || b.from[1] != here[1]) {
                self.draw(b.tool, b.from, here, ctx);
            }
        }
        here
    }

    /// Records a pen-down segment, on the paper.
    fn draw(&self, tool: u32, from: [f64; 3], to: [f64; 3], ctx: &mut Ctx<'_>) {
        let o = self.origin;
        ctx.record.segment(tool, [from[0] + o[0], from[1] + o[1]], [to[0] + o[0], to[1] + o[1]]);
    }

    /// Takes bytes from the receive buffer until a line is complete.
    fn next_line(&mut self) -> Option<Result<Vec<u8>, u32>> {
        while let Some(c) = self.rx.pop_front() {
            self.consumed += 1;
            if c == b'\n' || c == b'\r' {
                let line = std::mem::take(&mut self.line);
                self.comment = Comment::None;
                let overflow = std::mem::take(&mut self.line_overflow);
                return Some(if overflow { Err(11) } else { Ok(line) });
            }
            match self.comment {
                Comment::Paren => {
                    if c == b')' {
                        self.comment = Comment::None;
                    }
                }
                Comment::Semicolon => {}
                Comment::None => match c {
                    0..=b' ' | b'/' => {}
                    b'(' => self.comment = Comment::Paren,
                    b';' => self.comment = Comment::Semicolon,
                    _ if self.line.len() >= LINE_BUFFER - 1 => self.line_overflow = true,
                    _ => self.line.push(c.to_ascii_uppercase()),
                },
            }
        }
        None
    }

    fn process_line(&mut self, line: &[u8], ctx: &mut Ctx<'_>) -> Vec<Action> {
        if line.is_empty() {
            return vec![Action::Reply("ok".into())];
        }
        if let Some(code) = self.fail_next.take() {
            return vec![self.error(code, ctx)];
        }
        if line[0] == b'$' {
            return self.system_command(&line[1..], ctx);
        }
        if self.alarm {
            return vec![self.error(9, ctx)];
        }
        let tolerance = self.settings.get(12);
        match gcode::parse_line(line, &mut self.modal, tolerance) {
            Err(code) => vec![self.error(code, ctx)],
            Ok(_) if self.check => vec![Action::Reply("ok".into())],
            Ok(planned) => {
                let mut actions = Vec::new();
                let mut from = self.planned_end();
                let (mut on, mut s) = self.planned_spindle();
                for p in planned {
                    match p {
                        Planned::Spindle { on: o, s: v } => {
                            (on, s) = (o, v);
                            actions.push(Action::Spindle { on: o, s: v });
                        }
                        Planned::Dwell(t) => actions.push(Action::Dwell(t)),
                        Planned::Pause => actions.push(Action::Pause),
                        Planned::Move { to, rapid, feed } => {
                            let b = self.block(from, to, rapid, feed, on && s > 0.0);
                            from = to;
                            actions.push(Action::Block(b));
                        }
                    }
                }
                actions.push(Action::Reply("ok".into()));
                actions
            }
        }
    }

    /// Position at the end of everything planned so far.
    fn planned_end(&self) -> [f64; 3] {
        self.pending
            .iter()
            .rev()
            .find_map(|a| if let Action::Block(b) = a { Some(b.to) } else { None })
            .or_else(|| self.planner.back().map(|b| b.to))
            .or_else(|| self.exec.as_ref().map(|e| e.block.to))
            .unwrap_or(self.at)
    }

    fn planned_spindle(&self) -> (bool, f64) {
        self.pending
            .iter()
            .rev()
            .find_map(|a| if let Action::Spindle { on, s } = a { Some((*on, *s)) } else { None })
            .unwrap_or(self.spindle)
    }

    fn block(&self, from: [f64; 3], to: [f64; 3], rapid: bool, feed: f64, spindle_down: bool) -> Block {
        let max_rate = self.settings.get(110).max(1e-6);
        let rate = if rapid { max_rate } else { feed.min(max_rate) };
        let len = ((to[0] - from[0]).powi(2) + (to[1] - from[1]).powi(2) + (to[2] - from[2]).powi(2)).sqrt();
        let pen_down = match self.pen_mode {
            GrblPen::Spindle => spindle_down,
            GrblPen::ZBelow(z) => from[2] + self.origin[2] < z && to[2] + self.origin[2] < z,
        };
        Block {
            from,
            to,
            pen_down,
            tool: self.modal.tool.max(1),
            feed: rate,
            sim_seconds: self.motion.move_time(len, rate / 60.0),
            homing: false,
        }
    }

    /// The machine position homing sets (`limits.c`), in x and y: `-$27`
    /// on an axis homed towards its positive end, `-$13x + $27` towards its
    /// negative end (`$23` bit set). The simulated machine has X and Y
    /// switches only (a plotter build: HOMING_CYCLE_0 = X|Y); Z stays.
    fn home_position(&self) -> [f64; 2] {
        let pulloff = self.settings.get(27);
        [0, 1].map(|axis| if self.homes_towards_negative(axis) { -self.settings.get(130 + axis) + pulloff } else { -pulloff })
    }

    /// `$23`, the homing direction mask: bit set, the axis's switch is at
    /// its negative end.
    fn homes_towards_negative(&self, axis: u32) -> bool {
        (self.settings.get(23) as u32) & (1 << axis) != 0
    }

    /// The homing cycle from here: to the switches at the seek rate `$25`,
    /// then locating them: `$27` off at the seek rate, back at the feed rate
    /// `$24`, off again. It ends at the home position, on the paper's frame.
    fn homing_block(&self) -> Block {
        let s = &self.settings;
        let (seek, locate, pulloff) = (s.get(25).max(1e-6) / 60.0, s.get(24).max(1e-6) / 60.0, s.get(27));
        let home = self.home_position();
        let to = [home[0] - self.origin[0], home[1] - self.origin[1], self.at[2]];
        // The switches sit `$27` beyond the home position.
        let seek_mm = [0, 1]
            .map(|axis| {
                let switch = to[axis] + if self.homes_towards_negative(axis as u32) { -pulloff } else { pulloff };
                (switch - self.at[axis]).abs()
            })
            .into_iter()
            .fold(0.0, f64::max);
        let pen_down = match self.pen_mode {
            GrblPen::Spindle => self.spindle.0 && self.spindle.1 > 0.0,
            GrblPen::ZBelow(z) => self.at[2] + self.origin[2] < z,
        };
        Block {
            from: self.at,
            to,
            pen_down,
            tool: self.modal.tool.max(1),
            feed: s.get(25),
            sim_seconds: (seek_mm + 2.0 * pulloff) / seek + pulloff / locate,
            homing: true,
        }
    }

    fn system_command(&mut self, cmd: &[u8], ctx: &mut Ctx<'_>) -> Vec<Action> {
        let ok = || Action::Reply("ok".into());
        let busy = self.moving() || self.hold;
        let text = String::from_utf8_lossy(cmd).into_owned();
        match text.as_str() {
            "" => vec![Action::Reply(reports::HELP.into()), ok()],
            "$" if busy => vec![self.error(8, ctx)],
            "$" => {
                let mut v: Vec<Action> = self.settings.listing().lines().map(|l| Action::Reply(l.to_string())).collect();
                v.push(ok());
                v
            }
            "I" if busy => vec![self.error(8, ctx)],
            "I" => vec![
                Action::Reply(format!("[VER:{}:{}]", reports::VERSION, self.model)),
                // The issue fixes the planner and buffer figures as the sizes
                // themselves; GRBL firmware prints BLOCK_BUFFER_SIZE-1 here.
                Action::Reply(format!("[OPT:V,{},{}]", self.planner_cap, self.capacity)),
                ok(),
            ],
            "G" => {
                let m = &self.modal;
                let motion = m.motion.map_or("G80".to_string(), |g| format!("G{g}"));
                let spindle = if self.spindle.0 { "M3" } else { "M5" };
                let feed = m.feed.unwrap_or(0.0) / if m.inches { 25.4 } else { 1.0 };
                vec![
                    Action::Reply(format!(
                        "[GC:{motion} G54 G17 {} {} G94 {spindle} M9 T{} F{} S{}]",
                        if m.inches { "G20" } else { "G21" },
                        if m.relative { "G91" } else { "G90" },
                        m.tool,
                        feed,
                        m.spindle_s
                    )),
                    ok(),
                ]
            }
            "#" => {
                let mut v: Vec<Action> = ["G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30", "G92"]
                    .iter()
                    .map(|g| Action::Reply(format!("[{g}:0.000,0.000,0.000]")))
                    .collect();
                v.push(Action::Reply("[TLO:0.000]".into()));
                v.push(Action::Reply("[PRB:0.000,0.000,0.000:0]".into()));
                v.push(ok());
                v
            }
            "N" => vec![Action::Reply("$N0=".into()), Action::Reply("$N1=".into()), ok()],
            "C" if busy || self.alarm => vec![self.error(8, ctx)],
            "C" if self.check => vec![Action::Reply("[MSG:Disabled]".into()), ok(), Action::Reset],
            "C" => {
                self.check = true;
                vec![Action::Reply("[MSG:Enabled]".into()), ok()]
            }
            "X" => {
                if self.alarm {
                    self.alarm = false;
                    if std::mem::take(&mut self.homing_lock) {
                        ctx.record.unlocked_without_homing = true;
                    }
                    vec![Action::Reply("[MSG:Caution: Unlocked]".into()), ok()]
                } else {
                    vec![ok()]
                }
            }
            "H" if busy || self.check => vec![self.error(8, ctx)],
            "H" if self.settings.get(22) == 0.0 => vec![self.error(5, ctx)],
            "H" => vec![Action::Home, ok()],
            _ => {
                if let Some((n, v)) = text.split_once('=') {
                    if busy {
                        return vec![self.error(8, ctx)];
                    }
                    let value: Option<f64> = v.parse().ok();
                    return match (n.parse::<u32>(), value) {
                        (Ok(_), Some(v)) if v < 0.0 => vec![self.error(4, ctx)],
                        (Ok(n), Some(v)) if self.settings.set(n, v) => vec![ok()],
                        (Ok(_), None) => vec![self.error(2, ctx)],
                        _ => vec![self.error(3, ctx)],
                    };
                }
                vec![self.error(3, ctx)]
            }
        }
    }

    fn start_next_block(&mut self, now: Instant, ctx: &mut Ctx<'_>) {
        if self.exec.is_some() || self.hold {
            return;
        }
        let Some(block) = self.planner.pop_front() else { return };
        let total = ctx.scaled(block.sim_seconds);
        let start = self.last_end.max(now.checked_sub(CATCH_UP).unwrap_or(now));
        self.exec = Some(Exec { block, total, remaining: total, resumed: start });
    }

    fn finish_block(&mut self, ctx: &mut Ctx<'_>) {
        let Some(e) = self.exec.take() else { return };
        self.last_end = e.resumed + e.remaining;
        let b = e.block;
        ctx.record.plot_seconds += b.sim_seconds;
        if !b.pen_down {
            ctx.record.lift();
            if b.from[..2] != b.to[..2] {
                let o = self.origin;
                ctx.record.travelled([b.to[0] + o[0], b.to[1] + o[1]]);
            }
        } else if b.from[0] != b.to[0] || b.from[1] != b.to[1] {
            self.draw(b.tool, b.from, b.to, ctx);
        }
        self.at = b.to;
        if b.homing {
            // The switches found: the board's x and y are the paper's again.
            let home = self.home_position();
            self.origin = [0.0, 0.0, self.origin[2]];
            self.at = [home[0], home[1], b.to[2]];
            self.modal.pos = self.at;
            self.homing_lock = false;
        }
    }

    /// Moves pending actions into the planner as far as they go; true if any moved.
    fn advance_pending(&mut self, ctx: &mut Ctx<'_>) -> bool {
        let mut progressed = false;
        while let Some(a) = self.pending.front() {
            match a {
                _ if self.homing() => break,
                Action::Block(_) if self.planner.len() >= self.planner_cap => break,
                Action::Spindle { .. } | Action::Dwell(_) | Action::Pause | Action::Home if self.moving() => break,
                _ => {}
            }
            let a = self.pending.pop_front().expect("front exists");
            progressed = true;
            match a {
                Action::Block(b) => self.planner.push_back(b),
                Action::Spindle { on, s } => {
                    if !on {
                        ctx.record.lift();
                    }
                    self.spindle = (on, s);
                }
                Action::Dwell(t) => {
                    let here = self.at;
                    self.planner.push_back(Block {
                        from: here,
                        to: here,
                        pen_down: false,
                        tool: 1,
                        feed: 0.0,
                        sim_seconds: t,
                        homing: false,
                    });
                }
                Action::Pause => self.hold = true,
                Action::Home => {
                    self.alarm = false;
                    let b = self.homing_block();
                    self.planner.push_back(b);
                }
                Action::Reply(text) => self.reply_line(ctx, &text),
                Action::Reset => {
                    self.soft_reset(ctx);
                    return true;
                }
            }
        }
        progressed
    }
}

impl Device for Grbl {
    fn receive(&mut self, byte: u8, ctx: &mut Ctx<'_>) {
        if self.booting_until.is_some_and(|t| ctx.now < t) {
            return;
        }
        match byte {
            b'?' => {
                let r = self.status_report(ctx.now);
                self.reply_line(ctx, &r);
            }
            b'!' => {
                // Homing answers only to a reset.
                if !self.alarm && !self.hold && !self.homing() {
                    if let Some(e) = self.exec.as_mut() {
                        e.remaining = e.remaining.saturating_sub(ctx.now.saturating_duration_since(e.resumed));
                    }
                    self.hold = true;
                }
            }
            b'~' => {
                if self.hold {
                    self.hold = false;
                    if let Some(e) = self.exec.as_mut() {
                        e.resumed = ctx.now;
                    }
                }
            }
            0x18 => self.soft_reset(ctx),
            // Extended real-time commands (overrides, jog cancel, door) and
            // unknown high bytes never reach the buffer.
            0x80..=0xff => {}
            _ if self.losing_rest_of_line => self.losing_rest_of_line = !matches!(byte, b'\n' | b'\r'),
            _ => {
                self.line_open = !matches!(byte, b'\n' | b'\r');
                if self.rx.len() >= self.capacity {
                    ctx.record.overruns += 1;
                    if !self.overflowing {
                        ctx.record.error("overflow", 0, "receive buffer overflow: bytes lost");
                    }
                    self.overflowing = true;
                } else {
                    self.overflowing = false;
                    self.rx.push_back(byte);
                }
            }
        }
    }

    fn run(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        if self.banner_due {
            match self.booting_until {
                Some(t) if ctx.now < t => return Some(t),
                _ => {
                    self.banner_due = false;
                    self.greet(ctx.out);
                }
            }
        }
        loop {
            let now = ctx.now;
            if let Some(e) = &self.exec {
                if self.hold {
                    // Frozen; lines are still read and planned below.
                } else if now >= e.resumed + e.remaining {
                    self.finish_block(ctx);
                    continue;
                }
            }
            self.start_next_block(now, ctx);
            if self.exec.as_ref().is_some_and(|e| !self.hold && now >= e.resumed + e.remaining) {
                continue;
            }
            if self.advance_pending(ctx) {
                continue;
            }
            if self.pending.is_empty() {
                if let Some(line) = self.next_line() {
                    let actions = match line {
                        Ok(l) => self.process_line(&l, ctx),
                        Err(code) => vec![self.error(code, ctx)],
                    };
                    self.pending.extend(actions);
                    continue;
                }
            }
            return match &self.exec {
                Some(e) if !self.hold => Some(e.resumed + e.remaining),
                _ => None,
            };
        }
    }

    fn status(&self) -> DeviceStatus {
        let now = Instant::now();
        let p = self.position(now);
        DeviceStatus {
            buffer_used: self.rx.len(),
            buffer_capacity: self.capacity,
            idle: self.rx.is_empty() && self.pending.is_empty() && !self.moving() && !self.banner_due,
            position: [p[0], p[1]],
            pen_down: self.spindle.0 && self.spindle.1 > 0.0,
            state: self.state_name().to_string(),
            cts: true,
            xoff: false,
        }
    }

    fn power_cycle(&mut self, ctx: &mut Ctx<'_>) {
        let cfg_model = std::mem::take(&mut self.model);
        let motion = self.motion;
        self.soft_reset_quiet(ctx);
        self.model = cfg_model;
        self.settings = Settings::new(&motion, self.homing_required);
        // plotsim's power cycle takes the carriage to be back at the paper's
        // origin, as it always has; a real board loses its position here as
        // in `reset`, which is the fault that shows it.
        self.origin = [0.0; 3];
        self.booting_until = Some(ctx.now + BOOT);
        self.start_up(ctx.out);
    }

    fn reset(&mut self, ctx: &mut Ctx<'_>) {
        // The chip restarts: nothing is said about the motion it cut short.
        let here = self.stop_here(ctx);
        self.origin = [0, 1, 2].map(|k| self.origin[k] + here[k]);
        self.soft_reset_quiet(ctx);
        self.alarm = self.settings.get(22) != 0.0;
        self.homing_lock = self.alarm;
        self.booting_until = Some(ctx.now + RESET_BOOT);
        self.banner_due = true;
    }

    fn park(&mut self, ctx: &mut Ctx<'_>) -> Result<(), String> {
        if self.moving() {
            return Err("the carriage is moving: park it once the board is idle".into());
        }
        // Where the board thinks it is becomes the paper's origin.
        self.origin = [-self.at[0], -self.at[1], self.origin[2]];
        ctx.record.lift();
        Ok(())
    }

    fn set_lever(&mut self, _up: bool) -> Result<(), String> {
        Err("a GRBL board has no paper lever".into())
    }

    fn lose_input(&mut self) -> Result<(), String> {
        // A pty hands the host's bytes over in pieces: the rest of a line
        // half received may come after the simulator drained the wire. It is
        // part of what was lost, not a line of its own.
        self.losing_rest_of_line = self.line_open;
        self.rx.clear();
        self.line.clear();
        self.line_overflow = false;
        self.comment = Comment::None;
        Ok(())
    }

    fn alarm(&mut self, code: u32, ctx: &mut Ctx<'_>) -> Result<(), String> {
        let message = reports::alarm_message(code).ok_or_else(|| format!("no GRBL alarm {code}"))?;
        let here = self.position(ctx.now);
        self.clear_buffers();
        // What was planned is gone: the parser's position is where the tool stopped.
        self.at = here;
        self.modal.pos = here;
        self.last_end = ctx.now;
        self.alarm = true;
        // As on a reset, the spindle (the pen servo) is switched off.
        self.spindle = (false, 0.0);
        ctx.record.lift();
        ctx.record.error("alarm", code, message);
        ctx.out.extend_from_slice(format!("ALARM:{code}\r\n").as_bytes());
        Ok(())
    }

    fn fail_next(&mut self, code: Option<u32>) {
        self.fail_next = Some(code.unwrap_or(gcode::err::UNSUPPORTED));
    }

    fn consumed(&self) -> u64 {
        self.consumed
    }
}

impl Grbl {
    /// What a reset and a power loss both throw away: received bytes, the line
    /// being read, queued and planned motion, feed hold and check mode.
    fn clear_buffers(&mut self) {
        self.rx.clear();
        self.line.clear();
        self.line_overflow = false;
        self.comment = Comment::None;
        self.losing_rest_of_line = false;
        self.pending.clear();
        self.planner.clear();
        self.exec = None;
        self.hold = false;
        self.check = false;
    }

    /// Power loss: like a reset, but no alarm and no message (the board is off).
    fn soft_reset_quiet(&mut self, ctx: &mut Ctx<'_>) {
        self.clear_buffers();
        self.banner_due = false;
        ctx.record.lift();
        self.alarm = false;
        self.fail_next = None;
        self.overflowing = false;
        self.at = [0.0; 3];
        self.modal = Modal::default();
        self.spindle = (false, 0.0);
        self.last_end = ctx.now;
    }
}

#[cfg(test)]
mod tests;
