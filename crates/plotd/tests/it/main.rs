//! plotd's integration tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p plotd --test it MODULE::` runs one.

mod budget;
mod check_pool;
mod child;
mod cli;
mod connections;
mod daemon;
mod demo;
mod ebb_restart;
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
mod users;
mod warnings;

/// The repository's root (examples, config).
fn repo() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A fresh directory for `case` of test module `module`, removed when
/// dropped; its name says which (the case made safe as a file name).
fn case_dir(module: &str, case: &str) -> tempfile::TempDir {
    let slug: String = case.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).collect();
    tempfile::Builder::new().prefix(&format!("plotd-{module}-{slug}-")).tempdir().unwrap()
}
