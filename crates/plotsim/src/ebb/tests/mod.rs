//! The EBB personality driven directly, with a hand-moved clock.

mod arithmetic;
mod faults;
mod queue;
mod regression_data;
mod replies;

use super::board::{Board, Io};
use super::clock::{TICKS_PER_MS, TICKS_PER_SECOND};
use super::firmware::Firmware;
use super::pen::DEFAULT_CONTACT;
use crate::record::Record;

/// A board on the bench: bytes in, the clock moved by hand, replies out.
pub(crate) struct Rig {
    pub b: Board,
    pub record: Record,
    pub out: Vec<u8>,
    pub garble: bool,
}

impl Rig {
    /// A board that has been on for a moment (its power-on pen move done).
    pub fn new(fw: Firmware) -> Rig {
        let mut r = Rig { b: Board::new(fw, DEFAULT_CONTACT, Vec::new(), true), record: Record::default(), out: Vec::new(), garble: false };
        r.finish(1);
        r
    }

    fn io(&mut self) -> (&mut Board, Io<'_>) {
        (&mut self.b, Io { out: &mut self.out, record: &mut self.record, garble: &mut self.garble })
    }

    /// Moves the clock to `tick`.
    pub fn to(&mut self, tick: u64) {
        let (b, mut io) = self.io();
        b.advance_to(tick, &mut io);
    }

    /// Moves the clock on by `ms` milliseconds.
    pub fn wait_ms(&mut self, ms: u64) {
        let t = self.b.tick + ms * TICKS_PER_MS;
        self.to(t);
    }

    /// The host writes `text`; the board takes what its endpoint holds at
    /// once (as the USB host delivers it); the rest waits, as it waits in the
    /// host, until the board reads on. The clock does not move.
    pub fn write(&mut self, text: &str) -> Vec<u8> {
        let mut left: Vec<u8> = text.bytes().collect();
        loop {
            let n = self.b.rx_space().min(left.len());
            for b in left.drain(..n) {
                self.b.receive(b);
            }
            let t = self.b.tick;
            self.to(t);
            if left.is_empty() || self.b.rx_space() == 0 {
                return left;
            }
        }
    }

    /// Writes `text` (all of it must be taken) and returns what came back.
    pub fn send(&mut self, text: &str) -> String {
        let left = self.write(text);
        assert!(left.is_empty(), "the board did not take {:?}", String::from_utf8_lossy(&left));
        self.take()
    }

    /// The replies so far.
    pub fn take(&mut self) -> String {
        String::from_utf8_lossy(&std::mem::take(&mut self.out)).into_owned()
    }

    /// Runs until the motion system is idle (at most `seconds` of board time).
    pub fn finish(&mut self, seconds: u64) {
        let (b, mut io) = self.io();
        assert!(b.settle(seconds * TICKS_PER_SECOND, &mut io), "the board is still busy after {seconds} s");
    }
}
