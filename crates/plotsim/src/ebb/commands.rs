//! The commands, each as its firmware release parses, runs and answers it
//! (`ebb.c`, `UBW.c`, `RCServo2.c`). Where the two releases differ the
//! handler says so; the control flow is the firmware's, including its
//! oddities (an error flagged and then an OK printed, a reply that stops
//! short), because hosts meet them.

use super::args::{Args, Ty};
use super::board::{Board, Flow, Wait, NICKNAME_MAX, RA0_ADC};
use super::motion::{Command, Kind};
use super::rates::{self, Axis};
use super::reply::{flag, Le, Out};
use super::servo::{Plan, PORTB_TO_RPN};
use std::collections::VecDeque;

/// Commands of the firmware that plotsim does not model (analog and digital
/// port dumps, memory access, pulse trains, the engraver, the bootloader,
/// node counters; 3.0.2's paired T3 and its queries and test commands). They
/// answer as an unknown command would and log an error saying so.
const NOT_MODELLED: &[&[u8]] =
    &[b"A", b"AC", b"BL", b"C", b"CK", b"I", b"MR", b"MW", b"O", b"PC", b"PG", b"SE", b"T", b"NI", b"ND", b"SN", b"QN"];
const NOT_MODELLED_V3: &[&[u8]] = &[b"TD", b"QU", b"TR"];

impl Board {
    /// Runs a command; `name` is its one or two upper-cased letters.
    pub(super) fn dispatch(&mut self, name: [u8; 2], a: &mut Args, o: &mut Out) -> Flow {
        match &name {
            b"V\0" => self.version(o),
            b"QT" => self.query_tag(o),
            b"ST" => self.set_tag(a, o),
            b"EM" => return self.enable_motors(a, o),
            b"SM" => return self.stepper_move(a, o),
            b"XM" => return self.mixed_move(a, o),
            b"LM" => return self.low_level_move(a, o, false, false),
            b"LT" => return self.low_level_move(a, o, true, false),
            b"L3" if self.fw.is_v3() => return self.low_level_move(a, o, false, true),
            b"T3" if self.fw.is_v3() => return self.low_level_move(a, o, true, true),
            b"HM" => return self.home_move(a, o),
            b"ES" => self.e_stop(a, o),
            b"SP" => return self.set_pen(a, o),
            b"TP" => return self.toggle_pen(a, o),
            b"S2" => return self.servo_output(a, o),
            b"SC" => return self.configure(a, o),
            b"SR" => self.servo_timeout(a, o),
            b"CU" => return self.configure_user(a, o),
            b"R\0" => self.reset(o),
            b"RB" => self.reboot(),
            b"CS" => {
                o.name(false, false);
                self.engine.clear_counters();
                o.le(Le::Ok);
            }
            b"QS" => {
                let c = self.engine.counters;
                self.answer(o, false, &format!("{},{}", c[0], c[1]), Le::Rev, true);
            }
            b"QM" => {
                let s = self.engine.status_bits();
                let text = format!("QM,{},{},{},{}", s >> 3 & 1, s >> 2 & 1, s >> 1 & 1, s & 1);
                if self.fw.is_v3() {
                    o.name(true, true);
                    o.text(&text[3..]);
                } else {
                    o.text(&text);
                }
                o.le(Le::Rev);
            }
            b"QG" => self.query_general(o),
            b"QB" => {
                let b = u8::from(std::mem::take(&mut self.button));
                self.answer(o, false, &b.to_string(), Le::Norm, true);
            }
            b"QC" => {
                let text = if self.fw.is_v3() {
                    format!("{},{}", RA0_ADC, self.vplus_adc())
                } else {
                    format!("{:04},{:04}", RA0_ADC, self.vplus_adc())
                };
                self.answer(o, false, &text, Le::Norm, true);
            }
            b"QE" => {
                let res = 16 >> (self.motors.mode.clamp(1, 5) - 1);
                let state = |on: bool| if on { res } else { 0 };
                let text = format!("{},{}", state(self.motors.enabled[0]), state(self.motors.enabled[1]));
                self.answer(o, false, &text, Le::Rev, true);
            }
            b"QP" => {
                let up = u8::from(self.servos.pen_up);
                self.answer(o, false, &up.to_string(), Le::Rev, true);
            }
            b"QR" => {
                let p = u8::from(self.servos.power);
                let end = if self.fw.is_v3() { Le::Rev } else { Le::Norm };
                self.answer(o, false, &p.to_string(), end, true);
            }
            b"SL" => self.set_layer(a, o),
            b"QL" => self.query_layer(a, o),
            b"PI" => self.pin_input(a, o),
            b"PO" | b"PD" => self.pin_output(name[1] == b'D', a, o),
            _ => self.unknown(name, o),
        }
        Flow::Done
    }

