//! The board as a simulator device: wall-clock time onto the board's ticks,
//! bytes from the link, the faults, and the record.
//!
//! Bytes the thread reads wait in an inbox until [`Device::run`] moves the
//! board to "now" and hands them over, so a command is read at the time it
//! arrived and never before the board's motion has caught up (during a
//! `stall` the inbox fills, the board reads nothing, and its motion goes on).
//! The inbox and the board's endpoint together hold
//! [`RX_CAPACITY`](super::board::RX_CAPACITY) bytes; beyond that the thread
//! leaves the host's bytes in the pty, as a USB device NAKs.

use super::board::{Board, Io, RX_CAPACITY};
use super::clock::{TickClock, TICKS_PER_SECOND};
use crate::config::SimConfig;
use crate::device::{Ctx, Device, DeviceStatus};
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// How long the port is gone when the board resets (power cycle, `RB`): the
/// board boots and the host enumerates it again.
pub(crate) const REENUMERATE: Duration = Duration::from_millis(500);
/// Most board time one pass of the simulator runs ahead at speed scale 0
/// (a pass does not hold the thread longer than this much simulation).
const SETTLE_LIMIT_TICKS: u64 = 60 * 25_000;

pub(crate) struct EbbDevice {
    board: Board,
    clock: TickClock,
    inbox: VecDeque<u8>,
    contact: u16,
    /// The tick V+ comes back after a timed `power-loss`.
    vplus_back_at: Option<u64>,
    reenumerate: Option<Duration>,
    /// Motion time of the boards before the last reset, in ticks.
    busy_before: u64,
    /// Starved ticks of the boards before the last restart.
    starved_before: u64,
}

impl EbbDevice {
    pub fn new(cfg: &SimConfig, now: Instant) -> EbbDevice {
        let o = &cfg.ebb;
        let board = Board::new(o.firmware, o.pen_contact, o.nickname.clone().into_bytes(), o.motor_power);
        EbbDevice {
            board,
            clock: TickClock::new(now, 0, cfg.speed_scale),
            inbox: VecDeque::new(),
            contact: o.pen_contact,
            vplus_back_at: None,
            reenumerate: None,
            busy_before: 0,
            starved_before: 0,
        }
    }

    fn io<'a>(ctx: &'a mut Ctx<'_>) -> Io<'a> {
        Io { out: ctx.out, record: ctx.record, garble: ctx.garble_next }
    }

    /// Runs the board to `tick`, bringing V+ back on the way if it is due.
    fn advance(&mut self, tick: u64, ctx: &mut Ctx<'_>) {
        if let Some(back) = self.vplus_back_at.filter(|&t| t <= tick) {
            self.board.advance_to(back, &mut Self::io(ctx));
            self.board.set_vplus(true, &mut Self::io(ctx));
            self.vplus_back_at = None;
        }
        self.board.advance_to(tick, &mut Self::io(ctx));
    }

    /// The board resets (power on again, or `RB`): the firmware starts
    /// afresh, the flash keeps the nickname, the carriage stays where it is
    /// (with its drivers off), and the port leaves the bus for a moment.
    fn restart(&mut self, now: Instant) {
        let fw = self.board.fw;
        let nickname = std::mem::take(&mut self.board.nickname);
        let vplus = self.board.motors.vplus && self.vplus_back_at.is_none();
        let mut fresh = Board::new(fw, self.contact, nickname, vplus);
        fresh.adopt_mechanism(&self.board);
        self.busy_before += self.board.busy_ticks;
        self.starved_before += self.board.starved_ticks;
        self.board = fresh;
        self.clock.rebase(now, 0);
        self.inbox.clear();
        self.vplus_back_at = None;
        self.reenumerate = Some(REENUMERATE);
    }
}

impl Device for EbbDevice {
    fn receive(&mut self, byte: u8, _ctx: &mut Ctx<'_>) {
        if self.rx_space() > 0 {
            self.inbox.push_back(byte);
        }
    }

