//! The board: the USB side and main loop, the interrupts, and the mechanism
//! they drive, on the board's own clock.
//!
//! The main loop takes bytes from the USB endpoint, assembles a command and
//! runs it at once. A command that needs room in the motion FIFO (or, for
//! HM and `CU,4`, an idle motion system) waits in a spin loop, as in the
//! firmware: while it waits the board reads nothing more, its OK is not
//! sent, and the bytes behind it stay with the host (the endpoint holds
//! [`RX_CAPACITY`] bytes; beyond that the host's writes wait). That delayed
//! OK is the flow control every EBB host relies on. The command finishes in
//! the tick the ISR makes room.
//!
//! The board never reads a clock: [`Board::advance_to`] moves it to a tick,
//! running the 25 kHz ISR tick by tick and the 1 kHz interrupt every 25th
//! tick (stretches where nothing moves are skipped at once).

use super::args::Args;
use super::clock::TICKS_PER_MS;
use super::firmware::Firmware;
use super::line::{Fed, LineBuffer};
use super::motion::{Command, Engine, Kind};
use super::motors::Motors;
use super::pen::PenServo;
use super::reply::{flag, Le, Out};
use super::servo::{Servos, PEN_RPN};
use super::trace::Trace;
use crate::record::Record;
use std::collections::VecDeque;

/// Bytes the board holds that it has not read yet: the 64-byte CDC endpoint
/// buffer and the 64-byte chunk the main loop pulled from it.
pub(crate) const RX_CAPACITY: usize = 128;
/// V+ as `QC` reads it with the supply on (about 9 V: plotink's "typical
/// reading is about 300, for 9 V input") and off.
pub(crate) const VPLUS_ADC_ON: u16 = 300;
pub(crate) const VPLUS_ADC_OFF: u16 = 0;
/// The current-setting voltage `QC` reads first (the manual's example, 1.27 V).
pub(crate) const RA0_ADC: u16 = 394;
/// Most of a nickname (`ST`) the flash keeps.
pub(crate) const NICKNAME_MAX: usize = 16;
/// Port B at power-on: RB1, RB3, RB4 outputs, the rest inputs with pull-ups.
const PORTB_TRIS: u8 = 0b1110_0101;

/// Where the board's output goes: reply bytes, and the record of the paper.
pub(crate) struct Io<'a> {
    pub out: &'a mut Vec<u8>,
    pub record: &'a mut Record,
    /// The `garbage` fault: the next reply is replaced by noise.
    pub garble: &'a mut bool,
}

/// Noise sent instead of a reply by the `garbage` fault (no reply has these
/// bytes), followed by the reply's own last line end.
const GARBAGE: &[u8] = b"\xfe#\x8f?\xa5!%";

impl Io<'_> {
    fn emit(&mut self, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        if std::mem::take(self.garble) {
            self.out.extend_from_slice(GARBAGE);
            let end = bytes.iter().rev().take_while(|b| matches!(b, b'\r' | b'\n')).count();
            self.out.extend_from_slice(&bytes[bytes.len() - end..]);
        } else {
            self.out.extend_from_slice(bytes);
        }
    }
}

/// What a waiting command waits for, and what it does then.
#[derive(Clone, Debug)]
pub(crate) enum Wait {
    /// Room in the FIFO for each of these, in order; a servo move on a pin
    /// switches that pin's power on as it goes in.
    Queue { cmds: VecDeque<Command>, servo_rpn: Option<u8>, ok: bool },
    /// HM: an idle motion system, then the move from the step counters.
    Home { rate: u32, target: [i32; 2] },
    /// 3.0.2 `CU,4`: an idle motion system, then the new depth.
    Depth(usize),
}

/// A command waiting in the main loop.
#[derive(Clone, Debug)]
pub(crate) struct Blocked {
    pub wait: Wait,
    pub args: Args,
    pub out: Out,
    pub name: [u8; 2],
}

/// How a command's handler left it.
pub(crate) enum Flow {
    Done,
    Wait(Wait),
}

/// 3.0.2's stepper disable timeout (`CU,61`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum StepperTimeout {
    #[default]
    Disabled,
    /// Armed: starts counting when the motion system next goes idle.
    Primed,
    /// Counting: milliseconds left until the motors are disabled.
    Timing(u32),
    Fired,
}