    /// A query's answer: 3.0.2's name and comma, the data, the line end
    /// (legacy syntax only), then the OK if the query has one.
    fn answer(&self, o: &mut Out, always: bool, data: &str, end: Le, ok: bool) {
        o.name(always, true);
        o.text(data);
        if !(self.fw.is_v3() && self.settings.future) {
            o.le(end);
        }
        if ok {
            o.le(Le::Ok);
        }
    }

    fn unknown(&mut self, name: [u8; 2], o: &mut Out) {
        let letters: Vec<u8> = name.iter().copied().filter(|&b| b != 0).collect();
        let hex: String = letters.iter().map(|b| if self.fw.is_v3() { format!("{b:02X}") } else { format!("{b:2X}") }).collect();
        let mut message = b"!8 Err: Unknown command '".to_vec();
        message.extend_from_slice(&letters);
        message.extend_from_slice(format!(":{hex}'").as_bytes());
        o.error_bytes(8, &message, Le::Norm);
        if NOT_MODELLED.contains(&letters.as_slice()) || (self.fw.is_v3() && NOT_MODELLED_V3.contains(&letters.as_slice())) {
            o.logged.push((8, format!("{} is an EBB command plotsim does not model", String::from_utf8_lossy(&letters))));
        }
    }

    fn version(&mut self, o: &mut Out) {
        o.name(false, true);
        o.text(&self.fw.version_text());
        o.le(Le::Norm);
    }

    fn query_tag(&mut self, o: &mut Out) {
        // 2.8.1 prints a name that starts with a byte in 32..=127, 3.0.2 in 33..=127.
        let first = self.nickname.first().copied().unwrap_or(0);
        let shown = if self.fw.is_v3() { (33..128).contains(&first) } else { (32..128).contains(&first) };
        let name = if shown { String::from_utf8_lossy(&self.nickname).into_owned() } else { String::new() };
        self.answer(o, false, &name, Le::Norm, true);
    }

    fn set_tag(&mut self, a: &mut Args, o: &mut Out) {
        o.name(false, false);
        // The flash is rewritten even when the argument is missing (an empty name).
        self.nickname = a.string(NICKNAME_MAX, o);
        o.le(Le::Ok);
    }

    /// Queues `cmds` once the FIFO has room, then answers OK.
    fn queue(&mut self, cmds: impl IntoIterator<Item = Command>) -> Flow {
        Flow::Wait(Wait::Queue { cmds: cmds.into_iter().collect(), servo_rpn: None, ok: true })
    }

    /// SM/XM/LM/LT switch both drivers on as they are parsed (3.0.2: unless `CU,50,0`).
    fn auto_enable(&mut self) {
        if self.settings.auto_enable {
            self.motors.set_enabled([true, true]);
        }
    }

    fn enable_motors(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        // Both arguments are needed since 2.8.0; without the second the
        // command does nothing and answers nothing.
        let Ok(e1) = a.number(Ty::UChar, true, o) else { return Flow::Done };
        let Ok(e2) = a.number(Ty::UChar, false, o) else { return Flow::Done };
        if o.errors != 0 {
            return Flow::Done;
        }
        self.queue([Command { kind: Kind::Enable, enable: [e1 as u8, e2 as u8], ..Command::default() }])
    }

