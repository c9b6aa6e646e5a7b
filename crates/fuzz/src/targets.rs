//! The fuzz targets: one per parser of outside bytes, each running the real
//! path the bytes take (the daemon's and `plotd render`'s) and checking the
//! promises made about bad input beyond "no panic": errors are short and
//! name where the trouble is.

use crate::Input;
use plotcode::DeviceProfile;
use scene::{Attached, Scene, SceneError, SceneErrorKind};
use std::path::Path;

/// The longest error message a parser may give: it quotes at most a short
/// excerpt of the input, never a whole 100 KB line.
pub const MAX_MESSAGE_CHARS: usize = 600;

/// Scenes with more work than this (faces, grid points, line points, summed)
/// are loaded but not rendered by the fuzz targets: the render budget is the
/// daemon's, and a campaign needs many small inputs per second.
pub const MAX_RENDERED_WORK: usize = 20_000;

/// One fuzz target.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    /// Its name (the corpus directory under `corpus/`).
    pub name: &'static str,
    /// Whether inputs are bundles of files (a scene and the files it names)
    /// or one file.
    pub bundle: bool,
    /// Which files of a bundle are mutated (by name); single files always are.
    pub mutates: fn(&str) -> bool,
    /// Tokens of the format, for the mutator.
    pub dictionary: &'static [&'static [u8]],
    /// Runs one input; `Err` is a broken promise (a panic is caught apart).
    pub run: fn(&Input) -> Result<(), String>,
}

/// Every target.
pub const TARGETS: &[Target] = &[
    Target { name: "scene", bundle: true, mutates: |n| n == "scene.toml", dictionary: SCENE_WORDS, run: run_scene },
    Target { name: "mesh", bundle: true, mutates: |n| n.ends_with(".obj") || n.ends_with(".stl"), dictionary: MESH_WORDS, run: run_scene },
    Target {
        name: "data",
        bundle: true,
        mutates: |n| n.ends_with(".csv") || n.ends_with(".geojson") || n.ends_with(".json"),
        dictionary: DATA_WORDS,
        run: run_scene,
    },
    Target { name: "svg", bundle: false, mutates: |_| true, dictionary: SVG_WORDS, run: run_svg },
    Target { name: "hpgl", bundle: false, mutates: |_| true, dictionary: HPGL_WORDS, run: run_hpgl },
    Target { name: "gcode", bundle: false, mutates: |_| true, dictionary: GCODE_WORDS, run: run_gcode },
    Target { name: "request", bundle: false, mutates: |_| true, dictionary: REQUEST_WORDS, run: run_request },
];

/// The target called `name`.
#[must_use]
pub fn target(name: &str) -> Option<&'static Target> {
    TARGETS.iter().find(|t| t.name == name)
}

const SCENE_WORDS: &[&[u8]] = &[
    b"\n[[mesh]]\npath = \"cube.obj\"\n",
    b"\n[[polyline]]\npoints = [[0, 0, 0], [1e10, 0, 0]]\n",
    b"\n[[polygon]]\nouter = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]\n",
    b"\n[[surface]]\nz = \"x*y\"\n",
    b"\n[animation]\nframes = 3\nfrom = \"a\"\nto = \"b\"\n",
    b"transform = { scale = 1e300, translate = [1e308, 0, 0] }",
    b"steps = 100000",
    b"ortho_height = ",
    b"fov_deg = ",
    b"frame = \"fov\"",
    b"edges = \"feature\"",
    b"size = [1e9, 1]",
    b"\"",
    b"[",
    b"]",
    b"= ",
    b"\n",
];

const MESH_WORDS: &[&[u8]] = &[
    b"\nv 1e308 0 0\n",
    b"\nv 0 0 0 0\n",
    b"\nf 1 2 3\n",
    b"\nf -1 -2 -3\n",
    b"\nf 1/1/1 2//2 3\n",
    b"\nvt 0 0\n",
    b"\nvn 0 0 1\n",
    b"\nusemtl\n",
    b"\no x\n",
    b"solid ",
    b"facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n",
    b"\xff\xff\xff\xff",
    b"\x00\x00\x00\x00",
];

const DATA_WORDS: &[&[u8]] = &[
    b"[]",
    b"[1]",
    b"[1e308, -1e308]",
    b"{\"type\": \"Polygon\", \"coordinates\": [[[0]]]}",
    b"{\"type\": \"GeometryCollection\", \"geometries\": []}",
    b"\"coordinates\": ",
    b",",
    b"\n",
    b"\"",
    b",,,\n",
    b"name,lon,lat,value\n",
];

