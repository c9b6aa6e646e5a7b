//! HP-GL: the incremental [`Lexer`], the [`Interpreter`] that turns
//! instructions into strokes, the emitter, and the cutter of submitted files
//! into chunks.

mod cut;
mod emit;
mod interp;
pub mod lexer;

pub use cut::cut;
pub use emit::{emit, emit_to};
pub use interp::{parse, HpglError, Interpreter};
pub use lexer::{tokenize, Escape, EscapeKind, Instruction, LexError, LexErrorKind, Lexer, Token};