    fn stepper_move(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let duration = a.req(Ty::ULong, o).unwrap_or(0) as u32;
        let s1 = a.req(Ty::Long, o).unwrap_or(0) as i32;
        let s2 = a.opt(Ty::Long, o).unwrap_or(0) as i32;
        if self.fw.is_v3() {
            let clear = a.opt(Ty::ULong, o).unwrap_or(0) as u32;
            if o.errors != 0 {
                return Flow::Done;
            }
            return self.simple_move_v3(duration, [s1, s2], clear, o);
        }
        let mut clear = a.opt(Ty::UChar, o).unwrap_or(0) as u8;
        if self.settings.limit_checks {
            if duration == 0 {
                o.flag(flag::OUT_OF_RANGE);
            }
            if o.errors != 0 {
                return Flow::Done;
            }
            if let Some(message) = rates::v2_sm_limits(duration, [s1, s2]) {
                o.text(message);
                o.logged.push((0, message.trim_end().to_string()));
                return Flow::Done;
            }
            if clear > 3 {
                clear = 0;
            }
        }
        self.simple_move_v2(duration, [s1, s2], clear, o)
    }

    /// 2.8.1 `process_SM`, then OK.
    fn simple_move_v2(&mut self, duration: u32, steps: [i32; 2], clear: u8, o: &mut Out) -> Flow {
        let c = rates::v2_sm(duration, steps, clear);
        for note in &c.notes {
            o.text(note);
        }
        if c.command.kind != Kind::Delay {
            self.auto_enable();
        }
        self.queue([c.command])
    }

    /// 3.0.2 `process_simple_motor_move_fp`, then OK (also after its errors).
    fn simple_move_v3(&mut self, duration: u32, steps: [i32; 2], clear: u32, o: &mut Out) -> Flow {
        let checks = self.settings.limit_checks;
        if checks {
            if duration == 0 || clear > 3 {
                o.flag(flag::OUT_OF_RANGE);
            }
            if o.errors != 0 {
                o.le(Le::Ok);
                return Flow::Done;
            }
        }
        if steps != [0, 0] {
            self.auto_enable();
        }
        match rates::v3_sm(duration, steps, clear, checks) {
            Ok(c) => self.queue([c]),
            Err((axis, which)) => {
                o.error_line(0, rates::V3_RATE_ERRORS[axis][which], Le::Rev);
                o.le(Le::Ok);
                Flow::Done
            }
        }
    }

    fn mixed_move(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let duration = a.req(Ty::ULong, o).unwrap_or(0) as u32;
        let sa = a.req(Ty::Long, o).unwrap_or(0) as i32;
        let sb = a.req(Ty::Long, o).unwrap_or(0) as i32;
        let steps = [sa.wrapping_add(sb), sa.wrapping_sub(sb)];
        if self.fw.is_v3() {
            let clear = a.opt(Ty::ULong, o).unwrap_or(0) as u32;
            return self.simple_move_v3(duration, steps, clear, o);
        }
        let clear = (a.opt(Ty::UChar, o).unwrap_or(0) as u8).min(3);
        // 2.8.1 checks XM's rates whatever CU,2 says.
        if duration == 0 {
            o.flag(flag::OUT_OF_RANGE);
        }
        if let Some(message) = rates::v2_sm_limits(duration, steps) {
            o.text(message);
            o.logged.push((0, message.trim_end().to_string()));
            return Flow::Done;
        }
        if o.errors != 0 {
            return Flow::Done;
        }
        self.simple_move_v2(duration, steps, clear, o)
    }