    fn run(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let target = self.clock.tick_at(ctx.now).max(self.board.tick);
        self.advance(target, ctx);
        while self.board.rx_space() > 0 {
            let Some(b) = self.inbox.pop_front() else { break };
            self.board.receive(b);
        }
        self.advance(target, ctx);
        if self.clock.instant() {
            self.board.settle(SETTLE_LIMIT_TICKS, &mut Self::io(ctx));
            self.clock.rebase(ctx.now, self.board.tick);
        }
        ctx.record.plot_seconds = (self.busy_before + self.board.busy_ticks) as f64 / TICKS_PER_SECOND as f64;
        ctx.record.starved_seconds = (self.starved_before + self.board.starved_ticks) as f64 / TICKS_PER_SECOND as f64;
        if std::mem::take(&mut self.board.reboot_requested) {
            self.restart(ctx.now);
        }
        if self.reenumerate.is_some() {
            return Some(ctx.now);
        }
        let next = [self.board.next_event(), self.vplus_back_at].into_iter().flatten().min()?;
        // Busy: come back within a USB frame (1 ms of wall time), not every 40 µs.
        Some(self.clock.instant_of(next).max(ctx.now + Duration::from_millis(1)))
    }

    fn status(&self) -> DeviceStatus {
        let b = &self.board;
        let state = if !b.motors.vplus {
            "no-motor-power"
        } else if b.blocked.is_some() {
            "queue-full"
        } else if !b.engine.idle() {
            "moving"
        } else {
            "idle"
        };
        DeviceStatus {
            buffer_used: self.inbox.len() + b.buffered(),
            buffer_capacity: RX_CAPACITY,
            idle: self.inbox.is_empty() && b.idle() && self.vplus_back_at.is_none(),
            position: b.motors.position_mm(),
            pen_down: b.pen.on_paper(),
            state: state.to_string(),
            cts: true,
            xoff: false,
        }
    }

    fn power_cycle(&mut self, ctx: &mut Ctx<'_>) {
        let target = self.clock.tick_at(ctx.now).max(self.board.tick);
        self.advance(target, ctx);
        self.restart(ctx.now);
        // Power comes back to everything, the motor supply included.
        let mut io = Self::io(ctx);
        self.board.set_vplus(true, &mut io);
    }

    fn park(&mut self, ctx: &mut Ctx<'_>) -> Result<(), String> {
        let target = self.clock.tick_at(ctx.now).max(self.board.tick);
        self.advance(target, ctx);
        self.board.park(&mut Self::io(ctx))
    }

    fn set_lever(&mut self, _up: bool) -> Result<(), String> {
        Err("an EBB has no paper lever".into())
    }

    fn alarm(&mut self, _code: u32, _ctx: &mut Ctx<'_>) -> Result<(), String> {
        Err("alarms are a GRBL fault".into())
    }

    fn lose_input(&mut self) -> Result<(), String> {
        Err("an EBB on USB loses no input".into())
    }

    fn fail_next(&mut self, code: Option<u32>) {
        self.board.fail_next = Some(code.unwrap_or(6));
    }

    fn consumed(&self) -> u64 {
        self.board.taken
    }

    fn rx_space(&self) -> usize {
        RX_CAPACITY.saturating_sub(self.inbox.len() + RX_CAPACITY - self.board.rx_space())
    }

    fn take_reenumeration(&mut self) -> Option<Duration> {
        self.reenumerate.take()
    }

    fn power_loss(&mut self, lasting: Option<Duration>, ctx: &mut Ctx<'_>) -> Result<(), String> {
        let target = self.clock.tick_at(ctx.now).max(self.board.tick);
        self.advance(target, ctx);
        self.board.set_vplus(false, &mut Self::io(ctx));
        self.vplus_back_at = lasting.map(|d| self.board.tick + self.clock.board_ticks(d).max(1));
        Ok(())
    }

    fn power_restore(&mut self, ctx: &mut Ctx<'_>) -> Result<(), String> {
        let target = self.clock.tick_at(ctx.now).max(self.board.tick);
        self.advance(target, ctx);
        self.vplus_back_at = None;
        self.board.set_vplus(true, &mut Self::io(ctx));
        Ok(())
    }

    fn press_button(&mut self) -> Result<(), String> {
        self.board.press_button();
        Ok(())
    }
}
