//! scene's integration tests, in one binary (linking a test
//! binary takes seconds). Each module was a test file of its own;
//! `cargo test -p scene --test it MODULE::` runs one.

mod axes_labels;
mod grid_agreement;
mod knockout;
mod map_labels;
mod map_props;
mod map_reference;
mod map_scene;
mod meshes_as_exported;
mod scene_errors;
mod scene_props;
mod scenes;

/// A fresh directory for `case` of test module `module`, removed when
/// dropped; its name says which (the case made safe as a file name).
fn case_dir(module: &str, case: &str) -> tempfile::TempDir {
    let slug: String = case.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).collect();
    tempfile::Builder::new().prefix(&format!("plotd-{module}-{slug}-")).tempdir().unwrap()
}