    /// LM, LT and (3.0.2) their jerk forms L3, T3.
    fn low_level_move(&mut self, a: &mut Args, o: &mut Out, timed: bool, with_jerk: bool) -> Flow {
        o.name(false, false);
        let v3 = self.fw.is_v3();
        let rate_ty = if v3 || timed { Ty::Long } else { Ty::ULong };
        let mut intervals = 0u32;
        let mut ax = [Axis::default(); 2];
        if timed {
            intervals = a.req(Ty::ULong, o).unwrap_or(0) as u32;
        }
        for axis in &mut ax {
            axis.rate = a.req(rate_ty, o).unwrap_or(0) as u32 as i32;
            if !timed {
                axis.steps = a.req(Ty::Long, o).unwrap_or(0) as i32;
            }
            axis.accel = a.req(Ty::Long, o).unwrap_or(0) as i32;
            if with_jerk {
                axis.jerk = a.req(Ty::Long, o).unwrap_or(0) as i32;
            }
        }
        let clear = a.opt(if v3 { Ty::ULong } else { Ty::UChar }, o).unwrap_or(0) as u32;
        if o.errors != 0 {
            return Flow::Done;
        }
        if !v3 {
            let cmd = if timed {
                if intervals == 0 || (ax[0].rate == 0 && ax[1].rate == 0) {
                    o.flag(flag::OUT_OF_RANGE);
                    return Flow::Done;
                }
                rates::v2_lt(intervals, [ax[0].rate, ax[1].rate], [ax[0].accel, ax[1].accel], clear as u8)
            } else {
                // Rates are unsigned here; the check sees them clamped.
                let rate = [(ax[0].rate as u32).min(0x7FFF_FFFF), (ax[1].rate as u32).min(0x7FFF_FFFF)];
                let dead = |i: usize| (rate[i] == 0 && ax[i].accel == 0) || ax[i].steps == 0;
                if dead(0) && dead(1) {
                    o.flag(flag::OUT_OF_RANGE);
                    return Flow::Done;
                }
                rates::v2_lm(rate, [ax[0].steps, ax[1].steps], [ax[0].accel, ax[1].accel], clear as u8)
            };
            self.auto_enable();
            return self.queue([cmd]);
        }
        if self.settings.limit_checks {
            // L3 checks axis 2's jerk as axis 1's (as the firmware does).
            let jerk1 = ax[0].jerk;
            let dead = |x: &Axis| (x.rate == 0 && x.accel == 0 && jerk1 == 0) || x.steps == 0;
            if (timed && intervals == 0) || (!timed && dead(&ax[0]) && dead(&ax[1])) {
                o.flag(flag::OUT_OF_RANGE);
                return Flow::Done;
            }
        }
        // 3.0.2 answers OK after `process_low_level_move` even when that refused the move.
        match rates::v3_low_level(timed.then_some(intervals), ax, clear) {
            Ok(cmd) => {
                self.auto_enable();
                self.queue([cmd])
            }
            Err(_) => {
                o.flag(flag::OUT_OF_RANGE);
                o.le(Le::Ok);
                Flow::Done
            }
        }
    }

    fn home_move(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let mut rate = a.req(Ty::ULong, o).unwrap_or(0) as u32;
        let p1 = a.opt(Ty::Long, o).unwrap_or(0) as i32;
        let p2 = a.opt(Ty::Long, o).unwrap_or(0) as i32;
        if self.fw.is_v3() {
            rate = rate.clamp(1, 25_000);
        } else if rate == 0 {
            o.flag(flag::OUT_OF_RANGE);
            return Flow::Done;
        }
        Flow::Wait(Wait::Home { rate, target: [p1, p2] })
    }

    /// HM once the motion system is idle: the move from the step counters.
    pub(super) fn home(&mut self, rate: u32, target: [i32; 2], o: &mut Out) -> Flow {
        let counters = self.engine.counters;
        if self.fw.is_v3() {
            let steps = [target[0].wrapping_sub(counters[0]), target[1].wrapping_sub(counters[1])];
            return match rates::v3_rate_move(rate, steps) {
                Some(c) => {
                    self.auto_enable();
                    self.queue([c])
                }
                None => {
                    o.le(Le::Ok);
                    Flow::Done
                }
            };
        }
        match rates::v2_home(rate, counters, target) {
            Err(message) => {
                o.text(message);
                o.logged.push((0, message.trim_end().to_string()));
                Flow::Done
            }
            Ok(moves) => {
                let mut cmds = VecDeque::new();
                for m in moves {
                    for note in &m.notes {
                        o.text(note);
                    }
                    if m.command.kind != Kind::Delay {
                        self.auto_enable();
                    }
                    cmds.push_back(m.command);
                }
                self.queue(cmds)
            }
        }
    }

