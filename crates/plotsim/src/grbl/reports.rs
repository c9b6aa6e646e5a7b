//! GRBL's settings table and the text of its reports.
//!
//! Reference: GRBL 1.1 `doc/markdown/interface.md` (banner, `ok`/`error:N`,
//! `ALARM:N`, `[MSG:...]`, `$I` as `[VER:...]` + `[OPT:...]`, status report
//! `<State|MPos:...|Bf:...|FS:...>`, `$10` status mask) and
//! `doc/markdown/settings.md` (the `$` numbers and their defaults).

use std::collections::BTreeMap;
use strokes::MotionModel;

/// The version line after reset.
pub(crate) const BANNER: &str = "\r\nGrbl 1.1h ['$' for help]\r\n";
/// Version and build date reported by `$I`.
pub(crate) const VERSION: &str = "1.1h.20190825";
/// `$` help text.
pub(crate) const HELP: &str = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]";
/// Shown after a reset that left the machine in alarm.
pub(crate) const UNLOCK_HINT: &str = "[MSG:'$H'|'$X' to unlock]";

/// Settings that hold integers or bit masks (printed without decimals).
const INTEGER_SETTINGS: &[u32] = &[0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 30, 31, 32];

/// `$N` settings.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Settings(BTreeMap<u32, f64>);

impl Settings {
    /// GRBL's defaults, with speeds and acceleration from the motion model;
    /// homing enabled (`$22=1`) on a board that requires it.
    pub fn new(m: &MotionModel, homing: bool) -> Settings {
        let rate = m.pen_up_speed * 60.0;
        let accel = m.acceleration.unwrap_or(1000.0);
        let table: &[(u32, f64)] = &[
            (0, 10.0),
            (1, 25.0),
            (2, 0.0),
            (3, 0.0),
            (4, 0.0),
            (5, 0.0),
            (6, 0.0),
            (10, 1.0),
            (11, 0.010),
            (12, 0.002),
            (13, 0.0),
            (20, 0.0),
            (21, 0.0),
            (22, f64::from(u8::from(homing))),
            (23, 0.0),
            (24, 25.0),
            (25, 500.0),
            (26, 250.0),
            (27, 1.0),
            (30, 1000.0),
            (31, 0.0),
            (32, 0.0),
            (100, 80.0),
            (101, 80.0),
            (102, 80.0),
            (110, rate),
            (111, rate),
            (112, rate),
            (120, accel),
            (121, accel),
            (122, accel),
            (130, 200.0),
            (131, 200.0),
            (132, 200.0),
        ];
        Settings(table.iter().copied().collect())
    }

    /// A setting's value (0 for unknown numbers; callers use known ones).
    pub fn get(&self, n: u32) -> f64 {
        self.0.get(&n).copied().unwrap_or(0.0)
    }

    /// Sets an existing setting; `false` for a number GRBL does not have.
    pub fn set(&mut self, n: u32, v: f64) -> bool {
        match self.0.get_mut(&n) {
            Some(slot) => {
                *slot = if INTEGER_SETTINGS.contains(&n) { v.trunc() } else { v };
                true
            }
            None => false,
        }
    }

    /// The `$$` listing, one `$n=v` line each, CRLF-terminated.
    pub fn listing(&self) -> String {
        let mut s = String::new();
        for (n, v) in &self.0 {
            if INTEGER_SETTINGS.contains(n) {
                s.push_str(&format!("${n}={}\r\n", *v as i64));
            } else {
                s.push_str(&format!("${n}={v:.3}\r\n"));
            }
        }
        s
    }
}

/// Short meaning of a GRBL error number (for the record).
pub(crate) fn error_message(code: u32) -> &'static str {
    match code {
        1 => "expected command letter",
        2 => "bad number format",
        3 => "invalid $ statement",
        4 => "negative value",
        5 => "homing not enabled",
        8 => "not idle",
        9 => "G-code locked out during alarm",
        11 => "line overflow",
        20 => "unsupported command",
        21 => "modal group violation",
        22 => "undefined feed rate",
        25 => "repeated word",
        27 => "no arc offsets in plane",
        28 => "value word missing",
        31 => "axis words without motion",
        33 => "invalid target",
        36 => "unused value words",
        _ => "error",
    }
}

/// Meaning of a GRBL 1.1 alarm number; `None` for a number GRBL does not raise.
pub(crate) fn alarm_message(code: u32) -> Option<&'static str> {
    Some(match code {
        1 => "hard limit triggered",
        2 => "soft limit: motion target beyond travel",
        3 => "reset while in motion",
        4 | 5 => "probe fail",
        6 => "homing fail: reset during homing",
        7 => "homing fail: door opened",
        8 => "homing fail: pull-off did not clear the limit",
        9 => "homing fail: limit switch not found",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn listing_formats_integers_and_reals() {
        let mut s = Settings::new(&MotionModel::default(), false);
        let l = s.listing();
        assert!(l.starts_with("$0=10\r\n"));
        assert!(l.contains("$11=0.010\r\n"));
        assert!(l.contains("$110=30000.000\r\n"));
        assert!(s.set(10, 3.7));
        assert_eq!(s.get(10), 3.0);
        assert!(!s.set(7, 1.0));
    }
}
