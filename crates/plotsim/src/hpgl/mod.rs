//! The HP 7475A personality: a finite input buffer that loses bytes when
//! overrun, device-control instructions answered on arrival, HP-GL executed
//! at plotting speed.
//!
//! Reference: HP 7475A Interfacing and Programming Manual (HP-GL chapters
//! for IN, DF, SP, PU, PD, PA, PR, VS, IP and the output instructions; the
//! RS-232-C chapter for the buffer and device control, see [`escape`]).
//! `OS` bits: 1 pen down, 2 P1/P2 changed, 8 initialized (cleared by reading
//! OS), 16 ready for data (paper lever down), 32 error (OE non-zero).
//! `OE`: 0 none, 1 instruction not recognised, 2 wrong number of parameters,
//! 3 parameter out of range. Plotter units are 0.025 mm (40 per mm).

pub(crate) mod escape;
pub(crate) mod parser;

use crate::config::SimConfig;
use crate::device::{Ctx, Device, DeviceStatus};
use crate::quirks::Quirk;
use escape::{chars, ext, EscCommand, EscFeed, EscState, Handshake};
use parser::{Event, Parser};
use std::collections::VecDeque;
use std::time::{Duration, Instant};
use strokes::MotionModel;

/// Plotter units per millimetre.
pub const UNITS_PER_MM: f64 = 40.0;
/// Coordinates beyond ±this are out of range (HP-GL error 3); the 7475A
/// takes 16-bit integers.
const MAX_COORD: f64 = 32_767.0;
/// Fastest pen-down velocity a 7475A accepts (VS is in cm/s; larger values
/// are reduced to this).
const MAX_VS: f64 = 38.0;
/// How far behind "now" a new move may start when the device was busy until
/// then; keeps a stream of moves from drifting by the poll granularity.
const CATCH_UP: Duration = Duration::from_millis(5);

/// HP-GL (OE) error numbers.
mod oe {
    pub const UNKNOWN: u32 = 1;
    pub const PARAM_COUNT: u32 = 2;
    pub const RANGE: u32 = 3;
}

fn oe_message(code: u32) -> &'static str {
    match code {
        oe::UNKNOWN => "instruction not recognised",
        oe::PARAM_COUNT => "wrong number of parameters",
        oe::RANGE => "parameter out of range",
        _ => "injected error",
    }
}

fn ext_message(code: u32) -> &'static str {
    match code {
        ext::BAD_INSTRUCTION => "invalid byte after ESC.",
        ext::BAD_PARAMETER_BYTE => "invalid byte in device-control parameters",
        ext::OUT_OF_RANGE => "device-control parameter out of range",
        ext::TOO_MANY => "too many device-control parameters",
        ext::OVERFLOW => "input buffer overflow",
        _ => "I/O error",
    }
}

/// Instructions a 7475A knows that plotsim accepts without drawing (text,
/// arcs, fills, line types and windows change nothing in the record). This is
/// a known limit of the simulator, not of the device.
const ACCEPTED: &[&[u8; 2]] = &[
    b"IW", b"SC", b"LT", b"CS", b"CA", b"SS", b"SA", b"DI", b"DR", b"SI", b"SR", b"SL", b"SM", b"UC", b"DT", b"LB", b"CP", b"TL", b"XT",
    b"YT", b"CI", b"AA", b"AR", b"EA", b"ER", b"EW", b"RA", b"RR", b"WG", b"FT", b"PT", b"IM", b"DC", b"DP", b"RO", b"AS", b"GM", b"CT",
    b"NR", b"PB", b"BL", b"PS",
];

/// The instruction being read.
#[derive(Clone, Debug)]
struct Current {
    mn: [u8; 2],
    params: Vec<f64>,
    /// Rejected (bad parameter or injected error): read to its end, do nothing.
    rejected: bool,
}