    fn e_stop(&mut self, a: &mut Args, o: &mut Out) {
        o.name(false, true);
        let disable = a.opt(Ty::UChar, o).unwrap_or(0);
        if o.errors != 0 {
            return;
        }
        let s = self.engine.stop();
        // The carriage stops where it is: a corner in the drawn path.
        self.corner = true;
        if disable == 1 {
            self.motors.set_enabled([false, false]);
        }
        let i = u8::from(s.interrupted);
        let text = if self.fw.is_v3() {
            i.to_string()
        } else {
            format!("{i},{},{},{},{}", s.fifo_steps[0], s.fifo_steps[1], s.remaining[0], s.remaining[1])
        };
        o.text(&text);
        if !(self.fw.is_v3() && self.settings.future) {
            o.le(Le::Rev);
        }
        o.le(Le::Ok);
    }

    fn set_pen(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let state = a.req(Ty::UChar, o).unwrap_or(0) as u8;
        let duration = a.opt(Ty::UInt, o).unwrap_or(0) as u16;
        let mut pin = a.opt(Ty::UChar, o).unwrap_or(1) as u8;
        if o.errors != 0 {
            return Flow::Done;
        }
        if pin > 7 {
            pin = 1;
        }
        let state = state.min(if self.fw.is_v3() { 3 } else { 1 });
        if self.servos.pen_rpn != pin + PORTB_TO_RPN {
            // Moving the pen to another pin switches the old one off first.
            self.servos.plan(0, self.servos.pen_rpn, 0, 0);
            self.servos.pen_rpn = pin + PORTB_TO_RPN;
        }
        self.pen_move(state, duration, o)
    }

    fn toggle_pen(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let duration = a.opt(Ty::UInt, o).unwrap_or(0) as u16;
        if o.errors != 0 {
            return Flow::Done;
        }
        self.pen_move(u8::from(!self.servos.pen_up), duration, o)
    }

    /// `process_SP`: 0 down, 1 up (queued); 3.0.2's 2 up now, 3 up now and
    /// every queued pen move made a move up, and down made up until `SC,5`.
    fn pen_move(&mut self, state: u8, duration: u16, o: &mut Out) -> Flow {
        self.servos.power_on();
        if state >= 2 {
            if state == 3 {
                self.servos.down = self.servos.up;
                let (rpn, up) = (self.servos.pen_rpn, self.servos.up);
                for c in self.engine.queued_mut() {
                    if c.kind == Kind::Servo && c.servo.rpn == rpn {
                        c.servo.position = up;
                    }
                }
            }
            self.servos.lift_now();
            o.le(Le::Ok);
            return Flow::Done;
        }
        let (position, rate) = if state == 1 { (self.servos.up, self.servos.rate_up) } else { (self.servos.down, self.servos.rate_down) };
        let rpn = self.servos.pen_rpn;
        self.servo_plan(position, rpn, rate, duration, o)
    }

    /// `RCServo2_Move` through the FIFO, then OK.
    fn servo_plan(&mut self, position: u16, rpn: u8, rate: u16, delay: u16, o: &mut Out) -> Flow {
        match self.servos.plan(position, rpn, rate, delay) {
            Plan::Queue(c) => Flow::Wait(Wait::Queue { cmds: VecDeque::from([c]), servo_rpn: Some(rpn), ok: true }),
            Plan::Nothing | Plan::Disabled => {
                o.le(Le::Ok);
                Flow::Done
            }
        }
    }

    fn servo_output(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        let position = a.opt(Ty::UInt, o).unwrap_or(0) as u16;
        let pin = a.opt(Ty::UChar, o).unwrap_or(0) as u8;
        let rate = a.opt(Ty::UInt, o).unwrap_or(0) as u16;
        let delay = a.opt(Ty::UInt, o).unwrap_or(0) as u16;
        o.name(false, false);
        if o.errors != 0 {
            return Flow::Done;
        }
        if pin > 24 {
            o.flag(flag::OUT_OF_RANGE);
            return Flow::Done;
        }
        self.servo_plan(position, pin, rate, delay, o)
    }