/// Settings the host changes with `CU`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Settings {
    pub ack: bool,
    pub limit_checks: bool,
    pub future: bool,
    pub auto_enable: bool,
    pub checksums: bool,
    pub power_threshold: u16,
    pub stepper_timeout_s: u16,
}

impl Settings {
    fn boot() -> Settings {
        Settings {
            ack: true,
            limit_checks: true,
            future: false,
            auto_enable: true,
            checksums: false,
            power_threshold: 0,
            stepper_timeout_s: 0,
        }
    }
}

/// The simulated EiBotBoard.
#[derive(Clone, Debug)]
pub(crate) struct Board {
    pub fw: Firmware,
    /// Stepper ticks since power-on.
    pub tick: u64,
    rx: VecDeque<u8>,
    line: LineBuffer,
    pub blocked: Option<Blocked>,
    /// Bytes the main loop has read since power-on.
    pub taken: u64,
    pub settings: Settings,
    pub stepper_timeout: StepperTimeout,
    pub engine: Engine,
    pub servos: Servos,
    pub pen: PenServo,
    pub motors: Motors,
    /// The PRG button was pressed since the last `QB` / `QG`.
    pub button: bool,
    /// 3.0.2: V+ fell below the `CU,60` threshold since the last `QG`.
    pub power_drop: bool,
    /// `SL` storage (2.8.1 uses the first).
    pub layer: [u8; 32],
    /// The nickname in flash (`ST`); survives power cycles.
    pub nickname: Vec<u8>,
    pub portb_lat: u8,
    pub portb_tris: u8,
    trace: Trace,
    /// Ticks in which the motion system was executing a command.
    pub busy_ticks: u64,
    /// Ticks the motion system stood empty between one command and the
    /// next (see [`crate::Record::starved_seconds`]).
    pub starved_ticks: u64,
    /// Ticks it has stood empty since the last command ended; `None`
    /// before the first command.
    empty_for: Option<u64>,
    /// A command stopped the carriage (ES): the path has a corner here.
    pub corner: bool,
    /// `RB` asked for a reboot (the board leaves USB and starts afresh).
    pub reboot_requested: bool,
    /// The `error` fault: the next command fails with this error number.
    pub fail_next: Option<u32>,
}

impl Board {
    /// A board just powered on (V+ present or not), with a nickname in flash.
    pub fn new(fw: Firmware, contact: u16, nickname: Vec<u8>, vplus: bool) -> Board {
        let pen = PenServo::new(contact);
        let motors = Motors::new(vplus);
        let trace = Trace::new(pen.on_paper(), motors.shaft());
        let mut b = Board {
            fw,
            tick: 0,
            rx: VecDeque::with_capacity(RX_CAPACITY),
            line: LineBuffer::new(!fw.is_v3()),
            blocked: None,
            taken: 0,
            settings: Settings::boot(),
            stepper_timeout: StepperTimeout::Disabled,
            engine: Engine::new(fw),
            servos: Servos::new(fw),
            pen,
            motors,
            button: false,
            power_drop: false,
            layer: [0; 32],
            nickname,
            portb_lat: 0,
            portb_tris: PORTB_TRIS,
            trace,
            busy_ticks: 0,
            starved_ticks: 0,
            empty_for: None,
            corner: false,
            reboot_requested: false,
            fail_next: None,
        };
        b.init_firmware();
        b
    }

    /// `UserInit`: what power-on and `R` set up in the firmware (the
    /// mechanism, the USB link and the flash are left as they are).
    pub fn init_firmware(&mut self) {
        let keep_checks = self.settings.limit_checks;
        self.settings = Settings::boot();
        if !self.fw.is_v3() {
            // 2.8.1 sets the limit-check flag only where it is declared.
            self.settings.limit_checks = keep_checks;
        }
        self.stepper_timeout = StepperTimeout::Disabled;
        self.engine = Engine::new(self.fw);
        self.motors.set_enabled([false, false]);
        self.motors.mode = 1;
        self.motors.driven = true;
        self.servos = Servos::new(self.fw);
        self.button = false;
        self.power_drop = false;
        self.layer = [0; 32];
        self.portb_lat = 0;
        self.portb_tris = PORTB_TRIS;
        // RCServo2_Init queues the pen going up (which switches the servo
        // power on and starts its countdown), then switches the power off;
        // 3.0.2's UserInit also stops the countdown. (2.8.1's keeps running
        // and switches off a servo that SR turned on within its 60 s.)
        let (up, rate) = (self.servos.up, self.servos.rate_up);
        self.servos.power_on();
        if let super::servo::Plan::Queue(c) = self.servos.plan(up, PEN_RPN, rate, 0) {
            self.servos.power_for(PEN_RPN);
            self.engine.push(c);
        }
        self.servos.power = false;
        if self.fw.is_v3() {
            self.servos.power_left_ms = 0;
        }
    }

