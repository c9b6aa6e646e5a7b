//! HP-GL: the incremental [`Lexer`], the interpreter that turns instructions into
//! strokes, and the emitter.

pub mod lexer;

pub use lexer::{tokenize, Escape, EscapeKind, Instruction, LexError, LexErrorKind, Lexer, Token};
