//! The plot-time model, run along the commands a device is sent.
//!
//! One estimate has two users: a render's `stats` (the emitters tell the
//! clock what they write) and the seconds of the chunks a daemon cuts a
//! file into, which its ETA counts down (the cutters tell it what they
//! read). Both walk the same commands through the same [`Clock`], so for
//! an emitted file the two agree.
//!
//! It times the commands, not the drawing: straight moves between the
//! coordinates written (rounded, as the device gets them), from the device
//! origin where the pen starts; the pen lowered and lifted as the device is
//! told (by `PD`/`PU`, a servo's spindle word or a Z move); and with a
//! dashed line type in force, the dashes and gaps the device draws, the pen
//! lifted over each gap. What the commands do not say costs nothing: a pen
//! change, a dwell (a servo's wait is its lift time), a return home the
//! file does not make. Speeds, acceleration and lift times are the
//! profile's [`MotionModel`], except where a command says how long it takes:
//! an EBB's moves and pen moves carry the durations the motion planner gave
//! them ([`Clock::timed_move`], [`Clock::timed_pen`]).

use crate::profile::DeviceProfile;
use strokes::{DVec2, Dash, MotionModel, PlotStats};

/// Where the pen is and what it has cost so far.
#[derive(Clone, Debug)]
pub(crate) struct Clock {
    model: MotionModel,
    /// Millimetres per device unit.
    unit_mm: f64,
    /// Device units.
    at: DVec2,
    /// Whether the commands hold the pen down.
    down: bool,
    /// Whether it is on the paper: down, and not over a gap of the line type.
    lowered: bool,
    /// The dashed line type in force, in millimetres on paper.
    dash: Option<Dash>,
    /// How far into the dash pattern's period the pen is, mm (a dash from 0,
    /// then a gap).
    phase: f64,
    stats: PlotStats,
}

impl Clock {
    /// A clock at the device origin with the pen up.
    pub fn new(profile: &DeviceProfile) -> Clock {
        Clock {
            model: profile.motion_model(),
            unit_mm: profile.unit_mm,
            at: DVec2::ZERO,
            down: false,
            lowered: false,
            dash: None,
            phase: 0.0,
            stats: PlotStats::default(),
        }
    }

    /// Everything timed so far: a pen drop is a stroke.
    pub fn stats(&self) -> PlotStats {
        self.stats
    }

    /// The pen held down or let up; the seconds it takes (none when it
    /// already is). A dash pattern starts again at each drop.
    pub fn pen(&mut self, down: bool) -> f64 {
        if down == self.down {
            return 0.0;
        }
        self.down = down;
        self.phase = 0.0;
        if down {
            self.lower()
        } else {
            self.lift()
        }
    }

    /// The line type from here on: dashed, or solid (`None`). Its pattern
    /// starts again.
    pub fn line_type(&mut self, dash: Option<Dash>) {
        self.dash = dash.filter(|d| d.dash_mm > 0.0 && d.gap_mm > 0.0 && d.period_mm().is_finite());
        self.phase = 0.0;
    }

    /// A straight move to `to` (device units) at the drawing speed or the
    /// travel speed; the seconds it takes.
    pub fn move_to(&mut self, to: DVec2, drawing_speed: bool) -> f64 {
        let len = self.at.distance(to) * self.unit_mm;
        self.at = to;
        match self.dash {
            Some(dash) if self.down && len.is_finite() => self.dashed(len, dash),
            _ => {
                // Down again after a solid line type ended a dashed one in a gap.
                let lowered = if self.down { self.lower() } else { 0.0 };
                let speed = if drawing_speed { self.model.pen_down_speed } else { self.model.pen_up_speed };
                lowered + self.go(len, speed)
            }
        }
    }

    /// A move to `to` (device units) that takes the `seconds` the command
    /// itself says (an EBB `LM`'s ticks or `SM`'s milliseconds: the motion
    /// planner's own durations); the seconds.
    pub fn timed_move(&mut self, to: DVec2, seconds: f64) -> f64 {
        let len = self.at.distance(to) * self.unit_mm;
        self.at = to;
        self.go_taking(len, seconds)
    }

    /// The pen held down or let up by a command that waits `seconds` (an
    /// EBB `SP` with its duration), whether or not the pen moves.
    pub fn timed_pen(&mut self, down: bool, seconds: f64) -> f64 {
        if down != self.down {
            self.down = down;
            self.phase = 0.0;
            // Counted here; the time is the command's, spent below.
            if down {
                self.lower_taking(0.0);
            } else {
                self.lift_taking(0.0);
            }
        }
        self.spend(seconds)
    }