/// A simulated HP 7475A.
pub(crate) struct Hp {
    model: String,
    physical: usize,
    capacity: usize,
    /// Whether ESC.O (extended status) is answered ([`Quirk::NoEscO`]).
    answers_esc_o: bool,
    /// Whether ESC.L (buffer size) is answered ([`Quirk::NoEscL`]).
    answers_esc_l: bool,
    /// Whether ESC.M sets the output terminator ([`Quirk::NoEscM`]).
    honours_esc_m: bool,
    /// Whether ESC.K leaves a half-read instruction ([`Quirk::AbortKeepsPartial`]).
    abort_keeps_partial: bool,
    /// Bytes of the instruction being read, taken from the buffer; with
    /// `abort_keeps_partial` they still count as buffered.
    partial: usize,
    buf: VecDeque<u8>,
    esc: EscState,
    hs: Handshake,
    parser: Parser,
    events: Vec<Event>,
    cur: Option<Current>,
    pos: [f64; 2],
    pen_down: bool,
    pen: u32,
    relative: bool,
    velocity: f64,
    pens: u32,
    hard_clip: [i32; 4],
    default_p1p2: [i32; 4],
    p1p2: [i32; 4],
    motion: MotionModel,
    oe: u32,
    ext: u32,
    initialized: bool,
    p1p2_changed: bool,
    lever_up: bool,
    busy_until: Instant,
    overflowing: bool,
    xoff_sent: bool,
    ack_pending: bool,
    fail_next: Option<u32>,
    consumed: u64,
}

impl Hp {
    pub fn new(cfg: &SimConfig, now: Instant) -> Hp {
        let capacity = cfg.effective_buffer_size();
        Hp {
            model: cfg.model.clone().unwrap_or_else(|| "7475A".to_string()),
            physical: capacity,
            capacity,
            answers_esc_o: !cfg.has(Quirk::NoEscO),
            answers_esc_l: !cfg.has(Quirk::NoEscL),
            honours_esc_m: !cfg.has(Quirk::NoEscM),
            abort_keeps_partial: cfg.has(Quirk::AbortKeepsPartial),
            partial: 0,
            buf: VecDeque::with_capacity(capacity),
            esc: EscState::default(),
            hs: Handshake::default(),
            parser: Parser::new(cfg.has(Quirk::StrictSeparators)),
            events: Vec::new(),
            cur: None,
            pos: [0.0, 0.0],
            pen_down: false,
            pen: 0,
            relative: false,
            velocity: default_velocity(&cfg.motion),
            pens: cfg.pens,
            hard_clip: cfg.paper.hard_clip(),
            default_p1p2: cfg.paper.p1p2(),
            p1p2: cfg.paper.p1p2(),
            motion: cfg.motion,
            oe: 0,
            ext: 0,
            initialized: true,
            p1p2_changed: false,
            lever_up: false,
            busy_until: now,
            overflowing: false,
            xoff_sent: false,
            ack_pending: false,
            fail_next: None,
            consumed: 0,
        }
    }

    /// Hard-clip limits as the record's `limits`.
    pub fn limits(&self) -> [f64; 4] {
        self.hard_clip.map(f64::from)
    }

    fn free(&self) -> usize {
        let held = if self.abort_keeps_partial { self.partial } else { 0 };
        self.capacity.saturating_sub(self.buf.len() + held)
    }

    fn store(&mut self, b: u8, ctx: &mut Ctx<'_>) {
        if self.free() == 0 {
            // The real buffer drops the byte and flags error 16; one record
            // entry per run of lost bytes keeps the record readable.
            ctx.record.overruns += 1;
            self.ext = ext::OVERFLOW;
            if !self.overflowing {
                ctx.record.error("extended", ext::OVERFLOW, ext_message(ext::OVERFLOW));
            }
            self.overflowing = true;
        } else {
            self.overflowing = false;
            self.buf.push_back(b);
        }
        self.update_flow(ctx);
    }

    /// XON/XOFF and enquire/acknowledge replies as the free space changes.
    fn update_flow(&mut self, ctx: &mut Ctx<'_>) {
        let free = self.free();
        if self.hs.xon_xoff() {
            if !self.xoff_sent && free < self.hs.block {
                ctx.out.extend_from_slice(&self.hs.xoff);
                self.xoff_sent = true;
            } else if self.xoff_sent && self.buf.len() <= self.hs.xon_level(self.capacity) {
                ctx.out.extend_from_slice(&self.hs.ack);
                self.xoff_sent = false;
            }
        }
        if self.ack_pending && free >= self.hs.block {
            ctx.out.extend_from_slice(&self.hs.ack);
            self.ack_pending = false;
        }
    }