    fn configure(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let what = a.req(Ty::UChar, o).unwrap_or(0);
        let value = a.req(Ty::UInt, o).unwrap_or(0) as u16;
        if o.errors != 0 {
            return Flow::Done;
        }
        match what {
            1 => {
                (self.servos.use_solenoid, self.servos.use_servo) = match value {
                    0 => (true, false),
                    1 => (false, true),
                    _ => (true, true),
                };
                if value == 0 {
                    self.servos.plan(0, self.servos.pen_rpn, 0, 0);
                }
                // The pen is sent where it is, through the FIFO.
                return self.pen_move(u8::from(self.servos.pen_up), 0, o);
            }
            2 if value <= 2 => self.motors.driven = value == 0,
            4 => self.servos.up = value,
            5 => self.servos.down = value,
            8 => self.servos.set_slots(value),
            9 => self.servos.set_slot_ms(value),
            10 => (self.servos.rate_up, self.servos.rate_down) = (value, value),
            11 => self.servos.rate_up = value,
            12 => self.servos.rate_down = value,
            _ => {}
        }
        o.le(Le::Ok);
        Flow::Done
    }

    fn servo_timeout(&mut self, a: &mut Args, o: &mut Out) {
        o.name(false, false);
        let ms = a.req(Ty::ULong, o).unwrap_or(0) as u32;
        let state = a.opt(Ty::UChar, o);
        if o.errors != 0 {
            return;
        }
        self.servos.power_timeout_ms = ms;
        if let Some(s) = state {
            // The switch only: the countdown is left as it is.
            self.servos.power = s != 0;
        }
        o.le(Le::Ok);
    }

    fn configure_user(&mut self, a: &mut Args, o: &mut Out) -> Flow {
        o.name(false, false);
        let what = a.req(if self.fw.is_v3() { Ty::UInt } else { Ty::UChar }, o).unwrap_or(0);
        let value = a.req(Ty::Int, o).unwrap_or(0);
        if o.errors != 0 {
            return Flow::Done;
        }
        let bool_value = |o: &mut Out| match value {
            0 | 1 => Some(value == 1),
            _ => {
                o.flag(flag::OUT_OF_RANGE);
                None
            }
        };
        match what {
            1 => {
                if let Some(v) = bool_value(o) {
                    self.settings.ack = v;
                    o.ack = v;
                }
            }
            2 => {
                if let Some(v) = bool_value(o) {
                    self.settings.limit_checks = v;
                }
            }
            3 => {
                bool_value(o);
            }
            4 if self.fw.is_v3() => {
                // A depth of 0 or less leaves no room: the next queued command
                // waits for ever, as it spins on the board.
                let depth = usize::try_from(value).unwrap_or(0);
                return Flow::Wait(Wait::Depth(depth));
            }
            10 if self.fw.is_v3() => {
                if let Some(v) = bool_value(o) {
                    self.settings.future = v;
                    o.future = v;
                }
            }
            50 if self.fw.is_v3() => self.settings.auto_enable = value != 0,
            54 if self.fw.is_v3() => self.settings.checksums = value == 1,
            60 if self.fw.is_v3() => self.settings.power_threshold = (value & 0x3FF) as u16,
            61 if self.fw.is_v3() => {
                let s = value as u16;
                self.settings.stepper_timeout_s = s;
                self.stepper_timeout = match (s, self.stepper_timeout) {
                    (0, _) => super::board::StepperTimeout::Disabled,
                    (_, super::board::StepperTimeout::Timing(_)) => super::board::StepperTimeout::Timing(1000 * u32::from(s)),
                    (_, super::board::StepperTimeout::Fired) => super::board::StepperTimeout::Fired,
                    _ => super::board::StepperTimeout::Primed,
                };
            }
            // 51..53 (limit switches: plotsim has none), 250..257 (firmware
            // debugging) and unknown numbers change nothing.
            _ => {}
        }
        o.le(Le::Ok);
        Flow::Done
    }

    fn reset(&mut self, o: &mut Out) {
        // Motion stops where it is.
        self.corner = true;
        if self.fw.is_v3() {
            o.name(false, false);
            o.le(Le::Ok);
            self.init_firmware();
        } else {
            // 2.8.1's init clears the step counters with the CS handler,
            // which prints its own OK before R's.
            self.init_firmware();
            o.ack = true;
            o.le(Le::Ok);
            o.le(Le::Ok);
        }
    }

