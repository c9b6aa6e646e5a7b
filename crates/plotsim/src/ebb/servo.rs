//! The RC servo system (`RCServo2.c` and the 1 ms interrupt of `UBW.c`),
//! the pen-lift settings of `SC` and the servo power switch of `SR`.
//!
//! The firmware cycles through `slots` channels of `slot_ms` milliseconds
//! each (8 × 3 ms by default, so a channel pulses every 24 ms). When a
//! channel's slot comes round and its pulse width is not yet at the target,
//! the width moves by the channel's rate (all the way if the rate is 0); then
//! the pulse goes out. The pen is the channel on pin RP4 (B1) by default;
//! `SP,1` sends it to `SC,4` ("servo_min", pen up), `SP,0` to `SC,5`
//! ("servo_max", pen down), at the rates of `SC,11` and `SC,12`. The 5 V
//! supply of connector B1 is switched (pin RA3): a servo move queued for RP4
//! switches it on and restarts a countdown (`SR`, 60 s at boot) that
//! switches it off.

use super::firmware::Firmware;
use super::motion::{Command, Kind, ServoTarget};

/// The pen servo's pin at boot: port B pin 1 is RP4.
pub(crate) const PEN_RPN: u8 = 4;
/// Port B pin `n` is RPn `n + 3`.
pub(crate) const PORTB_TO_RPN: u8 = 3;
/// The solenoid pen-lift output, RB4 (RP7): a servo on it stops the solenoid.
const SOLENOID_RPN: u8 = 7;
/// `SR` at boot: 60 s.
pub(crate) const POWER_TIMEOUT_MS: u32 = 60_000;

/// One software servo channel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Channel {
    /// Pulse width now, 83.3 ns units; 0 = no pulses.
    value: u16,
    target: u16,
    rate: u16,
    rpn: u8,
}

/// What [`Servos::plan`] makes of a servo move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Plan {
    /// No free channel, or a channel beyond the slots in use: nothing happens.
    Nothing,
    /// Position 0: the channel was switched off at once (never queued).
    Disabled,
    /// Queue this command once the FIFO has room.
    Queue(Command),
}

/// The RC servo system and the pen settings.
#[derive(Clone, Debug)]
pub(crate) struct Servos {
    fw: Firmware,
    channels: Vec<Channel>,
    /// Channels cycled through (`SC,8`).
    slots: u8,
    /// Milliseconds per slot (`SC,9`).
    slot_ms: u8,
    ms_counter: u8,
    ptr: u8,
    /// The pen servo's pin (`SP`'s third argument + 3).
    pub pen_rpn: u8,
    /// `SC,4`: pen up ("servo_min").
    pub up: u16,
    /// `SC,5`: pen down ("servo_max").
    pub down: u16,
    pub rate_up: u16,
    pub rate_down: u16,
    /// `SC,1`: pen servo output on (0 turns it off, solenoid only).
    pub use_servo: bool,
    pub use_solenoid: bool,
    /// The firmware's pen state (`QG` bit 4, `QP`): up when the last servo
    /// move on the pen pin went to `SC,4`.
    pub pen_up: bool,
    /// Servo power switch (RA3), `QR`.
    pub power: bool,
    /// Milliseconds until the power switches off (0: not counting).
    pub power_left_ms: u32,
    /// `SR`'s timeout (0: never).
    pub power_timeout_ms: u32,
}

impl Servos {
    /// The state `RCServo2_Init` leaves (the pen-up move it queues is the
    /// caller's, as it goes through the FIFO).
    pub fn new(fw: Firmware) -> Servos {
        Servos {
            fw,
            channels: vec![Channel::default(); usize::from(fw.max_servo_channels())],
            slots: 8,
            slot_ms: 3,
            ms_counter: 0,
            ptr: 0,
            pen_rpn: PEN_RPN,
            up: 22_565,
            down: 15_302,
            rate_up: 400,
            rate_down: 400,
            use_servo: true,
            use_solenoid: true,
            pen_up: true,
            power: false,
            power_left_ms: 0,
            power_timeout_ms: POWER_TIMEOUT_MS,
        }
    }

