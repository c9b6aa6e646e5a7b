//! plotcode's integration tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p plotcode --test it MODULE::` runs one.

mod dashes;
mod ebb;
mod fixtures;
mod path;
mod program;
mod roundtrip;
