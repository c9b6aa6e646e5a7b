//! What the simulated plotter did: pen-down strokes, lost bytes, errors, faults.
//!
//! The record is the simulator's output file format (`--record OUT.json`), so
//! it carries serde derives; coordinates are in device units (HP-GL plotter
//! units of 0.025 mm, or GRBL millimetres) with y up, as the device sees them.

use serde::{Deserialize, Serialize};

/// Errors listed in a record; a device fed garbage for hours would otherwise
/// grow it without bound.
pub const MAX_RECORDED_ERRORS: usize = 10_000;

/// Everything a run drew and suffered.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// `hp7475a` or `grbl`.
    pub personality: String,
    /// Model name the device reports.
    pub model: String,
    /// Device units per millimetre (40 for HP-GL, 1 for GRBL).
    pub units_per_mm: f64,
    /// Device limits (x_min, y_min, x_max, y_max) in device units, when known.
    pub limits: Option<[f64; 4]>,
    /// Pen-down strokes in the order they were drawn.
    pub strokes: Vec<Stroke>,
    /// Where each move made with the pen up ended, in order, device units
    /// (HP-GL and GRBL): the carriage's travel between strokes and the
    /// moves a person asked for, which draw nothing.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub travel: Vec<[f64; 2]>,
    /// Bytes lost because they arrived while the input buffer was full.
    pub overruns: u64,
    /// Errors the device raised, in order.
    pub errors: Vec<ErrorEvent>,
    /// Errors raised after `errors` reached [`MAX_RECORDED_ERRORS`].
    #[serde(default)]
    pub errors_not_listed: u64,
    /// Faults injected, in order.
    pub faults: Vec<FaultEvent>,
    /// Seconds the plot would take on the real machine (motion and pen lifts;
    /// not scaled by the speed scale).
    pub plot_seconds: f64,
    /// EBB: seconds the motion FIFO ran empty between one command and a
    /// move that came next: the carriage stood still while the host had
    /// more to send (stutter). Real time at speed scale 1.
    #[serde(default)]
    pub starved_seconds: f64,
    /// Bytes the device received over the link (real-time bytes included).
    pub bytes_received: u64,
    /// GRBL: `$X` cleared the alarm lock of a board that requires homing
    /// before it was homed (since power-up or a reset): it then moved
    /// without knowing where it was. A host must never do that unasked.
    #[serde(default)]
    pub unlocked_without_homing: bool,
    /// Replies the device has sent (answers, `ok`s, status reports): what a
    /// test waits on to know the host has asked something (not in the file).
    #[serde(skip)]
    pub replies: u64,
    /// Whether the pen has stayed down since the last stroke's last point, so
    /// that a segment starting there continues it.
    #[serde(skip)]
    pub pen_on_paper: bool,
}

/// One connected pen-down path.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stroke {
    /// Pen (carousel slot for HP, tool number or 1 for GRBL).
    pub pen: u32,
    /// Vertices in device units.
    pub points: Vec<[f64; 2]>,
}

/// An error the device raised.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorEvent {
    /// Which error number space: `hpgl` (OE), `extended` (ESC.E), `grbl`
    /// (`error:N`), `alarm` (GRBL `ALARM:N`).
    pub kind: String,
    /// The device's error number.
    pub code: u32,
    /// What it means.
    pub message: String,
    /// Bytes received before the error was raised (its offset in the input stream).
    pub at_byte: u64,
}

/// A fault that was injected, or a reset a host's open caused.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FaultEvent {
    /// `unplug`, `stall`, `power-cycle`, `reset`, `park`, `lever up`,
    /// `lever down`, `garbage`, `error`, `alarm`, `lose-input`; and
    /// `reset-on-open` when a host's open reset the board
    /// ([`crate::Quirk::ResetOnOpen`]).
    pub kind: String,
    /// Duration for timed faults.
    pub ms: Option<u64>,
    /// Bytes received when it was injected.
    pub at_byte: u64,
}

impl Record {
    /// An empty record for a device.
    #[must_use]
    pub fn new(personality: &str, model: &str, units_per_mm: f64, limits: Option<[f64; 4]>) -> Record {
        Record { personality: personality.to_string(), model: model.to_string(), units_per_mm, limits, ..Record::default() }
    }

