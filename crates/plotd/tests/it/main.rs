//! plotd's integration tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p plotd --test it MODULE::` runs one.

mod budget;
mod child;
mod cli;
mod connections;
mod daemon;
mod demo;
mod hostile;
mod load;
mod locate;
mod maps_restart;
mod memory;
mod pens;
mod readme_commands;
mod render_cli;
mod render_device_cli;
mod render_frames;
mod render_grid_errors;
mod render_lifts;
mod render_stacks;
mod render_svg_cli;
mod restart;
mod sheets;
mod spool_faults;
mod spool_guard;
mod systemd;
mod systemd_units;
mod terminal;
mod warnings;
