//! What a host sends a device besides the job's own commands: the
//! questions, controls and markers a streaming host needs, one module per
//! protocol, each a vocabulary of operations that know their bytes
//! ([`hpgl::Op`], [`grbl::Op`], [`ebb::Op`]) and the [`Marker`] that follows
//! every chunk of a job. What the device answers is read by
//! [`crate::answer`].
//!
//! A new protocol adds its module here, its answers there, and nothing else
//! knows its syntax.
//!
//! ```
//! use plotcode::control::{grbl, hpgl};
//! assert_eq!(hpgl::Op::FreeSpace.bytes(), b"\x1b.B");
//! assert_eq!(hpgl::sequence(&[hpgl::Op::LastError, hpgl::Op::Position]), b"OE;OA;");
//! assert_eq!(grbl::MARKER.bytes, b"G4P0\n");
//! ```

pub mod ebb;
pub mod grbl;
pub mod hpgl;
pub mod manual;

/// What follows each chunk of a job so that the device says when it has
/// executed the chunk: its answer confirms it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Marker {
    /// The marker, whole.
    pub bytes: &'static [u8],
    /// A shorter form, ended by the next chunk's first byte when that is a
    /// letter (HP-GL: `OE` before `PU` needs no `;`); `None` when the
    /// protocol has none.
    pub chained: Option<&'static [u8]>,
}

impl Marker {
    /// The shorter form that may follow a chunk whose successor is `next`:
    /// `Some` when the protocol has one and `next` starts with a letter,
    /// which ends it. The device answers it only once that letter comes.
    #[must_use]
    pub fn chained_before(&self, next: &[u8]) -> Option<&'static [u8]> {
        self.chained.filter(|_| next.first().is_some_and(u8::is_ascii_alphabetic))
    }
}
