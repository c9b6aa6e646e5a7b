//! What a job must pass before it is queued, besides parsing: limits on the
//! work a scene asks for, and for HP-GL / G-code sent as they are, only
//! instructions the device knows and only coordinates it can reach. A job
//! refused here is refused at `submit` with the reason; one let through
//! would block its plotter's queue later with a device error, or take the
//! renderer's whole budget.
//!
//! These run in the job worker ([`crate::worker`]), under its budget.

use plotcode::{DeviceProfile, Protocol};
use scene::Work;

/// Most frames (sheets of paper) one animated scene may plot as a job.
pub const MAX_FRAMES: usize = 1000;
/// Most faces the general hidden-line engine may be given for one job, all
/// frames together (the fast grid engines' surfaces do not count).
pub const MAX_GENERAL_FACES: usize = 4_000_000;
/// Largest device text one job may become, all pages together, bytes.
pub const MAX_OUTPUT_BYTES: usize = 64 << 20;
/// DeviceProfile bytes a drawn segment takes at most, for the estimate of a
/// scene's output (`PD12345,-1234,` is 14; G-code's `X123.456 Y123.456` 17,
/// but a segment usually continues a stroke and costs one coordinate pair).
const BYTES_PER_SEGMENT: usize = 14;

/// Checks a scene's estimated work against the limits.
///
/// # Errors
/// A message naming the limit and the scene's figure.
pub fn scene_work(work: &Work) -> Result<(), String> {
    if work.frames > MAX_FRAMES {
        return Err(format!("[animation] frames: {} frames, the daemon plots at most {MAX_FRAMES} (one sheet each)", work.frames));
    }
    let faces = work.general_faces.saturating_mul(work.frames);
    if faces > MAX_GENERAL_FACES {
        return Err(format!(
            "{} faces for the general hidden-line engine ({} per frame x {} frames), the limit is {MAX_GENERAL_FACES}; \
             a surface alone (or with axes and contours) takes the fast grid engine and does not count",
            faces, work.general_faces, work.frames
        ));
    }
    let bytes = work.segments.saturating_mul(work.frames).saturating_mul(BYTES_PER_SEGMENT);
    if bytes > MAX_OUTPUT_BYTES {
        return Err(format!(
            "up to {} line segments ({} per frame x {} frames) make about {} MiB of device commands, the limit is {} MiB",
            work.segments.saturating_mul(work.frames),
            work.segments,
            work.frames,
            bytes >> 20,
            MAX_OUTPUT_BYTES >> 20
        ));
    }
    Ok(())
}

/// Checks the general hidden-line engine's estimated work on a scene
/// ([`scene::Scene::engine_estimate`]: from its faces' boxes in the
/// picture, without running the engine) against `limit` face tests, every
/// frame together (`max_face_tests` in the daemon's config). Cheap: it
/// lowers the scene once; a scene that would keep the engine busy for
/// hours is refused in seconds.
///
/// # Errors
/// A message naming the limit, the estimate and what it counts.
pub fn engine_work(scene: &scene::Scene, limit: u64) -> Result<(), String> {
    let Some(e) = scene.engine_estimate() else { return Ok(()) };
    let frames = scene.frame_count() as u64;
    let tests = e.tests.saturating_mul(frames);
    if tests <= limit {
        return Ok(());
    }
    let per_frame = if frames > 1 { format!(" per frame x {frames} frames") } else { String::new() };
    Err(format!(
        "the general hidden-line engine's work is estimated at {:.1e} face tests ({} faces, {} pairs of them overlapping \
         in the picture{per_frame}), over the limit of {:.1e} (max_face_tests in the daemon's config): faces that all \
         overlap each other cost the cube of their number",
        tests as f64, e.faces, e.overlaps, limit as f64
    ))
}