    fn ext_error(&mut self, code: u32, ctx: &mut Ctx<'_>) {
        self.ext = code;
        ctx.record.error("extended", code, ext_message(code));
    }

    fn device_control(&mut self, cmd: EscCommand, ctx: &mut Ctx<'_>) {
        let term = self.hs.terminator.clone();
        match cmd {
            EscCommand::Plain(b'B') => ctx.reply(self.free().to_string().as_bytes(), &term),
            // Firmware without ESC.O or ESC.L ignores them: no answer, no error.
            EscCommand::Plain(b'O') if !self.answers_esc_o => {}
            EscCommand::Plain(b'L') if !self.answers_esc_l => {}
            EscCommand::Plain(b'L') => ctx.reply(self.capacity.to_string().as_bytes(), &term),
            EscCommand::Plain(b'E') => {
                let e = std::mem::take(&mut self.ext);
                ctx.reply(e.to_string().as_bytes(), &term);
            }
            EscCommand::Plain(b'O') => {
                let mut s = 0;
                // Bit 3 is about the buffer only: the last move may still be running.
                if self.buf.is_empty() {
                    s |= escape::STATUS_BUFFER_EMPTY;
                }
                if self.lever_up {
                    s |= escape::STATUS_LEVER_UP;
                }
                ctx.reply(s.to_string().as_bytes(), &term);
            }
            EscCommand::Plain(b'K') => {
                // Abort graphics: everything buffered and the half-read instruction go.
                self.buf.clear();
                if !self.abort_keeps_partial {
                    self.parser.reset();
                    self.partial = 0;
                    self.cur = None;
                }
                self.update_flow(ctx);
            }
            EscCommand::Plain(b'R') => {
                self.hs = Handshake { hardwire: self.hs.hardwire, ..Handshake::default() };
                self.xoff_sent = false;
                self.ack_pending = false;
            }
            // ESC.J (abort device control: nothing is ever half-sent here) and
            // the plotter-on/off pairs change nothing plotsim models.
            EscCommand::Plain(_) => {}
            EscCommand::WithParams(letter, p) => {
                if let Err(code) = self.set_mode(letter, &p) {
                    self.ext_error(code, ctx);
                }
                self.update_flow(ctx);
            }
        }
    }

    fn set_mode(&mut self, letter: u8, p: &[Option<u32>]) -> Result<(), u32> {
        let at = |i: usize| p.get(i).copied().flatten();
        match letter {
            b'@' => {
                if let Some(size) = at(0) {
                    let size = size as usize;
                    if size != 0 && !(2..=self.physical).contains(&size) {
                        return Err(ext::OUT_OF_RANGE);
                    }
                    self.capacity = if size == 0 { self.physical } else { size };
                }
                if let Some(cfg) = at(1) {
                    if cfg > 255 {
                        return Err(ext::OUT_OF_RANGE);
                    }
                    self.hs.hardwire = cfg & 1 != 0;
                }
            }
            b'H' | b'I' => {
                let block = at(0).map_or(escape::DEFAULT_BLOCK, |v| v as usize);
                if block > self.capacity {
                    return Err(ext::OUT_OF_RANGE);
                }
                let enq = at(1).unwrap_or(0);
                if enq > 127 {
                    return Err(ext::OUT_OF_RANGE);
                }
                let s = chars(p.get(2..).unwrap_or(&[]))?;
                self.hs.block = block;
                self.hs.enq = (enq != 0).then_some(enq as u8);
                self.hs.ack = s;
                self.xoff_sent = false;
            }
            b'N' => self.hs.xoff = chars(p.get(1..).unwrap_or(&[]))?,
            b'M' if !self.honours_esc_m => {}
            b'M' => {
                let t1 = at(3).unwrap_or(0);
                let t2 = at(4).unwrap_or(0);
                if t1 > 127 || t2 > 127 {
                    return Err(ext::OUT_OF_RANGE);
                }
                self.hs.terminator = match (t1, t2) {
                    (0, _) => vec![b'\r'],
                    (a, 0) => vec![a as u8],
                    (a, b) => vec![a as u8, b as u8],
                };
            }
            _ => {}
        }
        Ok(())
    }

