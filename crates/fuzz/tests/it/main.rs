//! The fuzz targets' tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p fuzz --test it MODULE::` runs one.

mod targets;