    /// `SC,8`: at most the firmware's channel count.
    pub fn set_slots(&mut self, n: u16) {
        self.slots = n.min(u16::from(self.fw.max_servo_channels())) as u8;
    }

    /// `SC,9`: at most 6 ms.
    pub fn set_slot_ms(&mut self, n: u16) {
        self.slot_ms = n.min(6) as u8;
    }

    /// The channel a pin uses, 1-based (0: none free).
    fn channel_for(&self, rpn: u8) -> u8 {
        let i = self.channels.iter().position(|c| c.rpn == rpn).or_else(|| self.channels.iter().position(|c| c.rpn == 0));
        i.map_or(0, |i| i as u8 + 1)
    }

    fn disable(&mut self, channel: u8) {
        self.channels[usize::from(channel - 1)] = Channel::default();
    }

    /// `RCServo2_Move` up to the point where it waits for the FIFO.
    pub fn plan(&mut self, position: u16, rpn: u8, rate: u16, delay_ms: u16) -> Plan {
        let channel = self.channel_for(rpn);
        if channel == 0 {
            return Plan::Nothing;
        }
        if position == 0 {
            self.disable(channel);
            return Plan::Disabled;
        }
        if channel > self.slots || rpn > 24 {
            return Plan::Nothing;
        }
        if rpn == SOLENOID_RPN {
            self.use_solenoid = false;
        }
        let mut delay = 25 * u32::from(delay_ms);
        if self.fw.is_v3() && delay > 25 * 0x1_0000 {
            delay = 0;
        }
        let servo = ServoTarget { channel, rpn, position, rate };
        Plan::Queue(Command { kind: Kind::Servo, delay, servo, ..Command::default() })
    }

    /// What happens to a move on pin RP4 as it enters the FIFO (and, on
    /// 3.0.2, an immediate one): B1's power comes on and the countdown restarts.
    pub fn power_for(&mut self, rpn: u8) {
        if rpn == PEN_RPN {
            self.power_on();
        }
    }

    /// Switches the servo power on and restarts the `SR` countdown.
    pub fn power_on(&mut self) {
        self.power = true;
        self.power_left_ms = self.power_timeout_ms;
    }

    /// The ISR's servo move (every tick the command is current).
    pub fn apply(&mut self, t: ServoTarget) {
        if self.use_servo && t.channel != 0 {
            let c = &mut self.channels[usize::from(t.channel - 1)];
            if t.position == 0 {
                *c = Channel::default();
            } else {
                (c.rate, c.target, c.rpn) = (t.rate, t.position, t.rpn);
                if c.value == 0 {
                    c.value = t.position;
                }
            }
        }
        if t.rpn == self.pen_rpn {
            self.pen_up = t.position == self.up;
        }
    }

    /// 3.0.2 `SP,2` / `SP,3`: the pen channel heads up now, bypassing the FIFO.
    pub fn lift_now(&mut self) {
        let channel = self.channel_for(self.pen_rpn);
        if channel == 0 || channel > self.slots || self.pen_rpn > 24 {
            return;
        }
        if self.use_servo {
            self.power_for(self.pen_rpn);
            let c = &mut self.channels[usize::from(channel - 1)];
            (c.rate, c.target, c.rpn) = (self.rate_up, self.up, self.pen_rpn);
            if c.value == 0 {
                c.value = self.up;
            }
            self.pen_up = true;
        }
    }

    /// One millisecond of the low-priority interrupt: the slot pointer, the
    /// slewing of the channel whose slot it is, and the power countdown.
    /// Returns the pulse width sent on pin RP4 in this millisecond, if any.
    pub fn ms_tick(&mut self) -> Option<u16> {
        let mut pulse = None;
        self.ms_counter = self.ms_counter.wrapping_add(1);
        if self.ms_counter >= self.slot_ms {
            self.ms_counter = 0;
            self.ptr = self.ptr.wrapping_add(1);
            if self.ptr >= self.slots {
                self.ptr = 0;
            }
            let v3 = self.fw.is_v3();
            if let Some(c) = self.channels.get_mut(usize::from(self.ptr)) {
                if c.value != 0 {
                    slew(c, v3);
                    if c.rpn == PEN_RPN {
                        pulse = Some(c.value);
                    }
                }
            }
        }
        if self.power_left_ms != 0 {
            self.power_left_ms -= 1;
            if self.power_left_ms == 0 {
                self.power = false;
            }
        }
        pulse
    }