    fn hpgl_error(&mut self, code: u32, ctx: &mut Ctx<'_>) {
        self.oe = code;
        ctx.record.error("hpgl", code, oe_message(code));
    }

    fn handle(&mut self, ev: Event, ctx: &mut Ctx<'_>) {
        match ev {
            Event::Stray => self.hpgl_error(oe::UNKNOWN, ctx),
            Event::Begin(mn) => {
                let mut cur = Current { mn, params: Vec::new(), rejected: false };
                // The fault is in the job, not in the host's own queries
                // (`OI`, `OE`, `OA`): output instructions pass it by.
                let output = mn[0] == b'O';
                if let Some(code) = self.fail_next.take_if(|_| !output) {
                    cur.rejected = true;
                    self.hpgl_error(code, ctx);
                } else if !self.known(&mn) {
                    cur.rejected = true;
                    self.hpgl_error(oe::UNKNOWN, ctx);
                } else {
                    // Pen and mode changes happen before the coordinates are read.
                    match &mn {
                        b"PU" => self.set_pen(false, ctx),
                        b"PD" => self.set_pen(true, ctx),
                        b"PA" => self.relative = false,
                        b"PR" => self.relative = true,
                        _ => {}
                    }
                }
                self.cur = Some(cur);
            }
            Event::BadParam => {
                if let Some(cur) = self.cur.as_mut().filter(|c| !c.rejected) {
                    cur.rejected = true;
                    self.hpgl_error(oe::UNKNOWN, ctx);
                }
            }
            Event::Param(v) => {
                let Some(cur) = self.cur.as_mut().filter(|c| !c.rejected) else { return };
                cur.params.push(v);
                if is_move(&cur.mn) && cur.params.len() == 2 {
                    let (x, y) = (cur.params[0], cur.params[1]);
                    cur.params.clear();
                    self.move_to(x, y, ctx);
                }
            }
            Event::End => {
                let Some(cur) = self.cur.take().filter(|c| !c.rejected) else { return };
                if is_move(&cur.mn) {
                    if !cur.params.is_empty() {
                        self.hpgl_error(oe::PARAM_COUNT, ctx);
                    }
                } else {
                    self.execute(cur.mn, &cur.params, ctx);
                }
            }
        }
    }

    fn known(&self, mn: &[u8; 2]) -> bool {
        const OWN: &[&[u8; 2]] = &[
            b"IN", b"DF", b"SP", b"PU", b"PD", b"PA", b"PR", b"VS", b"IP", b"OI", b"OS", b"OE", b"OA", b"OC", b"OH", b"OF", b"OP", b"OW",
            b"OO", b"OD",
        ];
        OWN.contains(&mn) || ACCEPTED.contains(&mn)
    }

    /// Starts a timed action of `sim_seconds`; returns nothing, sets `busy_until`.
    fn spend(&mut self, sim_seconds: f64, ctx: &mut Ctx<'_>) {
        if sim_seconds <= 0.0 {
            return;
        }
        ctx.record.plot_seconds += sim_seconds;
        let start = self.busy_until.max(ctx.now.checked_sub(CATCH_UP).unwrap_or(ctx.now));
        self.busy_until = start + ctx.scaled(sim_seconds);
    }

    fn set_pen(&mut self, down: bool, ctx: &mut Ctx<'_>) {
        if down == self.pen_down {
            return;
        }
        self.pen_down = down;
        if !down {
            ctx.record.lift();
        }
        let t = if down { self.motion.pen_drop_time } else { self.motion.pen_lift_time };
        self.spend(t, ctx);
    }