    /// After a reset the carriage, the pen arm and the drawing are where
    /// they were; the drivers are off (the firmware starts with them so).
    pub fn adopt_mechanism(&mut self, old: &Board) {
        let vplus = self.motors.vplus;
        self.motors = old.motors.clone();
        self.motors.set_enabled([false, false]);
        self.motors.mode = 1;
        self.motors.driven = true;
        self.motors.set_vplus(vplus);
        self.pen = old.pen.clone();
        self.trace = old.trace.clone();
    }

    /// Room left in the USB endpoint.
    pub fn rx_space(&self) -> usize {
        RX_CAPACITY - self.rx.len()
    }

    /// Bytes received and not yet read, the command being assembled included.
    pub fn buffered(&self) -> usize {
        self.rx.len() + self.line.len()
    }

    /// A byte from the host (the caller respects [`Board::rx_space`]).
    pub fn receive(&mut self, byte: u8) {
        if self.rx.len() < RX_CAPACITY {
            self.rx.push_back(byte);
        }
    }

    /// The servo has power: its switch is on and V+ feeds its regulator.
    pub fn servo_powered(&self) -> bool {
        self.servos.power && self.motors.vplus
    }

    /// V+ as the ADC reads it.
    pub fn vplus_adc(&self) -> u16 {
        if self.motors.vplus {
            VPLUS_ADC_ON
        } else {
            VPLUS_ADC_OFF
        }
    }

    /// Nothing waiting, nothing received, nothing moving, the pen at rest.
    pub fn idle(&self) -> bool {
        self.rx.is_empty()
            && self.blocked.is_none()
            && self.engine.idle()
            && self.servos.settled()
            && self.pen.settled(self.servo_powered())
    }

    /// Runs the board up to `target`.
    pub fn advance_to(&mut self, target: u64, io: &mut Io<'_>) {
        loop {
            self.main_loop(io);
            if self.tick >= target {
                return;
            }
            let skip = self.quiet_ticks().min(target - self.tick);
            if skip > 1 {
                self.skip(skip - 1);
            }
            self.isr_tick(io);
        }
    }

    /// Runs the board until its motion system is idle and no command waits,
    /// or for at most `limit` ticks; returns whether it got there.
    pub fn settle(&mut self, limit: u64, io: &mut Io<'_>) -> bool {
        let end = self.tick + limit;
        loop {
            self.main_loop(io);
            if self.blocked.is_none() && self.rx.is_empty() && self.engine.idle() {
                return true;
            }
            if self.tick >= end {
                return false;
            }
            let skip = self.quiet_ticks().min(end - self.tick);
            if skip > 1 {
                self.skip(skip - 1);
            }
            self.isr_tick(io);
        }
    }

    /// The next tick at which something happens by itself (None: nothing
    /// until input or a fault).
    pub fn next_event(&self) -> Option<u64> {
        if !self.engine.idle() || self.blocked.is_some() || !self.rx.is_empty() {
            return Some(self.tick + 1);
        }
        let quiet = self.quiet_ticks();
        (quiet != u64::MAX).then(|| self.tick + quiet.max(1))
    }

