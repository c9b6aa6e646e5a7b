//! plotsim's integration tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p plotsim --test it MODULE::` runs one.

mod binary;
mod common;
mod ebb_link;
mod grbl_link;
mod hpgl_link;
