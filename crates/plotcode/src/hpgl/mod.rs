//! HP-GL: the incremental [`Lexer`], the [`Interpreter`] that turns
//! instructions into strokes, and the emitter.

mod emit;
mod interp;
pub mod lexer;

pub use emit::emit;
pub use interp::{parse, HpglError, Interpreter};
pub use lexer::{tokenize, Escape, EscapeKind, Instruction, LexError, LexErrorKind, Lexer, Token};