    fn move_to(&mut self, x: f64, y: f64, ctx: &mut Ctx<'_>) {
        if x.abs() > MAX_COORD || y.abs() > MAX_COORD {
            self.hpgl_error(oe::RANGE, ctx);
            return;
        }
        let to = if self.relative { [self.pos[0] + x, self.pos[1] + y] } else { [x, y] };
        let from = self.pos;
        let len_mm = ((to[0] - from[0]).powi(2) + (to[1] - from[1]).powi(2)).sqrt() / UNITS_PER_MM;
        let speed = if self.pen_down { self.velocity * 10.0 } else { self.motion.pen_up_speed };
        if self.pen_down && self.pen != 0 && !self.lever_up {
            if let Some((a, b)) = clip(from, to, self.hard_clip.map(f64::from)) {
                ctx.record.segment(self.pen, a, b);
            }
        } else if !self.pen_down {
            ctx.record.travelled(to);
        }
        self.pos = to;
        let t = self.motion.move_time(len_mm, speed);
        self.spend(t, ctx);
    }

    fn execute(&mut self, mn: [u8; 2], p: &[f64], ctx: &mut Ctx<'_>) {
        let term = self.hs.terminator.clone();
        let int = |v: f64| format!("{}", v.round() as i64);
        match &mn {
            b"IN" => {
                self.parser.reset_label_terminator();
                self.set_pen(false, ctx);
                self.defaults();
                self.oe = 0;
                self.initialized = true;
                self.p1p2 = self.default_p1p2;
                self.p1p2_changed = false;
            }
            b"DF" => self.defaults(),
            b"SP" => {
                let n = p.first().copied().unwrap_or(0.0);
                if p.len() > 1 {
                    self.hpgl_error(oe::PARAM_COUNT, ctx);
                } else if !(0.0..=f64::from(self.pens)).contains(&n.trunc()) {
                    self.hpgl_error(oe::RANGE, ctx);
                } else {
                    // The carousel takes the pen up before changing it.
                    self.set_pen(false, ctx);
                    self.pen = n.trunc() as u32;
                }
            }
            b"VS" => match p {
                [] => self.velocity = default_velocity(&self.motion),
                [v] | [v, _] if *v > 0.0 && *v < 128.0 => {
                    self.velocity = v.min(MAX_VS.max(default_velocity(&self.motion)));
                }
                [_] | [_, _] => self.hpgl_error(oe::RANGE, ctx),
                _ => self.hpgl_error(oe::PARAM_COUNT, ctx),
            },
            b"IP" => match p {
                [] => {
                    self.p1p2 = self.default_p1p2;
                    self.p1p2_changed = true;
                }
                [a, b, c, d] => {
                    self.p1p2 = [*a, *b, *c, *d].map(|v| v.round() as i32);
                    self.p1p2_changed = true;
                }
                _ => self.hpgl_error(oe::PARAM_COUNT, ctx),
            },
            b"OI" => ctx.reply(self.model.as_bytes(), &term),
            b"OS" => {
                let s = self.os_byte();
                self.initialized = false;
                ctx.reply(s.to_string().as_bytes(), &term);
            }
            b"OE" => {
                let e = std::mem::take(&mut self.oe);
                ctx.reply(e.to_string().as_bytes(), &term);
            }
            b"OA" | b"OC" => {
                let s = format!("{},{},{}", int(self.pos[0]), int(self.pos[1]), u8::from(self.pen_down));
                ctx.reply(s.as_bytes(), &term);
            }
            b"OH" | b"OW" => ctx.reply(join(self.hard_clip).as_bytes(), &term),
            b"OP" => ctx.reply(join(self.p1p2).as_bytes(), &term),
            b"OF" => ctx.reply(b"40,40", &term),
            b"OO" => ctx.reply(b"0,1,0,0,1,0,0,0", &term),
            b"OD" => {
                let s = format!("{},{},{}", int(self.pos[0]), int(self.pos[1]), u8::from(self.pen_down));
                ctx.reply(s.as_bytes(), &term);
            }
            // Known but not drawn (see ACCEPTED).
            _ => {}
        }
    }

    fn defaults(&mut self) {
        self.relative = false;
        self.velocity = default_velocity(&self.motion);
    }

    fn os_byte(&self) -> u32 {
        let mut s = 0;
        if self.pen_down {
            s |= 1;
        }
        if self.p1p2_changed {
            s |= 2;
        }
        if self.initialized {
            s |= 8;
        }
        if !self.lever_up {
            s |= 16;
        }
        if self.oe != 0 {
            s |= 32;
        }
        s
    }
}

fn default_velocity(m: &MotionModel) -> f64 {
    m.pen_down_speed / 10.0
}

