//! The board's time base, and how wall-clock time maps onto it.
//!
//! Everything on the EBB happens on its 25 kHz stepper interrupt (one tick
//! every 40 µs) or on the 1 kHz interrupt that slews the servo and counts the
//! power timeouts (every 25th tick). The simulated board counts ticks since
//! power-on and never reads a clock: the adapter moves it to the tick that
//! corresponds to "now", and unit tests move it by hand.

use std::time::{Duration, Instant};

/// Stepper interrupts per millisecond.
pub(crate) const TICKS_PER_MS: u64 = 25;
/// Stepper interrupts per second (the ISR runs at 25 kHz).
pub(crate) const TICKS_PER_SECOND: u64 = 25_000;

/// Maps wall-clock instants to board ticks at a speed scale (simulated
/// seconds per wall second is `1 / scale`). At scale 0 (instant plotting) the
/// board still lives in real time while it waits; the adapter runs its
/// queued work to the end at once and then [`TickClock::rebase`]s.
#[derive(Clone, Debug)]
pub(crate) struct TickClock {
    anchor: Instant,
    anchor_tick: u64,
    scale: f64,
}

impl TickClock {
    pub fn new(now: Instant, tick: u64, scale: f64) -> TickClock {
        TickClock { anchor: now, anchor_tick: tick, scale }
    }

    /// Wall seconds per simulated second; 0 is taken as 1 for waiting (the
    /// board's own timeouts run in real time when plotting is instant).
    fn wall_per_sim(&self) -> f64 {
        if self.scale > 0.0 {
            self.scale
        } else {
            1.0
        }
    }

    /// The board tick at `now`.
    pub fn tick_at(&self, now: Instant) -> u64 {
        let wall = now.saturating_duration_since(self.anchor).as_secs_f64();
        let sim = wall / self.wall_per_sim();
        self.anchor_tick + (sim * TICKS_PER_SECOND as f64) as u64
    }

    /// The instant the board reaches `tick` (never before the anchor).
    pub fn instant_of(&self, tick: u64) -> Instant {
        let sim = tick.saturating_sub(self.anchor_tick) as f64 / TICKS_PER_SECOND as f64;
        let wall = (sim * self.wall_per_sim()).min(1e6);
        self.anchor + Duration::from_secs_f64(wall)
    }

    /// Makes `now` correspond to `tick` (after the board ran ahead of the
    /// clock, at scale 0).
    pub fn rebase(&mut self, now: Instant, tick: u64) {
        self.anchor = now;
        self.anchor_tick = tick;
    }

    /// Board ticks a wall-clock duration stands for (at scale 0, as at 1).
    pub fn board_ticks(&self, d: Duration) -> u64 {
        (d.as_secs_f64() / self.wall_per_sim() * TICKS_PER_SECOND as f64) as u64
    }

    /// True when queued work runs to its end at once.
    pub fn instant(&self) -> bool {
        self.scale == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_follow_the_wall_clock_at_the_scale() {
        let t0 = Instant::now();
        let c = TickClock::new(t0, 100, 1.0);
        assert_eq!(c.tick_at(t0 + Duration::from_millis(2)), 150);
        assert_eq!(c.instant_of(150), t0 + Duration::from_millis(2));
        let fast = TickClock::new(t0, 0, 0.1);
        assert_eq!(fast.tick_at(t0 + Duration::from_millis(1)), 250, "ten times faster");
        let instant = TickClock::new(t0, 0, 0.0);
        assert_eq!(instant.tick_at(t0 + Duration::from_millis(1)), 25, "waiting runs in real time");
        assert_eq!(instant.board_ticks(Duration::from_millis(60_000)), 1_500_000);
        assert_eq!(fast.board_ticks(Duration::from_millis(1)), 250);
    }
}
