//! From a job's submitted content to the device's command text.
//!
//! HP-GL and G-code go to the device as given (after checking the language
//! fits); scenes are rendered (`scene::render`) and SVG drawings read
//! (`plotcode::svg_import`), both chained and ordered and emitted for the
//! device (`plotcode::emit`) exactly as `plotd render --device` does. Runs on a
//! blocking thread: rendering can take a while. A scene reads the files it
//! names from the job's attachments only (`scene::Attached`).

use crate::spool::JobKind;
use plotcode::{DeviceProfile, Program, Protocol};
use rayon::prelude::*;
use scene::Attached;
use scene::Scene;
use std::path::Path;

/// Turns content into a program for `device`; `files` are the job's
/// attachments (the files a scene names), the only files a scene may read.
/// The error is for humans.
///
/// # Errors
/// Why the content cannot be plotted on this device.
pub fn program_for(kind: JobKind, content: &[u8], files: &Attached, device: &DeviceProfile) -> Result<Program, String> {
    let pages = match (kind, device.protocol) {
        (JobKind::Hpgl, Protocol::Hpgl) | (JobKind::Gcode, Protocol::Gcode) => {
            vec![plotcode::cut(content, device).map_err(|e| e.to_string())?]
        }
        (JobKind::Hpgl, Protocol::Gcode) => return Err(format!("an HP-GL job cannot go to {} (G-code)", device.name)),
        (JobKind::Gcode, Protocol::Hpgl) => return Err(format!("a G-code job cannot go to {} (HP-GL)", device.name)),
        (JobKind::Scene, _) => render_scene(content, files, device)?,
        (JobKind::Svg, _) => vec![render_svg(content, device)?],
    };
    Program::paged(pages).ok_or_else(|| "nothing to plot".to_owned())
}

/// Loads submitted scene text, reading the files it names from `files` only
/// (never the daemon's file system): a name not attached, absolute, or with a
/// `..` is refused, naming the scene key and the path.
///
/// # Errors
/// The scene's own error (naming line and field, or key and path).
pub fn load_scene(content: &[u8], files: &Attached) -> Result<Scene, String> {
    let text = std::str::from_utf8(content).map_err(|e| format!("scene is not UTF-8 text (byte {})", e.valid_up_to()))?;
    // No directory: the loaders then ask `files` for the names as written.
    Scene::from_toml_in(text, Path::new(SCENE_NAME), files).map_err(|e| e.to_string())
}

/// What the daemon calls a submitted scene in messages.
const SCENE_NAME: &str = "submitted-scene.toml";

/// Renders scene text to the device's program: one per frame of its
/// `[animation]` (one for a still), frames rendered in parallel, each exactly
/// as `plotd render scene.toml -o f-%04d.hpgl --device` writes it.
///
/// # Errors
/// As [`load_scene`], or the emitter's error (naming the frame).
pub fn render_scene(content: &[u8], files: &Attached, device: &DeviceProfile) -> Result<Vec<Program>, String> {
    let scene = load_scene(content, files)?;
    let frames = scene.frame_count();
    (0..frames)
        .into_par_iter()
        .map(|i| {
            let in_frame = |e: String| if frames > 1 { format!("frame {i}: {e}") } else { e };
            let frame = scene.frame(i).map_err(|e| in_frame(e.to_string()))?;
            let drawing = crate::pipeline::plotted_drawing(&frame).map_err(|e| in_frame(e.to_string()))?;
            emit(&drawing, device).map_err(in_frame)
        })
        .collect()
}

/// Reads an SVG drawing and emits it for the device, as `plotd render
/// drawing.svg -o out.hpgl --device NAME` does (its own page size, no `--fit`).
///
/// # Errors
/// The SVG reader's error (saying where), or the emitter's.
pub fn render_svg(content: &[u8], device: &DeviceProfile) -> Result<Program, String> {
    let text = std::str::from_utf8(content).map_err(|e| format!("SVG is not UTF-8 text (byte {})", e.valid_up_to()))?;
    let drawing = crate::pipeline::plotted_svg(text).map_err(|e| format!("SVG: {e}"))?;
    emit(&drawing, device)
}