/// HP-GL instructions of the HP 7475A and its HP-GL/1 relatives (7550A,
/// 7585B, Roland DXY); anything else gets "instruction not recognized" from
/// the device.
const HPGL1: &[&[u8; 2]] = &[
    b"AA", b"AP", b"AR", b"AS", b"BL", b"CA", b"CC", b"CI", b"CM", b"CP", b"CS", b"CT", b"CV", b"DC", b"DF", b"DI", b"DL", b"DP", b"DR",
    b"DS", b"DT", b"EA", b"EP", b"ER", b"ES", b"EW", b"FP", b"FS", b"FT", b"GC", b"GM", b"GP", b"IM", b"IN", b"IP", b"IV", b"IW", b"KY",
    b"LB", b"LO", b"LT", b"NR", b"OA", b"OC", b"OD", b"OE", b"OF", b"OG", b"OH", b"OI", b"OK", b"OL", b"OO", b"OP", b"OS", b"OT", b"OW",
    b"PA", b"PB", b"PD", b"PG", b"PR", b"PS", b"PT", b"PU", b"RA", b"RO", b"RP", b"RR", b"SA", b"SC", b"SG", b"SI", b"SL", b"SM", b"SP",
    b"SR", b"SS", b"TL", b"UC", b"UF", b"VA", b"VN", b"VS", b"WD", b"WG", b"XT", b"YT",
];

/// What HP-GL/2 adds (for the `hpgl2-*` profiles).
const HPGL2: &[&[u8; 2]] = &[
    b"AC", b"AD", b"AT", b"BP", b"BR", b"BZ", b"CF", b"CO", b"CR", b"DV", b"EC", b"FI", b"FN", b"FR", b"LA", b"LM", b"MC", b"MG", b"MT",
    b"NP", b"PC", b"PE", b"PM", b"PP", b"PW", b"QL", b"RF", b"RT", b"SB", b"SD", b"SV", b"TD", b"TR", b"UL", b"WU",
];

/// Checks command text to be sent as it is: HP-GL instructions the device
/// knows, G-code the device runs, and every position within the plotting
/// range of the device's largest paper.
///
/// # Errors
/// A message naming the byte offset (HP-GL) or line (G-code), the
/// instruction and what is wrong.
pub fn device_text(text: &[u8], device: &DeviceProfile) -> Result<(), String> {
    match device.protocol {
        Protocol::Hpgl => hpgl(text, device),
        Protocol::Gcode => gcode(text, device),
        // Jobs for an EBB are scenes and SVG drawings, planned for it here.
        Protocol::Ebb => Err(format!("{} takes scenes and SVG drawings, not command text", device.name)),
    }
}

/// The plotting range over every paper the device takes, device units:
/// `[x_min, x_max, y_min, y_max]`.
fn reach(device: &DeviceProfile) -> [f64; 4] {
    device.paper.iter().fold([f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY], |r, p| {
        [r[0].min(p.x_range[0]), r[1].max(p.x_range[1]), r[2].min(p.y_range[0]), r[3].max(p.y_range[1])]
    })
}

fn outside(r: &[f64; 4], x: f64, y: f64) -> bool {
    // Half a unit of slack: coordinates are rounded to whole device units.
    !(r[0] - 0.5..=r[1] + 0.5).contains(&x) || !(r[2] - 0.5..=r[3] + 0.5).contains(&y)
}

fn hpgl(text: &[u8], device: &DeviceProfile) -> Result<(), String> {
    use plotcode::hpgl::{Interpreter, Lexer, Token};
    let hpgl2 = device.name.starts_with("hpgl2");
    let r = reach(device);
    let mut lexer = Lexer::new();
    lexer.feed(text);
    lexer.end();
    let mut interp = Interpreter::new();
    while let Some(token) = lexer.next_token().map_err(|e| e.to_string())? {
        let Token::Instruction(i) = &token else { continue };
        let known = HPGL1.contains(&&i.mnemonic) || (hpgl2 && HPGL2.contains(&&i.mnemonic));
        if !known {
            return Err(format!("HP-GL byte {}: {} is not an instruction the {} knows", i.offset, i.name(), device.name));
        }
        if let (b"SP", Some(&pen)) = (&i.mnemonic, i.params.first()) {
            if pen >= 1.0 && pen.trunc() > f64::from(device.pens) {
                return Err(format!(
                    "HP-GL byte {}: SP{pen} selects pen {pen}; the {} has pens 1 to {}",
                    i.offset, device.name, device.pens
                ));
            }
        }
        interp.execute(&token).map_err(|e| e.to_string())?;
        let at = interp.position();
        if outside(&r, at.x, at.y) {
            return Err(format!(
                "HP-GL byte {}: {} moves to ({}, {}), outside the {}'s plotting range x {}..{}, y {}..{}",
                i.offset,
                i.name(),
                at.x,
                at.y,
                device.name,
                r[0],
                r[1],
                r[2],
                r[3]
            ));
        }
    }
    Ok(())
}

