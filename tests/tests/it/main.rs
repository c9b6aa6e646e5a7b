//! The end-to-end tests (crate `plotd-e2e`), in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p plotd-e2e --test it MODULE::` runs one.

mod any;
mod architecture;
mod axidraw;
mod axidraw_faults;
mod axidraw_found;
mod device;
mod e2e;
mod faults;
mod frames;
mod grbl;
mod manual;
mod maps;
mod pens;
mod position;
mod reasons;
mod stop_now;
mod svg;
mod web;
mod web_page;