    /// Every channel is at its target: only the slot pointer and the power
    /// countdown change, which [`Servos::skip_ms`] computes at once.
    pub fn settled(&self) -> bool {
        self.channels.iter().all(|c| c.value == c.target || c.value == 0)
    }

    /// Milliseconds until the power countdown fires (None: not counting).
    pub fn power_off_in_ms(&self) -> Option<u32> {
        (self.power_left_ms != 0).then_some(self.power_left_ms)
    }

    /// `n` milliseconds of [`Servos::ms_tick`] while [`Servos::settled`], for
    /// `n` not past the power countdown.
    pub fn skip_ms(&mut self, n: u64) {
        debug_assert!(self.settled());
        debug_assert!(self.power_left_ms == 0 || n < u64::from(self.power_left_ms));
        // The pointer advances once every `slot_ms` milliseconds, wrapping at
        // `slots` (a slot of 0 ms advances it every millisecond; 0 slots keep
        // it at 0).
        let per = u64::from(self.slot_ms.max(1));
        let total = u64::from(self.ms_counter) + n;
        let advances = if self.slot_ms == 0 { n } else { total / per };
        self.ms_counter = if self.slot_ms == 0 { 0 } else { (total % per) as u8 };
        if self.slots > 0 {
            self.ptr = ((u64::from(self.ptr) + advances) % u64::from(self.slots)) as u8;
        }
        if self.power_left_ms != 0 {
            self.power_left_ms -= n as u32;
        }
    }

    /// The pulse width the pen pin carries now (0: none).
    pub fn pen_pin_value(&self) -> u16 {
        self.channels.iter().find(|c| c.rpn == PEN_RPN).map_or(0, |c| c.value)
    }
}

/// One slot's slewing of a channel towards its target. The difference is a
/// 16-bit signed int on the PIC; 3.0.2 compares it with the rate as a
/// signed 16-bit value, 2.8.1 as an unsigned one.
fn slew(c: &mut Channel, v3: bool) {
    if c.target == c.value {
        return;
    }
    if c.rate == 0 {
        c.value = c.target;
        return;
    }
    let diff = c.target.wrapping_sub(c.value) as i16;
    let far = |d: i16| if v3 { d > c.rate as i16 } else { d as u16 > c.rate };
    if diff > 0 {
        c.value = if far(diff) { c.value.wrapping_add(c.rate) } else { c.target };
    } else {
        c.value = if far(diff.wrapping_neg()) { c.value.wrapping_sub(c.rate) } else { c.target };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_channel_slews_by_its_rate_once_per_cycle() {
        // The FAQ of both manuals: from 10000 to 15000 at rate 100 takes 50
        // cycles of 24 ms, 1.2 s.
        let mut s = Servos::new(Firmware::V2_8_1);
        let Plan::Queue(c) = s.plan(10_000, PEN_RPN, 0, 0) else { panic!("queued") };
        s.apply(c.servo);
        let Plan::Queue(c) = s.plan(15_000, PEN_RPN, 100, 0) else { panic!("queued") };
        s.apply(c.servo);
        let mut ms = 0;
        let mut last = 0;
        while s.pen_pin_value() != 15_000 {
            if let Some(p) = s.ms_tick() {
                last = p;
            }
            ms += 1;
        }
        assert_eq!(last, 15_000);
        // Channel 1's slot comes every 24 ms, the first one 24 ms after boot.
        assert_eq!(ms, 50 * 24);
        assert!(!s.pen_up, "15000 is not SC,4: the pen counts as down");
    }

    #[test]
    fn skipping_matches_ticking() {
        let mut a = Servos::new(Firmware::V3_0_2);
        a.set_slot_ms(5);
        a.power_on();
        let mut b = a.clone();
        for _ in 0..1234 {
            a.ms_tick();
        }
        b.skip_ms(1234);
        assert_eq!((a.ptr, a.ms_counter, a.power_left_ms), (b.ptr, b.ms_counter, b.power_left_ms));
    }
}
