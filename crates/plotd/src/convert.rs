//! From a job's submitted content to the device's command text, in the job
//! worker ([`crate::worker`]), never in the daemon's own process.
//!
//! HP-GL and G-code go to the device as given (after checking the language
//! fits); scenes are rendered (`scene::render`) and SVG drawings read
//! (`plotcode::svg_import`), both chained and ordered and emitted for the
//! device (`plotcode::emit`) exactly as `plotd render --device` does. A scene
//! reads the files it names from the job's attachments only
//! (`scene::Attached`). An animation's frames are rendered a few at a time
//! (as many as there are cores) and handed on in order, never all held.

use crate::pen_map::PenMap;
use crate::spool::{JobKind, Occult};
use plotcode::{DeviceProfile, PenSettings, Protocol};
use rayon::prelude::*;
use scene::Attached;
use scene::Scene;
use std::path::Path;

/// Whether an HP-GL or G-code job can go to `device` as it is.
///
/// # Errors
/// The job's language is not the device's.
pub fn fits(kind: JobKind, device: &DeviceProfile) -> Result<(), String> {
    match (kind, device.protocol) {
        (JobKind::Hpgl, Protocol::Gcode) => Err(format!("an HP-GL job cannot go to {} (G-code)", device.name)),
        (JobKind::Gcode, Protocol::Hpgl) => Err(format!("a G-code job cannot go to {} (HP-GL)", device.name)),
        (JobKind::Hpgl | JobKind::Gcode, Protocol::Ebb) => {
            Err(format!("{} (EBB) takes scenes and SVG drawings, not command text", device.name))
        }
        _ => Ok(()),
    }
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

/// Renders a loaded scene to the device's commands: one text per frame of
/// its `[animation]` (one for a still), each exactly as `plotd render
/// scene.toml -o f-%04d.hpgl --device` writes it, given to `page` in order.
/// Frames are rendered in parallel, as many at a time as there are threads.
///
/// # Errors
/// The renderer's or emitter's error (naming the frame), or `page`'s.
pub fn render_scene(
    scene: &Scene,
    device: &DeviceProfile,
    pens: Pens<'_>,
    page: &mut dyn FnMut(Vec<u8>) -> Result<(), String>,
) -> Result<(), String> {
    let frames = scene.frame_count();
    let batch = rayon::current_num_threads().max(1);
    for start in (0..frames).step_by(batch) {
        let texts: Vec<Result<Vec<u8>, String>> = (start..(start + batch).min(frames))
            .into_par_iter()
            .map(|i| {
                let in_frame = |e: String| if frames > 1 { format!("frame {i}: {e}") } else { e };
                let frame = scene.frame(i).map_err(|e| in_frame(e.to_string()))?;
                let drawing = crate::pipeline::plotted_drawing(frame).map_err(|e| in_frame(e.to_string()))?;
                emit(drawing, device, pens).map_err(in_frame)
            })
            .collect();
        for text in texts {
            page(text?)?;
        }
    }
    Ok(())
}

/// Reads an SVG drawing and emits it for the device, as `plotd render
/// drawing.svg -o out.hpgl --device NAME` does (its own page size, no `--fit`).
///
/// # Errors
/// The SVG reader's error (saying where), or the emitter's.
pub fn render_svg(content: &[u8], device: &DeviceProfile, pens: Pens<'_>, occult: Option<Occult>) -> Result<Vec<u8>, String> {
    let text = std::str::from_utf8(content).map_err(|e| format!("SVG is not UTF-8 text (byte {})", e.valid_up_to()))?;
    let drawing = crate::pipeline::plotted_svg(text, occult.map(Into::into)).map_err(|e| format!("SVG: {e}"))?;
    emit(drawing, device, pens)
}

/// The pens a job is drawn with.
#[derive(Clone, Copy, Debug, Default)]
pub struct Pens<'a> {
    /// The job's pens mapped to the plotter's (`submit --pens`).
    pub map: Option<&'a PenMap>,
    /// The plotter's pen table: speed and force per pen.
    pub table: Option<&'a PenSettings>,
}

/// `drawing` for `device`, with `pens`.
fn emit(drawing: strokes::Drawing, device: &DeviceProfile, pens: Pens<'_>) -> Result<Vec<u8>, String> {
    // The daemon pauses for a pen change itself (`pen_change`), so the
    // program does not stop the board.
    let opts = plotcode::EmitOptions {
        pen_change_pauses: false,
        pens: pens.table.cloned().unwrap_or_default(),
        ..plotcode::EmitOptions::default()
    };
    let drawing = match pens.map {
        Some(map) => crate::pen_map::mapped(drawing, map),
        None => drawing,
    };
    let emitted = plotcode::emit(&drawing, device, &opts).map_err(|e| e.to_string())?;
    Ok(emitted.text.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn repo() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    const CAMERA: &str = "[camera]\neye = [-9.0, -17.0, 10.0]\ntarget = [0.0, 0.0, 1.0]\nfov_deg = 32.0\n";

    /// `--pens 1=3`: the red lines (pen 1, the first colour) are drawn
    /// with pen 3, the blue ones (pen 2) with their own.
    #[test]
    fn a_job_s_pens_are_drawn_with_the_pens_it_maps_them_to() {
        let svg = br#"<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
            <path d="M10 10 L50 10" stroke="red" fill="none"/><path d="M10 50 L50 70" stroke="blue" fill="none"/></svg>"#;
        let hp = DeviceProfile::builtin("hp7475a").unwrap();
        let pens = |text: Vec<u8>| -> Vec<(u32, usize)> {
            plotcode::hpgl::parse(&text).unwrap().strokes.iter().map(|s| (s.pen, s.points.len())).collect()
        };
        assert_eq!(pens(render_svg(svg, &hp, Pens::default(), None).unwrap()), [(1, 2), (2, 2)]);
        let map = PenMap::from([(1, 3)]);
        assert_eq!(pens(render_svg(svg, &hp, Pens { map: Some(&map), table: None }, None).unwrap()), [(3, 2), (2, 2)]);
    }

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
        let scene = load_scene(job.content.as_bytes(), &Attached { files: job.files }).unwrap();
        let mut pages = Vec::new();
        render_scene(&scene, &device, Pens::default(), &mut |text| {
            pages.push(text);
            Ok(())
        })
        .unwrap();
        let disk = Scene::load(&path).unwrap();
        let want: Vec<Vec<u8>> =
            disk.frames().map(|f| emit(crate::pipeline::plotted_drawing(f.unwrap()).unwrap(), &device, Pens::default()).unwrap()).collect();
        assert_eq!(pages.len(), 2);
        assert_eq!(pages, want);
        assert_ne!(pages[0], pages[1]);
    }
}