const SVG_WORDS: &[&[u8]] = &[
    b"<g>",
    b"</g>",
    b"<g id=\"a\">",
    b"<use href=\"#a\"/>",
    b"<circle r=\"1e12\" stroke=\"black\"/>",
    b"<ellipse rx=\"9.2e18\" ry=\"1\" stroke=\"black\"/>",
    b"<path d=\"M0 0 C 1e30 0 0 1e30 1 1\" stroke=\"black\"/>",
    b"<image href=\"/etc/passwd\"/>",
    b" transform=\"scale(1e30)\"",
    b" viewBox=\"0 0 1e-30 1e-30\"",
    b"<!DOCTYPE svg [<!ENTITY a \"aaaa\">]>",
    b"&a;",
    b"<text>x</text>",
];

const HPGL_WORDS: &[&[u8]] = &[
    b"PD",
    b"PU",
    b"PA",
    b"PR",
    b"SP1;",
    b"IN;",
    b"IP0,0,1e30,1;",
    b"SC0,1e-30,0,1;",
    b"LB",
    b"\x03",
    b"DT;",
    b"PE",
    b"\x1b.@;1:",
    b"\x1b.I81;;17:",
    b"\x1b%-1B",
    b"CI1e9;",
    b"AA0,0,360;",
    b"VS1e9;",
];

const GCODE_WORDS: &[&[u8]] = &[
    b"G0 X1e30 Y0\n",
    b"G1 X0 Y0 F1e-30\n",
    b"G2 X1 Y0 I1e9 J0\n",
    b"G3 X0 Y0 R1e-9\n",
    b"G20\n",
    b"G91\n",
    b"M3 S1000\n",
    b"M5\n",
    b"Z-1\n",
    b"(comment",
    b";",
    b"$H\n",
    b"G17 G21 G90\n",
];

const REQUEST_WORDS: &[&[u8]] = &[
    b"{\"cmd\":\"submit\",\"kind\":\"hpgl\",\"content\":\"IN;\"}\n",
    b"{\"cmd\":\"jobs\"}\n",
    b"{\"cmd\":\"cancel\",\"id\":18446744073709551616}\n",
    b"\"files\":{\"../../etc/shadow\":\"AAAA\"}",
    b"\\u0000",
    b"\n",
    b"\r\n",
];

/// A broken promise unless `message` is short.
fn short(what: &str, message: &str) -> Result<(), String> {
    let n = message.chars().count();
    if n > MAX_MESSAGE_CHARS {
        let head: String = message.chars().take(160).collect();
        return Err(format!("{what} error message is {n} characters (limit {MAX_MESSAGE_CHARS}): {head}..."));
    }
    Ok(())
}

/// The scene targets: load as the daemon does (files from the bundle only),
/// then render small scenes to device programs as a job would.
fn run_scene(input: &Input) -> Result<(), String> {
    let (main, text) = &input.files[0];
    let files = Attached { files: input.files[1..].iter().cloned().collect() };
    let Ok(text) = std::str::from_utf8(text) else { return Ok(()) };
    let scene = match Scene::from_toml_in(text, Path::new(main), &files) {
        Ok(s) => s,
        Err(e) => return check_scene_error(&e),
    };
    if work(&scene) > MAX_RENDERED_WORK {
        return Ok(());
    }
    let device = DeviceProfile::builtin("hp7475a").expect("built-in device");
    let last = scene.frame_count() - 1;
    for i in if last == 0 { vec![0] } else { vec![0, last] } {
        let frame = scene.frame(i).map_err(|e| format!("frame {i} of a loaded scene: {e}"))?;
        match plotd::pipeline::plotted_drawing(frame) {
            Ok(drawing) => emit_and_cut(&drawing, &device)?,
            Err(e) => short("render", &e.to_string())?,
        }
    }
    Ok(())
}

