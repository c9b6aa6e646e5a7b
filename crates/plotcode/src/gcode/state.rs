//! What a GRBL board's state is after each line, as far as chunks and plot
//! times need it: the modal words worth re-sending on resume, the motion
//! mode, the position, the pen as the board reports it (spindle on with a
//! speed, Z) and as the job holds it down. The cutter and the emitter both
//! time their lines here ([`BoardState::run`]), so a file's chunks add up to
//! the estimate of the render that wrote it.

use super::line::Block;
use super::ParseOptions;
use crate::clock::Clock;
use crate::profile::DeviceProfile;
use crate::program::{resume_number, PenAt};
use strokes::DVec2;

/// The board's state after the lines seen so far.
#[derive(Clone, Debug)]
pub(crate) struct BoardState {
    /// Modal words by group (units, distance, plane, feed mode, feed), in the
    /// order first seen, as last given.
    modal: Vec<(&'static str, String)>,
    /// The motion mode (`G0`..`G3`).
    pub motion: u32,
    /// `G90` (true) or `G91`.
    pub absolute: bool,
    /// Where the job's moves have put the tool (work coordinates).
    pub pos: DVec2,
    /// Whether the position the board reports is `pos`: inches, homing,
    /// machine or offset coordinates make it something else.
    pub pos_known: bool,
    spindle_on: bool,
    spindle_s: f64,
    z: Option<f64>,
    /// The tool (`T`) selected: the pen; a single-pen board starts with pen 1.
    pub pen: Option<u32>,
    /// Whether the job holds the pen down, as `plotd render` reads G-code:
    /// by the last spindle word or Z move.
    pen_down: bool,
    /// A Z at or below this is the pen down.
    z_down_at_or_below: f64,
}

/// What one line does to the tool's XY position.
pub(crate) struct Move {
    /// Where it goes.
    pub to: DVec2,
    /// Whether it is a feed (drawing) move rather than a rapid.
    pub feed: bool,
}

impl BoardState {
    /// A board at power-up running a job written for `profile`.
    pub fn new(profile: &DeviceProfile) -> BoardState {
        BoardState {
            modal: Vec::new(),
            motion: 0,
            absolute: true,
            pos: DVec2::ZERO,
            pos_known: true,
            spindle_on: false,
            spindle_s: 0.0,
            z: None,
            pen: Some(1),
            pen_down: false,
            z_down_at_or_below: ParseOptions::for_profile(profile).z_down_at_or_below,
        }
    }

    /// Applies `block` and times it on `clock`: the pen first (GRBL switches
    /// the spindle before it moves), then the XY move. Returns the move and
    /// the seconds.
    pub fn run(&mut self, block: &Block, clock: &mut Clock) -> (Option<Move>, f64) {
        let m = self.apply(block);
        let mut seconds = clock.pen(self.pen_down);
        if let Some(m) = &m {
            seconds += clock.move_to(m.to, m.feed);
        }
        (m, seconds)
    }

    /// The motion mode after `block`'s `G0`..`G3`, if it moves in XY:
    /// the cutter decides on this before the block changes the state.
    pub fn xy_motion(&self, block: &Block) -> Option<u32> {
        let moves = block.words.iter().any(|w| matches!(w.letter, 'X' | 'Y'));
        let g = block.words.iter().rfind(|w| w.letter == 'G' && w.value.fract() == 0.0 && (0.0..=3.0).contains(&w.value));
        moves.then(|| g.map_or(self.motion, |w| w.value as u32))
    }

    /// Applies `block` and returns its XY move, if any.
    pub fn apply(&mut self, block: &Block) -> Option<Move> {
        let (mut x, mut y) = (None, None);
        let mut spindle = false;
        for w in &block.words {
            let v = w.value;
            match w.letter {
                'M' if v == 3.0 || v == 4.0 => (self.spindle_on, spindle) = (true, true),
                'M' if v == 5.0 => (self.spindle_on, spindle) = (false, true),
                'S' => self.spindle_s = v,
                'Z' => self.z = if self.absolute { Some(v) } else { self.z.map(|z| z + v) },
                'G' if v.fract() == 0.0 && (0.0..=3.0).contains(&v) => self.motion = v as u32,
                'G' if v == 90.0 => self.absolute = true,
                'G' if v == 91.0 => self.absolute = false,
                'T' if v >= 1.0 => self.pen = Some(v as u32),
                // Inches, homing, machine or offset coordinates: the
                // position GRBL reports is no longer `pos`.
                'G' if matches!(v, 10.0 | 20.0 | 28.0 | 30.0 | 53.0 | 92.0) || (54.0..=59.0).contains(&v) => self.pos_known = false,
                'X' => x = Some(v),
                'Y' => y = Some(v),
                _ => {}
            }
        }
        self.note_modal(block);
        if spindle {
            self.pen_down = self.spindle_on && self.spindle_s > 0.0;
        }
        if let Some(z) = self.z.filter(|_| block.get('Z').is_some()) {
            self.pen_down = z <= self.z_down_at_or_below;
        }
        if x.is_none() && y.is_none() {
            return None;
        }
        let to = if self.absolute {
            DVec2::new(x.unwrap_or(self.pos.x), y.unwrap_or(self.pos.y))
        } else {
            self.pos + DVec2::new(x.unwrap_or(0.0), y.unwrap_or(0.0))
        };
        self.pos = to;
        Some(Move { to, feed: self.motion != 0 })
    }

    /// An absolute XY move the emitter writes itself (`G0`, or `G1` at
    /// `feed`), timed on `clock`.
    pub fn move_to(&mut self, to: DVec2, feed: bool, clock: &mut Clock) {
        self.motion = u32::from(feed);
        self.pos = to;
        clock.move_to(to, feed);
    }

    /// Modal state worth re-sending: units, distance mode, plane, feed rate.
    fn note_modal(&mut self, block: &Block) {
        for w in &block.words {
            let key = match (w.letter, w.value as i64) {
                ('G', 20 | 21) => "units",
                ('G', 90 | 91) => "distance",
                ('G', 17..=19) => "plane",
                ('G', 93 | 94) => "feedmode",
                ('F', _) => "feed",
                _ => continue,
            };
            self.set_modal(key, format!("{}{}", w.letter, resume_number(w.value)));
        }
    }

    fn set_modal(&mut self, key: &'static str, word: String) {
        match self.modal.iter_mut().find(|(k, _)| *k == key) {
            Some(slot) => slot.1 = word,
            None => self.modal.push((key, word)),
        }
    }

    /// The pen as the board shows it: down when the spindle is on with a
    /// speed above 0 (a servo), and the Z the job last set.
    pub fn pen_at(&self) -> PenAt {
        PenAt { pos: self.pos, down: self.spindle_on && self.spindle_s > 0.0, z: self.z }
    }

    /// The resume prefix for a chunk starting in this state: `pen_up`, the
    /// modal words, the position (absolute: a chunk's travel line may leave
    /// out an axis it does not change, and a board that lost power is at
    /// zero), then `G91` when the job moves relative.
    pub fn resume(&self, pen_up: &[u8]) -> Vec<u8> {
        let mut out = pen_up.to_vec();
        for (_, word) in &self.modal {
            out.extend_from_slice(word.as_bytes());
            out.push(b'\n');
        }
        out.extend_from_slice(format!("G90\nG0 X{} Y{}\n", resume_number(self.pos.x), resume_number(self.pos.y)).as_bytes());
        if !self.absolute {
            out.extend_from_slice(b"G91\n");
        }
        out
    }
}