fn gcode(text: &[u8], device: &DeviceProfile) -> Result<(), String> {
    let text = std::str::from_utf8(text).map_err(|e| format!("G-code is not UTF-8 text (byte {})", e.valid_up_to()))?;
    let options = plotcode::gcode::ParseOptions::for_profile(device);
    let plot = plotcode::gcode::parse(text, &options).map_err(|e| e.to_string())?;
    if let Some(w) = plot.warnings.iter().find(|w| w.message.contains("unsupported")) {
        return Err(format!("G-code {w}: GRBL would stop the job with an error"));
    }
    // Strokes are in device units (mm for G-code profiles).
    let r = reach(device);
    for p in plot.strokes.iter().flat_map(|s| &s.points) {
        if outside(&r, p.x, p.y) {
            let line = first_line_naming(text, p.x, p.y).map_or_else(String::new, |l| format!("line {l}: "));
            return Err(format!(
                "G-code {line}a stroke reaches ({}, {}) mm, outside the {}'s plotting range x {}..{}, y {}..{}",
                p.x, p.y, device.name, r[0], r[1], r[2], r[3]
            ));
        }
    }
    Ok(())
}

/// The first line with an `X` or `Y` word of this value (exact in absolute
/// mode, which is what plotters' G-code uses), to point at.
fn first_line_naming(text: &str, x: f64, y: f64) -> Option<usize> {
    text.lines()
        .position(|raw| match plotcode::gcode::parse_line(raw) {
            Ok(plotcode::gcode::Line::Block(b)) => {
                b.get('X').is_some_and(|v| (v - x).abs() < 1e-9) || b.get('Y').is_some_and(|v| (v - y).abs() < 1e-9)
            }
            _ => false,
        })
        .map(|i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_work_limits_name_the_figure() {
        let ok = Work { frames: 48, general_faces: 20_000, segments: 30_000 };
        scene_work(&ok).unwrap();
        let e = scene_work(&Work { frames: 1_000_000, ..ok }).unwrap_err();
        assert!(e.contains("1000000 frames") && e.contains("1000"), "{e}");
        // A 3000 x 3000 surface beside a polyline: the general engine's.
        let e = scene_work(&Work { frames: 1, general_faces: 18_000_000, segments: 18_000_000 }).unwrap_err();
        assert!(e.contains("18000000 faces"), "{e}");
        // Alone it takes the grid engine; its output is what is too large.
        let e = scene_work(&Work { frames: 1, general_faces: 0, segments: 18_000_000 }).unwrap_err();
        assert!(e.contains("MiB"), "{e}");
        scene_work(&Work { frames: 1, general_faces: 0, segments: 2_000_000 }).unwrap();
    }

    /// A scene of one mesh, `obj` sent with it, seen from `eye`.
    fn mesh_scene(obj: String, eye: [f64; 3]) -> scene::Scene {
        let toml = format!("[camera]\neye = {eye:?}\ntarget = [0.0, 0.0, 0.0]\nfov_deg = 35.0\n\n[[mesh]]\npath = \"m.obj\"\n");
        let files = scene::Attached { files: [("m.obj".to_string(), obj.into_bytes())].into() };
        crate::convert::load_scene(toml.as_bytes(), &files).unwrap()
    }

    /// A height field of `n` x `n` cells, two triangles each, rolling hills.
    fn height_field(n: usize) -> String {
        let mut obj = String::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (-1.0 + 2.0 * i as f64 / n as f64, -1.0 + 2.0 * j as f64 / n as f64);
                let z = 0.2 * (3.1 * x + 0.3).sin() * (2.3 * y - 0.4).cos();
                obj += &format!("v {x:.6} {y:.6} {z:.6}\n");
            }
        }
        let id = |i: usize, j: usize| j * (n + 1) + i + 1;
        for j in 0..n {
            for i in 0..n {
                obj += &format!(
                    "f {} {} {}\nf {} {} {}\n",
                    id(i, j),
                    id(i + 1, j),
                    id(i + 1, j + 1),
                    id(i, j),
                    id(i + 1, j + 1),
                    id(i, j + 1)
                );
            }
        }
        obj
    }

    #[test]
    fn an_estimate_over_the_limit_is_refused_naming_the_limit_and_the_figures() {
        // Two triangles folded like a roof: each box overlaps the other's.
        let roof = "v -1 -1 0\nv 1 -1 0\nv 1 1 0.5\nv -1 1 0\nf 1 2 3\nf 1 3 4\n".to_string();
        let scene = mesh_scene(roof, [4.0, -5.0, 3.0]);
        let estimate = scene.engine_estimate().unwrap();
        assert_eq!((estimate.faces, estimate.overlaps, estimate.tests), (2, 1, 8), "each face: 1 x (3 edges + 1)");
        engine_work(&scene, 8).unwrap();
        let e = engine_work(&scene, 7).unwrap_err();
        assert!(e.contains("8.0e0 face tests (2 faces, 1 pairs") && e.contains("limit of 7.0e0 (max_face_tests"), "{e}");
    }

    #[test]
    fn the_bundled_examples_and_a_million_triangle_height_field_pass_the_estimate() {
        let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
        let mut checked = 0;
        for entry in std::fs::read_dir(&examples).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let scene = scene::Scene::load(&path).unwrap();
                engine_work(&scene, crate::config::DEFAULT_MAX_FACE_TESTS).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                checked += 1;
            }
        }
        assert!(checked >= 10, "{checked} examples");
        // 708 x 708 cells: 1,002,528 triangles, seen at a slant.
        // 30.5 million overlapping pairs, 1.75 x 10^10 face tests.
        let terrain = mesh_scene(height_field(708), [2.0, -2.5, 1.2]);
        engine_work(&terrain, crate::config::DEFAULT_MAX_FACE_TESTS).unwrap();
    }

    #[test]
    fn hpgl_unknown_instructions_and_unreachable_points_are_refused_with_their_offset() {
        let hp = DeviceProfile::builtin("hp7475a").unwrap();
        device_text(b"IN;SP1;PU0,0;PD1000,1000;LBhi\x03;CI100;PU;SP0;", &hp).unwrap();
        let e = device_text(b"IN;SP1;ZZ12;PU;", &hp).unwrap_err();
        assert!(e.contains("byte 7") && e.contains("ZZ") && e.contains("hp7475a"), "{e}");
        // HP-GL/2 only: refused on a 7475A, fine on an HP-GL/2 device.
        let e = device_text(b"IN;PE<=;", &hp).unwrap_err();
        assert!(e.contains("byte 3") && e.contains("PE"), "{e}");
        let e = device_text(b"IN;PU0,0;PD100000,0;", &hp).unwrap_err();
        assert!(e.contains("byte 9") && e.contains("PD") && e.contains("100000"), "{e}");
        let e = device_text(b"IN;PU0,0;PR0,-90000;", &hp).unwrap_err();
        assert!(e.contains("byte 9") && e.contains("PR"), "{e}");
    }

    /// Issue 36: pen 7 for a 6-pen 7475A was accepted and failed later.
    #[test]
    fn hpgl_a_pen_the_plotter_does_not_have_is_refused_naming_it() {
        let hp = DeviceProfile::builtin("hp7475a").unwrap();
        device_text(b"IN;SP6;PU0,0;PD10,10;SP0;", &hp).unwrap();
        let e = device_text(b"IN;SP1;PU0,0;SP7;PD10,10;", &hp).unwrap_err();
        assert!(e.contains("byte 13") && e.contains("pen 7") && e.contains("pens 1 to 6"), "{e}");
    }

    #[test]
    fn gcode_unsupported_words_and_unreachable_points_are_refused_with_their_line() {
        let grbl = DeviceProfile::builtin("grbl-servo").unwrap();
        device_text(b"G21 G90\nM5\nG0 X10 Y10\nM3 S1000\nG1 X20 Y20 F1000\nM5\n", &grbl).unwrap();
        let e = device_text(b"G21 G90\nG0 X10 Y10\nG38.2 Z-5\n", &grbl).unwrap_err();
        assert!(e.contains("line 3"), "{e}");
        let e = device_text(b"G21 G90\nM3 S1000\nG1 X5000 Y10 F1000\nM5\n", &grbl).unwrap_err();
        assert!(e.contains("line 3") && e.contains("5000"), "{e}");
    }
}