/// A scene error must be short and say where: a line or field, or be about a
/// whole file (named) or the scene as a whole; mesh errors give a line (OBJ)
/// or byte offset (STL).
fn check_scene_error(e: &SceneError) -> Result<(), String> {
    let message = e.to_string();
    short("scene", &message)?;
    let placed = e.line.is_some() || e.field.is_some();
    let whole = matches!(
        e.kind,
        SceneErrorKind::Io(_)
            | SceneErrorKind::FileTooLarge { .. }
            | SceneErrorKind::Refused(_)
            | SceneErrorKind::MeshFile { .. }
            | SceneErrorKind::UnknownMeshFormat
            | SceneErrorKind::Empty
            | SceneErrorKind::TooMany { .. }
            | SceneErrorKind::Map(_)
    );
    let stl_offset = matches!(e.kind, SceneErrorKind::Stl(_)) && message.contains("byte");
    if placed || whole || stl_offset {
        Ok(())
    } else {
        Err(format!("scene error names no line, field or byte: {message}"))
    }
}

/// A rough count of the engine's work for a scene: faces, grid points and line points.
fn work(scene: &Scene) -> usize {
    let meshes: usize = scene.meshes.iter().map(|m| m.faces.len()).sum();
    let lines: usize = scene.polylines.iter().map(|p| p.points.len()).sum();
    let grids: usize = scene.surfaces.iter().map(|s| s.grid.nx() * s.grid.ny()).sum();
    let ridges: usize = scene.ridgelines.iter().map(|r| r.profiles.iter().map(Vec::len).sum::<usize>()).sum();
    let maps = scene.maps.as_ref().map_or(0, |m| m.face_estimate());
    meshes + lines + grids + ridges + maps + scene.polygons.len()
}

/// Emits a drawing for `device` as a job's program; the emitted file must
/// cut back into the daemon's program as a submitted file would.
fn emit_and_cut(drawing: &strokes::Drawing, device: &DeviceProfile) -> Result<(), String> {
    match plotcode::emit(drawing, device, &plotcode::EmitOptions::default()) {
        Ok(e) => match plotcode::cut(e.text.as_bytes(), device) {
            Ok(_) => Ok(()),
            Err(err) => Err(format!("our own emitted file does not cut: {err}")),
        },
        Err(e) => short("emit", &e.to_string()),
    }
}

/// SVG as `plotd render drawing.svg` and an SVG job read it.
fn run_svg(input: &Input) -> Result<(), String> {
    let Ok(text) = std::str::from_utf8(&input.files[0].1) else { return Ok(()) };
    match plotd::pipeline::plotted_svg(text, None) {
        Ok(drawing) => emit_and_cut(&drawing, &DeviceProfile::builtin("hp7475a").expect("built-in device")),
        Err(e) => short("svg", &e.to_string()),
    }
}

/// HP-GL as `plotd render file.hpgl` reads it and as an HP-GL job is cut.
fn run_hpgl(input: &Input) -> Result<(), String> {
    let bytes = &input.files[0].1;
    if let Err(e) = plotcode::hpgl::parse(bytes) {
        short("hpgl", &e.to_string())?;
    }
    if let Err(e) = plotcode::cut(bytes, &DeviceProfile::builtin("hp7475a").expect("built-in device")) {
        short("hpgl program", &e.to_string())?;
    }
    Ok(())
}

/// G-code as `plotd render file.gcode` reads it and as a G-code job is cut.
fn run_gcode(input: &Input) -> Result<(), String> {
    let bytes = &input.files[0].1;
    let device = DeviceProfile::builtin("grbl-servo").expect("built-in device");
    if let Ok(text) = std::str::from_utf8(bytes) {
        if let Err(e) = plotcode::gcode::parse(text, &plotcode::gcode::ParseOptions::for_profile(&device)) {
            short("gcode", &e.to_string())?;
        }
    }
    if let Err(e) = plotcode::cut(bytes, &device) {
        short("gcode program", &e.to_string())?;
    }
    Ok(())
}

/// The daemon's socket request decoder, fed the bytes in uneven pieces as a
/// connection delivers them.
fn run_request(input: &Input) -> Result<(), String> {
    let bytes = &input.files[0].1;
    let limit = 4096;
    let mut lines = plotd::protocol::LineDecoder::new(limit);
    for piece in bytes.chunks(1 + bytes.len() % 97) {
        lines.extend(piece);
        loop {
            match lines.next_frame() {
                plotd::protocol::Frame::Incomplete => break,
                plotd::protocol::Frame::TooLong => {}
                plotd::protocol::Frame::Line(Ok(_)) => {}
                plotd::protocol::Frame::Line(Err(e)) => short("request", &e.to_string())?,
            }
        }
        if lines.held() > limit + piece.len() {
            return Err(format!("the decoder holds {} bytes, past its limit of {limit}", lines.held()));
        }
    }
    Ok(())
}