    /// Ticks from now in which only counters run (the ISR has nothing to
    /// do, the servo is settled): they can be computed at once.
    fn quiet_ticks(&self) -> u64 {
        if self.blocked.is_some() || !self.rx.is_empty() {
            return 0;
        }
        let engine = self.engine.quiet_ticks();
        if engine == 0 || !self.servos.settled() || !self.pen.settled(self.servo_powered()) {
            return 0;
        }
        let to_ms = TICKS_PER_MS - self.tick % TICKS_PER_MS;
        let stepper = match self.stepper_timeout {
            StepperTimeout::Primed if self.engine.idle() => return 0,
            StepperTimeout::Timing(left) => to_ms + u64::from(left.saturating_sub(1)) * TICKS_PER_MS,
            _ => u64::MAX,
        };
        // Stop short of the next 1 ms interrupt that switches the servo off.
        let power = self.servos.power_off_in_ms().map_or(u64::MAX, |ms| to_ms + (u64::from(ms) - 1) * TICKS_PER_MS);
        // A power drop below the threshold is seen on the next millisecond.
        let low = self.vplus_adc() < self.settings.power_threshold;
        let watch = if self.fw.is_v3() && low && !self.power_drop { to_ms } else { u64::MAX };
        engine.min(power).min(watch).min(stepper)
    }

    /// Skips `n` quiet ticks.
    fn skip(&mut self, n: u64) {
        let ms_before = self.tick / TICKS_PER_MS;
        if self.engine.executing() {
            self.busy_ticks += n;
        }
        if let Some(empty) = self.empty_for.as_mut().filter(|_| self.engine.idle()) {
            *empty += n;
        }
        self.engine.skip(n);
        self.tick += n;
        let ms = self.tick / TICKS_PER_MS - ms_before;
        self.servos.skip_ms(ms);
        if let StepperTimeout::Timing(left) = &mut self.stepper_timeout {
            *left -= ms as u32;
        }
    }

    /// One tick of the stepper ISR (and of the 1 ms interrupt on every 25th).
    fn isr_tick(&mut self, io: &mut Io<'_>) {
        self.tick += 1;
        if self.engine.executing() {
            self.busy_ticks += 1;
        }
        let t = self.engine.tick();
        self.count_starved(t.loaded);
        for axis in 0..2 {
            if t.step[axis] != 0 {
                let shaft = self.motors.shaft();
                self.trace.before_step(shaft, axis, t.step[axis], io.record);
                self.motors.step(axis, t.step[axis]);
            }
        }
        // An axis that finishes while the other has more than a step to go
        // bends the path (a one-step kink is within the record's tolerance).
        let bend = (0..2).any(|a| t.axis_done[a] && self.engine.active[1 - a] && self.engine.current.steps[1 - a] > 1);
        if bend || t.ended.is_some_and(Kind::is_motion) {
            self.trace.boundary(self.motors.shaft(), io.record);
        }
        if let Some(s) = t.servo {
            self.servos.apply(s);
            if s.rpn == self.servos.pen_rpn && self.servos.use_solenoid {
                self.set_portb_bit(4, !self.servos.pen_up);
            }
        }
        if let Some([e1, e2]) = t.enable {
            if (1..=5).contains(&e1) {
                self.motors.mode = e1;
            }
            self.motors.set_enabled([e1 > 0, e2 > 0]);
            self.trace.boundary(self.motors.shaft(), io.record);
        }
        if self.fw.is_v3() {
            // 3.0.2's stepper timeout: armed by every command loaded, counting
            // once the motion system runs dry.
            if t.loaded && self.stepper_timeout != StepperTimeout::Disabled {
                self.stepper_timeout = StepperTimeout::Primed;
            }
            if self.stepper_timeout == StepperTimeout::Primed && self.engine.idle() {
                self.stepper_timeout = StepperTimeout::Timing(1000 * u32::from(self.settings.stepper_timeout_s));
            }
        }
        if self.tick % TICKS_PER_MS == 0 {
            self.ms_tick(io);
        }
    }

    /// Counts a tick of the motion system standing empty, and the empty
    /// ticks since the last command as starved once a move is `loaded`
    /// (a pen move or `EM` after a wait starts the count afresh: the wait
    /// before the run's last pen lift is no stutter).
    fn count_starved(&mut self, loaded: bool) {
        if loaded {
            let empty = self.empty_for.replace(0).unwrap_or(0);
            if self.engine.current.kind.is_motion() {
                self.starved_ticks += empty;
            }
        } else if let Some(empty) = self.empty_for.as_mut().filter(|_| self.engine.idle()) {
            *empty += 1;
        }
    }