    /// `RB`: the board drops off USB and restarts; no reply.
    fn reboot(&mut self) {
        self.reboot_requested = true;
    }

    fn query_general(&mut self, o: &mut Out) {
        let mut bits = self.engine.status_bits() & 0x0F;
        bits |= u8::from(self.servos.pen_up) << 4 | u8::from(self.button) << 5;
        if self.fw.is_v3() {
            bits |= u8::from(std::mem::take(&mut self.power_drop)) << 6;
        } else {
            bits |= u8::from(self.portb_pin(2)) << 6 | u8::from(self.portb_pin(5)) << 7;
        }
        self.button = false;
        o.name(false, true);
        o.text(&format!("{bits:02X}"));
        o.le(Le::Norm);
    }

    fn set_layer(&mut self, a: &mut Args, o: &mut Out) {
        o.name(false, false);
        let value = a.req(Ty::UChar, o).unwrap_or(0) as u8;
        let index = if self.fw.is_v3() { a.opt(Ty::UChar, o).unwrap_or(0) as usize } else { 0 };
        if o.errors != 0 {
            return;
        }
        self.layer[index.min(31)] = value;
        o.le(Le::Ok);
    }

    fn query_layer(&mut self, a: &mut Args, o: &mut Out) {
        if self.fw.is_v3() {
            o.name(false, true);
            let index = a.opt(Ty::UChar, o).unwrap_or(0) as usize;
            if o.errors != 0 {
                return;
            }
            let v = self.layer[index.min(31)];
            o.text(&v.to_string());
            if !self.settings.future {
                o.le(Le::Norm);
            }
            o.le(Le::Ok);
        } else {
            // The layer is a signed char printed with %03i.
            o.text(&format!("{:03}\r\n", self.layer[0] as i8));
            o.le(Le::Ok);
        }
    }

    /// `PI,port,pin`: port B as modelled; the driver pins plotink reads (E0
    /// and C1 enables, active low; E2, E1, A6 the microstep pins MS1..MS3);
    /// other pins read low.
    fn pin_input(&mut self, a: &mut Args, o: &mut Out) {
        let port = a.req(Ty::UpperChar, o).unwrap_or(0) as u8;
        let pin = a.req(Ty::UChar, o).unwrap_or(0) as u8;
        if o.errors != 0 {
            return;
        }
        if pin > 7 || !(b'A'..=b'E').contains(&port) {
            o.flag(flag::OUT_OF_RANGE);
            return;
        }
        let ms = match self.motors.mode {
            1 => [true, true, true],
            2 => [true, true, false],
            3 => [false, true, false],
            4 => [true, false, false],
            _ => [false, false, false],
        };
        let value = match (port, pin) {
            (b'B', p) => self.portb_pin(p),
            (b'E', 0) => !self.motors.enabled[0],
            (b'C', 1) => !self.motors.enabled[1],
            (b'E', 2) => ms[0],
            (b'E', 1) => ms[1],
            (b'A', 6) => ms[2],
            _ => false,
        };
        if self.fw.is_v3() {
            o.name(true, true);
            o.text(if value { "1" } else { "0" });
            o.le(Le::Norm);
        } else {
            o.text(if value { "PI,1\r\n" } else { "PI,0\r\n" });
        }
    }

    /// `PO,port,pin,value` and `PD,port,pin,direction`: port B is modelled.
    fn pin_output(&mut self, direction: bool, a: &mut Args, o: &mut Out) {
        o.name(false, false);
        let port = a.req(Ty::UpperChar, o).unwrap_or(0) as u8;
        let pin = a.req(Ty::UChar, o).unwrap_or(0) as u8;
        let value = a.req(Ty::UChar, o).unwrap_or(0);
        if o.errors != 0 {
            return;
        }
        if pin > 7 || value > 1 || !(b'A'..=b'E').contains(&port) {
            o.flag(flag::OUT_OF_RANGE);
            return;
        }
        if port == b'B' {
            if direction {
                if value == 1 {
                    self.portb_tris |= 1 << pin;
                } else {
                    self.portb_tris &= !(1 << pin);
                }
            } else {
                self.set_portb_bit(pin, value == 1);
            }
        }
        o.le(Le::Ok);
    }
}