fn is_move(mn: &[u8; 2]) -> bool {
    matches!(mn, b"PA" | b"PR" | b"PU" | b"PD")
}

fn join(v: [i32; 4]) -> String {
    format!("{},{},{},{}", v[0], v[1], v[2], v[3])
}

/// The part of segment `a`-`b` inside the box (Liang-Barsky), if any: the
/// plotter does not draw past its hard-clip limits.
fn clip(a: [f64; 2], b: [f64; 2], bx: [f64; 4]) -> Option<([f64; 2], [f64; 2])> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [(-d[0], a[0] - bx[0]), (d[0], bx[2] - a[0]), (-d[1], a[1] - bx[1]), (d[1], bx[3] - a[1])] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1]];
    Some((at(t0), at(t1)))
}

impl Device for Hp {
    fn receive(&mut self, byte: u8, ctx: &mut Ctx<'_>) {
        if self.esc.is_idle() && self.hs.enq == Some(byte) {
            // Enquire/acknowledge: answer once a block fits.
            self.ack_pending = true;
            self.update_flow(ctx);
            return;
        }
        let after_esc = self.esc == EscState::Esc;
        match self.esc.feed(byte) {
            EscFeed::Data => {
                // ESC not followed by '.' is not device control: both bytes are data.
                if after_esc {
                    self.store(0x1b, ctx);
                }
                self.store(byte, ctx);
            }
            EscFeed::Consumed => {}
            EscFeed::Command(cmd) => self.device_control(cmd, ctx),
            EscFeed::Error(code) => self.ext_error(code, ctx),
        }
    }

    fn run(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        loop {
            if self.lever_up {
                return None;
            }
            if self.busy_until > ctx.now {
                return Some(self.busy_until);
            }
            let b = self.buf.pop_front()?;
            self.consumed += 1;
            let mut events = std::mem::take(&mut self.events);
            self.parser.feed(b, &mut events);
            self.partial = if self.parser.is_idle() { 0 } else { self.partial + 1 };
            for ev in events.drain(..) {
                self.handle(ev, ctx);
            }
            self.events = events;
            self.update_flow(ctx);
        }
    }

    fn status(&self) -> DeviceStatus {
        DeviceStatus {
            buffer_used: self.buf.len(),
            buffer_capacity: self.capacity,
            idle: self.buf.is_empty() && self.busy_until <= Instant::now(),
            position: self.pos,
            pen_down: self.pen_down,
            state: if self.lever_up { "lever up".into() } else { "ready".into() },
            cts: !self.hs.hardwire || self.free() >= self.hs.block,
            xoff: self.xoff_sent,
        }
    }

    fn power_cycle(&mut self, ctx: &mut Ctx<'_>) {
        let cfg_motion = self.motion;
        self.buf.clear();
        self.esc = EscState::default();
        self.hs = Handshake::default();
        self.parser.reset();
        self.parser.reset_label_terminator();
        self.partial = 0;
        self.cur = None;
        self.capacity = self.physical;
        self.pen_down = false;
        ctx.record.lift();
        self.pen = 0;
        self.defaults();
        self.velocity = default_velocity(&cfg_motion);
        self.p1p2 = self.default_p1p2;
        self.oe = 0;
        self.ext = 0;
        self.initialized = true;
        self.p1p2_changed = false;
        self.busy_until = ctx.now;
        self.overflowing = false;
        self.xoff_sent = false;
        self.ack_pending = false;
        self.fail_next = None;
    }

    fn set_lever(&mut self, up: bool) -> Result<(), String> {
        self.lever_up = up;
        Ok(())
    }

    fn lose_input(&mut self) -> Result<(), String> {
        Err("an HP plotter answers each output instruction as it reaches it; losing lines is a GRBL fault".into())
    }

    fn alarm(&mut self, _code: u32, _ctx: &mut Ctx<'_>) -> Result<(), String> {
        Err("an HP plotter has no alarm state".into())
    }

    fn fail_next(&mut self, code: Option<u32>) {
        self.fail_next = Some(code.unwrap_or(oe::UNKNOWN));
    }

    fn consumed(&self) -> u64 {
        self.consumed
    }
}

#[cfg(test)]
mod tests;