    /// The 1 ms interrupt: servo slots and slewing, the servo power
    /// countdown, the stepper timeout, the V+ watch; and the pen mechanism.
    fn ms_tick(&mut self, io: &mut Io<'_>) {
        let pulse = self.servos.ms_tick();
        if let StepperTimeout::Timing(left) = self.stepper_timeout {
            self.stepper_timeout = if left <= 1 {
                self.motors.set_enabled([false, false]);
                StepperTimeout::Fired
            } else {
                StepperTimeout::Timing(left - 1)
            };
        }
        if self.fw.is_v3() && self.vplus_adc() < self.settings.power_threshold {
            self.power_drop = true;
        }
        let powered = self.servo_powered();
        self.pen.ms_tick(powered, pulse);
        let on = self.pen.on_paper();
        self.trace.contact(on, self.motors.shaft(), io.record);
    }

    /// Reads and runs commands until the input is used up or a command waits.
    fn main_loop(&mut self, io: &mut Io<'_>) {
        loop {
            if let Some(b) = self.blocked.take() {
                match self.resume(b, io) {
                    Some(still) => {
                        self.blocked = Some(still);
                        return;
                    }
                    None => continue,
                }
            }
            let Some(byte) = self.rx.pop_front() else { return };
            self.taken += 1;
            match self.line.feed(byte) {
                Fed::Nothing => {}
                Fed::Echo(e) => io.emit(&e),
                Fed::Overrun => {
                    let mut out = self.out();
                    out.flag(flag::RX_OVERRUN);
                    out.print_errors();
                    self.emit(out, io);
                }
                Fed::Command(line) => self.command(&line, io),
            }
        }
    }

    /// A fresh reply in the syntax in force.
    pub fn out(&self) -> Out {
        Out::new(self.fw, self.settings.future, self.settings.ack)
    }

    fn emit(&mut self, out: Out, io: &mut Io<'_>) {
        for (n, message) in &out.logged {
            io.record.error("ebb", *n, message);
        }
        io.emit(&out.bytes);
    }

    /// Runs one complete command (`parse_packet`).
    fn command(&mut self, line: &[u8], io: &mut Io<'_>) {
        let mut out = self.out();
        let mut line = line.to_vec();
        if self.fw.is_v3() && self.settings.checksums && !self.check_sum(&mut line, &mut out) {
            out.print_errors();
            self.emit(out, io);
            return;
        }
        if let Some(code) = self.fail_next.take() {
            out.flag(match code {
                3 => flag::RX_OVERRUN,
                4 => flag::MISSING,
                7 => flag::EXTRA,
                _ => flag::OUT_OF_RANGE,
            });
            out.print_errors();
            self.emit(out, io);
            return;
        }
        let c1 = line.first().copied().unwrap_or(b'\r').to_ascii_uppercase();
        let second = line.get(1).copied().filter(|&b| b != b',');
        let c2 = second.map_or(0, |b| b.to_ascii_uppercase());
        out.name = if c2 == 0 { vec![c1] } else { vec![c1, c2] };
        let mut args = Args::new(&line, if c2 == 0 { 1 } else { 2 });
        let name = [c1, c2];
        let flow = self.dispatch(name, &mut args, &mut out);
        if std::mem::take(&mut self.corner) {
            self.trace.boundary(self.motors.shaft(), io.record);
        }
        match flow {
            Flow::Done => self.finish(name, &args, out, io),
            Flow::Wait(wait) => {
                // What was printed before the wait goes out now (3.0.2
                // future syntax prints the command's name first).
                let printed = std::mem::take(&mut out.bytes);
                io.emit(&printed);
                self.blocked = Some(Blocked { wait, args, out, name });
            }
        }
    }

    /// The end of `parse_packet`: unread arguments are an error (except
    /// after `R`), then the error flags are printed.
    fn finish(&mut self, name: [u8; 2], args: &Args, mut out: Out, io: &mut Io<'_>) {
        if !args.at_end() && out.errors == 0 && name != [b'R', 0] {
            out.flag(flag::EXTRA);
        }
        out.print_errors();
        self.emit(out, io);
    }

