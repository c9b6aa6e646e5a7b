//! From a job's submitted content to the device's command text.
//!
//! HP-GL and G-code go to the device as given (after checking the language
//! fits); scenes are rendered (`hiddenline::render`) and SVG drawings read
//! (`plotcode::svg_import`), both chained and ordered and emitted for the
//! device (`plotcode::emit`) exactly as `plotd render --device` does. Runs on a
//! blocking thread: rendering can take a while.

use crate::device::{Device, Language};
use crate::program::Program;
use crate::spool::JobKind;
use rayon::prelude::*;
use std::path::Path;

/// Turns content into a program for `device`; the error is for humans.
///
/// # Errors
/// Why the content cannot be plotted on this device.
pub fn program_for(kind: JobKind, content: &[u8], device: &Device) -> Result<Program, String> {
    let pages = match (kind, device.language) {
        (JobKind::Hpgl, Language::Hpgl) | (JobKind::Gcode, Language::Gcode) => vec![content.to_vec()],
        (JobKind::Hpgl, Language::Gcode) => return Err(format!("an HP-GL job cannot go to {} (G-code)", device.name)),
        (JobKind::Gcode, Language::Hpgl) => return Err(format!("a G-code job cannot go to {} (HP-GL)", device.name)),
        (JobKind::Scene, _) => render_scene(content, device)?,
        (JobKind::Svg, _) => vec![render_svg(content, device)?],
    };
    let programs = pages.iter().map(|t| Program::build(t, device).map_err(|e| e.to_string())).collect::<Result<Vec<_>, _>>()?;
    Program::paged(programs).ok_or_else(|| "nothing to plot".to_owned())
}

/// Renders scene text to the device's commands: one text per frame of its
/// `[animation]` (one for a still), frames rendered in parallel, each exactly
/// as `plotd render scene.toml -o f-%04d.hpgl --device` writes it. The daemon
/// never opens paths named by a client, so a scene that names files (meshes,
/// height data) is refused: render it on the client side to HP-GL or G-code
/// instead.
///
/// # Errors
/// The scene's own error (naming line and field), or the emitter's (naming the frame).
pub fn render_scene(content: &[u8], device: &Device) -> Result<Vec<Vec<u8>>, String> {
    let text = std::str::from_utf8(content).map_err(|e| format!("scene is not UTF-8 text (byte {})", e.valid_up_to()))?;
    if let Some(key) = names_a_file(text) {
        return Err(format!(
            "the scene names a file (`{key}`); the daemon does not open client paths: render it with `plotd render --device` and submit the result"
        ));
    }
    let scene = hiddenline::Scene::from_toml(text, Path::new("submitted-scene.toml")).map_err(|e| e.to_string())?;
    let frames = scene.frame_count();
    (0..frames)
        .into_par_iter()
        .map(|i| {
            let in_frame = |e: String| if frames > 1 { format!("frame {i}: {e}") } else { e };
            let frame = scene.frame(i).map_err(|e| in_frame(e.to_string()))?;
            let drawing = crate::render::plotted_drawing(&frame).map_err(|e| in_frame(e.to_string()))?;
            emit(&drawing, device).map_err(in_frame)
        })
        .collect()
}

/// Reads an SVG drawing and emits it for the device, as `plotd render
/// drawing.svg -o out.hpgl --device NAME` does (its own page size, no `--fit`).
///
/// # Errors
/// The SVG reader's error (saying where), or the emitter's.
pub fn render_svg(content: &[u8], device: &Device) -> Result<Vec<u8>, String> {
    let text = std::str::from_utf8(content).map_err(|e| format!("SVG is not UTF-8 text (byte {})", e.valid_up_to()))?;
    let drawing = crate::render::plotted_svg(text).map_err(|e| format!("SVG: {e}"))?;
    emit(&drawing, device)
}

fn emit(drawing: &hiddenline::Drawing, device: &Device) -> Result<Vec<u8>, String> {
    let emitted = plotcode::emit(drawing, &device.profile, &plotcode::EmitOptions::default()).map_err(|e| e.to_string())?;
    Ok(emitted.text.into_bytes())
}

/// The first key of a scene that names a file to read, if any.
fn names_a_file(text: &str) -> Option<String> {
    let value: toml::Value = toml::from_str(text).ok()?;
    let table = value.as_table()?;
    for (kind, objects) in table {
        let Some(list) = objects.as_array() else { continue };
        for obj in list {
            if let Some(t) = obj.as_table() {
                for key in ["path", "data", "file", "outline"] {
                    if t.get(key).is_some_and(toml::Value::is_str) {
                        return Some(format!("[[{kind}]] {key}"));
                    }
                }
            }
        }
    }
    None
}