    /// Adds a pen-down segment, extending the last stroke when it continues
    /// it (same pen, same point, no lift in between). A zero-length segment
    /// is a dot: kept as a stroke of its own unless it sits at the end of the
    /// stroke it would extend.
    pub fn segment(&mut self, pen: u32, from: [f64; 2], to: [f64; 2]) {
        let continues = std::mem::replace(&mut self.pen_on_paper, true);
        if let Some(last) = self.strokes.last_mut().filter(|_| continues) {
            if last.pen == pen && last.points.last() == Some(&from) {
                if from != to {
                    // A dot followed by a line is just the line.
                    if last.points.len() == 2 && last.points[0] == last.points[1] {
                        last.points[1] = to;
                    } else {
                        last.points.push(to);
                    }
                }
                return;
            }
        }
        self.strokes.push(Stroke { pen, points: vec![from, to] });
    }

    /// The pen left the paper (lifted, or the device lost power): the next
    /// segment starts a new stroke even where the last one ended.
    pub fn lift(&mut self) {
        self.pen_on_paper = false;
    }

    /// A move with the pen up ended at `to`.
    pub fn travelled(&mut self, to: [f64; 2]) {
        self.travel.push(to);
    }

    /// Logs an error at the current input offset (the first
    /// [`MAX_RECORDED_ERRORS`]; later ones are only counted).
    pub fn error(&mut self, kind: &str, code: u32, message: &str) {
        if self.errors.len() >= MAX_RECORDED_ERRORS {
            self.errors_not_listed += 1;
            return;
        }
        self.errors.push(ErrorEvent { kind: kind.to_string(), code, message: message.to_string(), at_byte: self.bytes_received });
    }

    /// Total pen-down length in device units.
    #[must_use]
    pub fn drawn_length(&self) -> f64 {
        self.strokes
            .iter()
            .flat_map(|s| s.points.windows(2))
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .sum()
    }

    /// The JSON record (`--record`).
    #[must_use]
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a record always serialises")
    }

    /// Reads a JSON record back.
    ///
    /// # Errors
    /// The JSON error, with its line and column.
    pub fn from_json(text: &str) -> Result<Record, serde_json::Error> {
        serde_json::from_str(text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_chain_only_when_continuous_and_same_pen() {
        let mut r = Record::default();
        r.segment(1, [0.0, 0.0], [1.0, 0.0]);
        r.segment(1, [1.0, 0.0], [1.0, 1.0]);
        r.segment(2, [1.0, 1.0], [2.0, 1.0]);
        r.segment(2, [5.0, 5.0], [6.0, 5.0]);
        assert_eq!(r.strokes.len(), 3);
        // A dot is a stroke; a dot at a stroke's end adds nothing.
        r.segment(2, [6.0, 5.0], [6.0, 5.0]);
        r.segment(2, [9.0, 9.0], [9.0, 9.0]);
        r.segment(2, [9.0, 9.0], [9.0, 10.0]);
        assert_eq!(r.strokes.len(), 4);
        assert_eq!(r.strokes[3].points, vec![[9.0, 9.0], [9.0, 10.0]]);
        assert_eq!(r.strokes[0].points.len(), 3);
        assert!((r.drawn_length() - 5.0).abs() < 1e-12);
    }

    #[test]
    fn a_lift_ends_the_stroke_even_where_the_next_begins() {
        let mut r = Record::default();
        r.segment(1, [0.0, 0.0], [1.0, 0.0]);
        r.lift();
        r.segment(1, [1.0, 0.0], [1.0, 1.0]);
        r.segment(1, [1.0, 1.0], [2.0, 1.0]);
        assert_eq!(r.strokes.len(), 2);
        assert_eq!(r.strokes[1].points, vec![[1.0, 0.0], [1.0, 1.0], [2.0, 1.0]]);
    }

    #[test]
    fn json_round_trip_has_the_agreed_keys() {
        let mut r = Record::default();
        r.segment(3, [0.0, 0.0], [4.0, 3.0]);
        r.overruns = 7;
        r.error("extended", 16, "input buffer overflow");
        let text = r.to_json();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["strokes"][0]["pen"], 3);
        assert_eq!(v["strokes"][0]["points"][1][0], 4.0);
        assert_eq!(v["overruns"], 7);
        assert_eq!(v["errors"][0]["code"], 16);
        // The pen's state is the live device's, not part of the file.
        assert_eq!(Record::from_json(&text).unwrap().to_json(), text);
    }
}