    /// Tries to finish a waiting command; gives it back if it must wait on.
    fn resume(&mut self, mut b: Blocked, io: &mut Io<'_>) -> Option<Blocked> {
        match &mut b.wait {
            Wait::Queue { cmds, servo_rpn, ok } => {
                while let Some(c) = cmds.front() {
                    if !self.engine.has_room() {
                        return Some(b);
                    }
                    if c.kind == Kind::Servo {
                        if let Some(rpn) = *servo_rpn {
                            self.servos.power_for(rpn);
                        }
                    }
                    self.engine.push(*c);
                    cmds.pop_front();
                }
                if *ok {
                    b.out.le(Le::Ok);
                }
            }
            Wait::Home { rate, target } => {
                let idle = self.engine.current.kind == Kind::None && self.engine.current.delay == 0;
                let room = if self.fw.is_v3() { self.engine.has_room() } else { self.engine.fifo_len() == 0 };
                if !(idle && room) {
                    return Some(b);
                }
                let (rate, target) = (*rate, *target);
                match self.home(rate, target, &mut b.out) {
                    Flow::Done => {}
                    Flow::Wait(w) => {
                        b.wait = w;
                        return self.resume(b, io);
                    }
                }
            }
            Wait::Depth(depth) => {
                if self.engine.status_bits() != 0 {
                    return Some(b);
                }
                self.engine.set_depth(*depth);
                b.out.le(Le::Ok);
            }
        }
        let Blocked { args, out, name, .. } = b;
        self.finish(name, &args, out, io);
        None
    }

    /// Sets a port B output latch bit.
    pub fn set_portb_bit(&mut self, bit: u8, high: bool) {
        if high {
            self.portb_lat |= 1 << bit;
        } else {
            self.portb_lat &= !(1 << bit);
        }
    }

    /// A port B pin as `PI` reads it: inputs are pulled up, outputs read
    /// their latch (the servo pin's pulses are short: it reads low).
    pub fn portb_pin(&self, bit: u8) -> bool {
        if bit == 1 && self.servos.pen_pin_value() != 0 {
            return false;
        }
        if self.portb_tris & (1 << bit) != 0 {
            true
        } else {
            self.portb_lat & (1 << bit) != 0
        }
    }

    /// The PRG button is pressed.
    pub fn press_button(&mut self) {
        self.button = true;
    }

    /// V+ goes or comes back. The carriage's end of the open stroke is
    /// marked first (the motors stop holding it).
    /// A person pushes the carriage home (where the board powered on) by
    /// hand, the pen up; only with the motors let go and nothing moving.
    pub fn park(&mut self, io: &mut Io<'_>) -> Result<(), String> {
        if !self.engine.idle() {
            return Err("the carriage is moving: park it once the board is idle".into());
        }
        if self.motors.holding() {
            return Err("the motors hold the carriage: turn them off (EM,0,0) or cut V+ first".into());
        }
        if self.pen.on_paper() {
            return Err("the pen is on the paper: raise it first".into());
        }
        self.trace.boundary(self.motors.shaft(), io.record);
        self.motors.park();
        self.trace.boundary(self.motors.shaft(), io.record);
        Ok(())
    }

    pub fn set_vplus(&mut self, on: bool, io: &mut Io<'_>) {
        self.trace.boundary(self.motors.shaft(), io.record);
        self.motors.set_vplus(on);
        self.trace.boundary(self.motors.shaft(), io.record);
        if self.fw.is_v3() && self.vplus_adc() < self.settings.power_threshold {
            self.power_drop = true;
        }
    }

    /// 3.0.2 checksums (`CU,54,1`): the last argument is the two's
    /// complement of the sum of the bytes before its comma. True when the
    /// command may run (its checksum cut off).
    fn check_sum(&mut self, line: &mut Vec<u8>, out: &mut Out) -> bool {
        let mut i = line.len();
        let mut len = 0;
        while i > 0 && line[i - 1] != b',' && len < 5 {
            i -= 1;
            len += 1;
        }
        if i == 0 || line[i - 1] != b',' {
            out.error_line(8, "!8 Err: Checksum not found but required.", Le::Norm);
            return false;
        }
        let comma = i - 1;
        let mut args = Args::new(line, comma);
        let given = args.number(super::args::Ty::UChar, true, out).unwrap_or(0) as u8;
        let sum = line[..comma].iter().fold(0u8, |s, &b| s.wrapping_add(b));
        let expected = (!sum).wrapping_add(1);
        if given != expected {
            out.error_line(8, &format!("!8 Err: Checksum incorrect, expected {expected}"), Le::Norm);
            return false;
        }
        line.truncate(comma);
        true
    }
}
