//! hiddenline's integration tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p hiddenline --test it MODULE::` runs one.

mod engine_proptest;
mod engine_scenes;