fn emit(drawing: &strokes::Drawing, device: &DeviceProfile) -> Result<Program, String> {
    // The daemon pauses for a pen change itself (`pen_change`), so the
    // program does not stop the board.
    let opts = plotcode::EmitOptions { pen_change_pauses: false, ..plotcode::EmitOptions::default() };
    let emitted = plotcode::emit(drawing, device, &opts).map_err(|e| e.to_string())?;
    Ok(emitted.program)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn repo() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    const CAMERA: &str = "[camera]\neye = [-9.0, -17.0, 10.0]\ntarget = [0.0, 0.0, 1.0]\nfov_deg = 32.0\n";

    #[test]
    fn a_scene_naming_a_file_not_sent_is_refused_naming_key_and_path() {
        let none = Attached::default();
        // (A mesh named `/etc/passwd` is refused for its extension before any read.)
        for (table, key) in
            [("[[map]]\noutline", "map[0].outline"), ("[[surface]]\ndata", "surface[0].data"), ("[[mesh]]\npath", "mesh[0].path")]
        {
            let scene = format!("{CAMERA}{table} = \"/etc/passwd.stl\"\n");
            let e = load_scene(scene.as_bytes(), &none).unwrap_err();
            assert!(e.contains(key) && e.contains("/etc/passwd") && e.contains("absolute"), "{e}");
        }
        let scene = format!("{CAMERA}[[symbols]]\ndata = \"/etc/passwd\"\n");
        let e = load_scene(scene.as_bytes(), &none).unwrap_err();
        assert!(e.contains("symbols[0].data") && e.contains("/etc/passwd") && e.contains("not served"), "{e}");
        let scene = format!("{CAMERA}[[surface]]\ndata = \"heights.csv\"\n");
        let e = load_scene(scene.as_bytes(), &none).unwrap_err();
        assert!(e.contains("surface[0].data") && e.contains("`heights.csv` was not sent with the job (sent: none)"), "{e}");
    }

    #[test]
    fn the_daemon_never_reads_the_file_system_for_a_scene() {
        // This mesh exists and loads from disk; the daemon must not read it,
        // by absolute path or by escaping upwards, attached or not.
        let obj = repo().join("examples/cube.obj").canonicalize().unwrap();
        let scene = format!("{CAMERA}[[mesh]]\npath = \"{}\"\n", obj.display());
        assert!(Scene::from_toml(&scene, Path::new("s.toml")).is_ok());
        assert!(load_scene(scene.as_bytes(), &Attached::default()).unwrap_err().contains("not served"));
        let cube = std::fs::read(&obj).unwrap();
        let escaping = Attached { files: BTreeMap::from([("../cube.obj".to_owned(), cube.clone())]) };
        let scene = format!("{CAMERA}[[mesh]]\npath = \"../cube.obj\"\n");
        assert!(load_scene(scene.as_bytes(), &escaping).unwrap_err().contains(".."));
        // Attached under its relative name, it is served.
        let sent = Attached { files: BTreeMap::from([("m/cube.obj".to_owned(), cube)]) };
        let scene = format!("{CAMERA}[[mesh]]\npath = \"./m/cube.obj\"\n");
        assert_eq!(load_scene(scene.as_bytes(), &sent).unwrap().meshes.len(), 1);
    }

    #[test]
    fn an_attached_animated_map_renders_as_from_disk() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("map")).unwrap();
        for f in ["westmark.geojson", "towns.csv"] {
            std::fs::copy(repo().join("examples/map").join(f), dir.path().join("map").join(f)).unwrap();
        }
        let text = format!(
            "{CAMERA}[[map]]\noutline = \"map/westmark.geojson\"\nprojection = \"mercator\"\noffset = [-15.0, -55.7]\n\
             [[symbols]]\ndata = \"./map/towns.csv\"\nshape = \"box\"\nsize = 0.5\nheight_scale = 0.01\npen = 2\n\
             [[labels]]\nplacement = \"ground\"\npen = 2\n\
             [animation]\nframes = 2\nfrom = \"pop1970\"\nto = \"pop2000\"\n"
        );
        let path = dir.path().join("movie.toml");
        std::fs::write(&path, &text).unwrap();
        let job = crate::client::read_job_file(&path, None).unwrap();
        assert_eq!(job.files.keys().collect::<Vec<_>>(), ["map/towns.csv", "map/westmark.geojson"]);
        let device = DeviceProfile::builtin("hp7475a").unwrap();
        let pages = render_scene(job.content.as_bytes(), &Attached { files: job.files }, &device).unwrap();
        let disk = Scene::load(&path).unwrap();
        let want: Vec<Program> =
            disk.frames().map(|f| emit(&crate::pipeline::plotted_drawing(&f.unwrap()).unwrap(), &device).unwrap()).collect();
        assert_eq!(pages.len(), 2);
        assert_eq!(pages, want);
        assert_ne!(pages[0], pages[1]);
    }
}