    /// A move of `len` mm with the pen down under `dash`: the rest of the
    /// dash or gap it is in, then whole periods at once (so that a long
    /// move on a short pattern takes no longer to time than a short one),
    /// then what is left.
    fn dashed(&mut self, len: f64, dash: Dash) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let (d, period) = (dash.dash_mm, dash.period_mm());
        let mut left = len;
        let mut seconds = 0.0;
        loop {
            let in_dash = self.phase < d;
            let piece = left.min(if in_dash { d } else { period } - self.phase);
            seconds += self.piece(piece, in_dash);
            left -= piece;
            if left <= 0.0 {
                self.phase += piece;
                return seconds;
            }
            if in_dash {
                self.phase = d;
                continue;
            }
            self.phase = 0.0;
            let periods = (left / period).floor();
            if periods >= 1.0 {
                seconds += self.periods(periods, dash);
                left -= periods * period;
                if left <= 0.0 {
                    return seconds;
                }
            }
        }
    }

    /// Part of a dash (pen on the paper) or of a gap (pen lifted).
    fn piece(&mut self, len: f64, in_dash: bool) -> f64 {
        if in_dash {
            self.lower() + self.go(len, self.model.pen_down_speed)
        } else {
            self.lift() + self.go(len, self.model.pen_up_speed)
        }
    }

    /// `n` whole periods from the start of a dash, the pen lifted before it
    /// and after.
    fn periods(&mut self, n: f64, dash: Dash) -> f64 {
        let m = &self.model;
        let one =
            m.pen_drop_time + m.move_time(dash.dash_mm, m.pen_down_speed) + m.pen_lift_time + m.move_time(dash.gap_mm, m.pen_up_speed);
        // A file may ask for more dashes than a count holds.
        let count = n as usize;
        self.stats.strokes = self.stats.strokes.saturating_add(count);
        self.stats.pen_lifts = self.stats.pen_lifts.saturating_add(count);
        self.stats.drawn_mm += n * dash.dash_mm;
        self.stats.travel_mm += n * dash.gap_mm;
        self.spend(n * one)
    }

    fn lower(&mut self) -> f64 {
        self.lower_taking(self.model.pen_drop_time)
    }

    fn lower_taking(&mut self, seconds: f64) -> f64 {
        if self.lowered {
            return 0.0;
        }
        self.lowered = true;
        self.stats.strokes = self.stats.strokes.saturating_add(1);
        self.spend(seconds)
    }

    fn lift(&mut self) -> f64 {
        self.lift_taking(self.model.pen_lift_time)
    }

    fn lift_taking(&mut self, seconds: f64) -> f64 {
        if !self.lowered {
            return 0.0;
        }
        self.lowered = false;
        self.stats.pen_lifts = self.stats.pen_lifts.saturating_add(1);
        self.spend(seconds)
    }

    /// A straight move of `len` mm at top speed `speed`, drawing if the pen
    /// is on the paper.
    fn go(&mut self, len: f64, speed: f64) -> f64 {
        self.go_taking(len, self.model.move_time(len, speed))
    }

    fn go_taking(&mut self, len: f64, seconds: f64) -> f64 {
        if self.lowered {
            self.stats.drawn_mm += len;
        } else {
            self.stats.travel_mm += len;
        }
        self.spend(seconds)
    }

    fn spend(&mut self, seconds: f64) -> f64 {
        self.stats.seconds += seconds;
        seconds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A device of 1 mm units, 10 mm/s drawing, 20 mm/s travel, 0.5 s to
    /// lift and 0.25 s to drop, no acceleration.
    fn clock() -> Clock {
        let mut p = DeviceProfile::builtin("grbl-servo").unwrap();
        (p.pen_down_speed_mm_s, p.pen_up_speed_mm_s, p.pen_lift_s, p.pen_drop_s, p.acceleration_mm_s2) =
            (10.0, 20.0, Some(0.5), Some(0.25), None);
        Clock::new(&p)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn a_stroke_is_the_travel_to_it_a_drop_the_drawing_and_a_lift() {
        let mut c = clock();
        let mut s = c.move_to(DVec2::new(0.0, 10.0), false);
        s += c.pen(true);
        s += c.move_to(DVec2::new(10.0, 10.0), true);
        s += c.pen(true);
        s += c.pen(false);
        assert!(close(s, 10.0 / 20.0 + 0.25 + 10.0 / 10.0 + 0.5), "{s}");
        let st = c.stats();
        assert!(close(st.seconds, s));
        assert_eq!((st.strokes, st.pen_lifts), (1, 1), "a second pen-down changes nothing");
        assert!(close(st.travel_mm, 10.0) && close(st.drawn_mm, 10.0));
    }

    #[test]
    fn a_dashed_line_lifts_over_its_gaps_at_the_travel_speed() {
        let dash = Dash { dash_mm: 3.0, gap_mm: 2.0 };
        let mut c = clock();
        c.line_type(Some(dash));
        c.pen(true);
        // 12 mm in two moves, the first ending inside a gap: dashes 0..3,
        // 5..8, 10..12; gaps 3..5, 8..10.
        c.move_to(DVec2::new(4.0, 0.0), true);
        c.move_to(DVec2::new(12.0, 0.0), true);
        c.pen(false);
        let st = c.stats();
        assert_eq!((st.strokes, st.pen_lifts), (3, 3));
        assert!(close(st.drawn_mm, 8.0) && close(st.travel_mm, 4.0), "{st:?}");
        assert!(close(st.seconds, 3.0 * 0.25 + 8.0 / 10.0 + 3.0 * 0.5 + 4.0 / 20.0), "{st:?}");
        // Ending in a gap, the pen is already up.
        let mut c = clock();
        c.line_type(Some(dash));
        c.pen(true);
        c.move_to(DVec2::new(9.0, 0.0), true);
        let before = c.stats().seconds;
        assert_eq!(c.pen(false), 0.0);
        assert_eq!(c.stats().seconds, before);
        assert_eq!(c.stats().pen_lifts, 2);
    }

    #[test]
    fn whole_periods_at_once_cost_what_they_cost_one_by_one() {
        let dash = Dash { dash_mm: 0.7, gap_mm: 0.3 };
        let mut p = DeviceProfile::builtin("hp7475a").unwrap();
        // Without acceleration a dash cut across moves costs what it costs whole.
        (p.unit_mm, p.acceleration_mm_s2) = (1.0, None);
        let (mut long, mut steps) = (Clock::new(&p), Clock::new(&p));
        for c in [&mut long, &mut steps] {
            c.line_type(Some(dash));
            c.pen(true);
        }
        long.move_to(DVec2::new(1000.25, 0.0), true);
        // Steps of 0.25 mm never hold a whole period.
        for k in 1..=4001 {
            steps.move_to(DVec2::new(k as f64 * 0.25, 0.0), true);
        }
        let (a, b) = (long.stats(), steps.stats());
        assert_eq!((a.strokes, a.pen_lifts), (b.strokes, b.pen_lifts));
        assert_eq!(a.strokes, 1001);
        assert!((a.seconds - b.seconds).abs() < 1e-9 * a.seconds, "{a:?} {b:?}");
        assert!((a.drawn_mm - b.drawn_mm).abs() < 1e-9 && (a.travel_mm - b.travel_mm).abs() < 1e-9, "{a:?} {b:?}");
    }

    #[test]
    fn more_dashes_than_a_count_holds_are_counted_as_many_as_it_holds() {
        let mut c = clock();
        c.line_type(Some(Dash { dash_mm: 1e-9, gap_mm: 1e-9 }));
        c.pen(true);
        c.move_to(DVec2::new(1e30, 0.0), true);
        c.move_to(DVec2::new(0.0, 0.0), true);
        c.pen(false);
        let st = c.stats();
        assert_eq!((st.strokes, st.pen_lifts), (usize::MAX, usize::MAX));
        assert!(st.seconds > 1e30 / 10.0, "{st:?}");
    }

    #[test]
    fn a_solid_line_type_after_a_gap_lowers_the_pen_to_draw() {
        let mut c = clock();
        c.line_type(Some(Dash { dash_mm: 1.0, gap_mm: 1.0 }));
        c.pen(true);
        c.move_to(DVec2::new(1.5, 0.0), true);
        c.line_type(None);
        let s = c.move_to(DVec2::new(2.5, 0.0), true);
        assert!(close(s, 0.25 + 1.0 / 10.0), "{s}");
        assert_eq!(c.stats().strokes, 2);
    }
}
