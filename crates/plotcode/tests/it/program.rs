//! Programs: submitted files cut into chunks, and emitted files cut as the
//! daemon cuts them, with the render estimate's seconds.

use plotcode::{cut, emit, gcode, hpgl, DeviceProfile, EmitOptions, PenAt, Program};
use strokes::{DVec2, Drawing, LineKind, Polyline};

fn hp() -> DeviceProfile {
    DeviceProfile::builtin("hp7475a").unwrap()
}
fn grbl() -> DeviceProfile {
    DeviceProfile::builtin("grbl-servo").unwrap()
}
fn text(b: &[u8]) -> &str {
    std::str::from_utf8(b).unwrap()
}

#[test]
fn hpgl_cuts_at_pen_up_after_drawing() {
    let src = b"IN;SP1;VS10;PU0,0;PD100,0,100,100;PU200,200;PD300,300;SP2;PU0,0;PD0,10;PU;SP0;";
    let p = cut(src, &hp()).unwrap();
    let parts: Vec<&str> = p.chunks.iter().map(|c| text(&c.bytes)).collect();
    assert_eq!(parts, ["IN;SP1;VS10;PU0,0;PD100,0,100,100;", "PU200,200;PD300,300;SP2;", "PU0,0;PD0,10;", "PU;SP0;"]);
    // Concatenated chunks are the input, byte for byte.
    assert_eq!(p.bytes(), src.to_vec());
    // The `SP2;` ends the second chunk, which draws with pen 1.
    assert_eq!(p.chunks.iter().map(|c| c.pen).collect::<Vec<_>>(), [Some(1), Some(1), Some(2), None]);
    assert_eq!(p.chunks.iter().map(|c| c.draws).collect::<Vec<_>>(), [true, true, true, false]);
    assert_eq!(text(&p.chunks[1].resume), "PU;IN;SP1;VS10;PA;PU100,100;");
    assert_eq!(text(&p.chunks[2].resume), "PU;IN;SP2;VS10;PA;PU300,300;");
    assert!(p.chunks[0].seconds > 0.0);
}

/// Issue 36: a strict HP-GL device (a clone, an emulator) reads a bare `;`
/// or a line feed where an instruction should begin as error 1. What the
/// daemon sends is the file's instructions with nothing between them,
/// whoever wrote the file; an instruction ended by a line feed is ended by
/// `;`, and what is inside an instruction (a label's text) is kept.
#[test]
fn hpgl_chunks_carry_no_separators_between_instructions() {
    let src = b"IN;;\nSP1;\r\nPU0,0;PD10,10\n ;PU20,20;PD30,30;\x1b.B\nLBa\r\nb\x03;PU;SP0;\n";
    let p = cut(src, &hp()).unwrap();
    let parts: Vec<&str> = p.chunks.iter().map(|c| text(&c.bytes)).collect();
    assert_eq!(parts, ["IN;SP1;PU0,0;PD10,10;", "PU20,20;PD30,30;\x1b.BLBa\r\nb\x03", "PU;SP0;"]);
}

#[test]
fn hpgl_chunk_ends_are_where_the_device_leaves_the_pen() {
    let at = |x: f64, y: f64, down: bool| Some(PenAt { pos: DVec2::new(x, y), down, z: None });
    let p = cut(b"IN;PU0,0;PD100,0;PU;PR;PU5,5;PD10,0;SP2;PU;PA;PU7,7;PD8,8;LBab\x03PU;PU1,1;PD2,2;", &hp()).unwrap();
    let ends: Vec<_> = p.chunks.iter().map(|c| c.end).collect();
    // Relative moves add up; a pen change lifts the pen; a label moves the
    // pen where the cutter does not follow, until an absolute move.
    assert_eq!(ends, [at(100.0, 0.0, true), at(115.0, 5.0, false), None, at(2.0, 2.0, true)]);
    let p = cut(b"IN;SC0,10,0,10;PU0,0;PD1,1;PU;IN;PU0,0;PD3,3;", &hp()).unwrap();
    assert_eq!(p.chunks.iter().map(|c| c.end).collect::<Vec<_>>(), [None, at(3.0, 3.0, true)]);
}

#[test]
fn chunk_paths_are_every_rest_in_order() {
    let at = |x: f64, y: f64, down: bool| PenAt { pos: DVec2::new(x, y), down, z: None };
    let p = cut(b"IN;PU0,0;PD100,0,100,100;PU;LBab\x03PU5,5;PD6,6;", &hp()).unwrap();
    // The pen goes down before it moves: a device that lost the
    // coordinates rests there.
    let want = [at(0.0, 0.0, false), at(0.0, 0.0, true), at(100.0, 0.0, true), at(100.0, 100.0, true)];
    assert_eq!(p.chunks[0].path.as_deref(), Some(&want[..]));
    assert_eq!(p.chunks[0].path.as_ref().unwrap().last(), p.chunks[0].end.as_ref());
    // A label moves the pen where the cutter does not follow.
    assert_eq!(p.chunks[1].path, None);
    let p = cut(b"G0 X1 Y1\nM3\nG1 X2 Y2\nG1 X3 Y2\nM5\nG0 X5 Y5\nG1 X6 Y6\n", &grbl()).unwrap();
    assert_eq!(p.chunks[0].path, Some(vec![at(1.0, 1.0, false), at(2.0, 2.0, false), at(3.0, 2.0, false)]));
    assert_eq!(p.chunks[1].path, Some(vec![at(5.0, 5.0, false), at(6.0, 6.0, false)]));
    // The pen as GRBL shows it: the spindle (a servo) and Z.
    let p = cut(b"M3 S0\nG0 X1 Y1\nM3 S900\nG1 X2 Y2\nM5\nG0 Z5\nG0 X3 Y3\nG1 Z0\nG91\nG1 X1 Y1 Z-1\n", &grbl()).unwrap();
    let z = |x: f64, down: bool, z: Option<f64>| PenAt { pos: DVec2::new(x, x), down, z };
    let want =
        [z(0.0, false, None), z(1.0, false, None), z(1.0, true, None), z(2.0, true, None), z(2.0, false, None), z(2.0, false, Some(5.0))];
    assert_eq!(p.chunks[0].path.as_deref(), Some(&want[..]));
    assert_eq!(p.chunks[1].path, Some(vec![z(3.0, false, Some(5.0)), z(3.0, false, Some(0.0)), z(4.0, false, Some(-1.0))]));
}

#[test]
fn hpgl_relative_moves_resume_at_absolute_position() {
    let p = cut(b"IN;PR;PU10,10;PD5,0;PU5,5;PD0,5;", &hp()).unwrap();
    assert_eq!(p.chunks.len(), 2);
    assert_eq!(text(&p.chunks[1].resume), "PU;IN;PA;PU15,10;PR;");
}

#[test]
fn hpgl_labels_and_escapes() {
    let src = b"\x1b.@;0:IN;SP1;PU0,0;PD1,1;LBhi;PU there\x03PU5,5;PD6,6;DT#;LBa;b#PU;";
    let p = cut(src, &hp()).unwrap();
    assert_eq!(p.chunks.len(), 3);
    assert_eq!(text(&p.chunks[1].bytes), "PU5,5;PD6,6;DT#;LBa;b#");
}

/// A submitted file's line type is timed as the device draws it: types 2
/// and 3 lift the pen over each gap of a pattern whose length is a
/// percentage of the P1-P2 diagonal; other types count as solid.
#[test]
fn hpgl_line_types_are_timed_with_their_gaps() {
    let hp = hp();
    let m = hp.motion_model();
    let seconds = |src: &str| cut(src.as_bytes(), &hp).unwrap().seconds_from(0);
    // 4100 units: ten periods of a 10 % pattern of a 4000-unit diagonal (200
    // units drawn, 200 lifted), then 100 units of the eleventh dash.
    let line = "PU0,0;PD4100,0;PU;";
    let dashed = seconds(&format!("IN;IP0,0,4000,0;LT2,10;{line}"));
    let half = 200.0 * hp.unit_mm;
    let period = m.pen_drop_time + m.move_time(half, m.pen_down_speed) + m.pen_lift_time + m.move_time(half, m.pen_up_speed);
    let want = 10.0 * period + m.pen_drop_time + m.move_time(100.0 * hp.unit_mm, m.pen_down_speed) + m.pen_lift_time;
    assert!((dashed - want).abs() < 1e-9 * want, "{dashed} s, want {want} s");
    let solid = seconds(&format!("IN;{line}"));
    assert!(dashed > solid + 10.0 * (m.pen_lift_time + m.pen_drop_time), "{dashed} vs {solid}");
    for solid_again in ["LT;", "LT6,10;", "LT2,10;DF;", "LT2,10;IN;"] {
        assert_eq!(seconds(&format!("IN;IP0,0,4000,0;{solid_again}{line}")), solid, "{solid_again}");
    }
    // Without IP, P1 and P2 are taken at the default paper's corners.
    assert!(seconds(&format!("IN;LT2,10;{line}")) > solid);
}

#[test]
fn hpgl_errors_name_the_offset() {
    let e = cut(b"IN;PU0,0;PD1,x;", &hp()).unwrap_err();
    assert_eq!(e.offset, 9, "{e}");
    let e = cut(b"IN;#", &hp()).unwrap_err();
    assert_eq!(e.offset, 3);
    assert!(e.to_string().starts_with("HP-GL byte 3"), "{e}");
    let e = cut(b"IN;PD1,2,3;", &hp()).unwrap_err();
    assert!(e.message.contains("odd"), "{e}");
    let e = cut(b"IN;LBnever ends", &hp()).unwrap_err();
    assert_eq!(e.offset, 3, "{e}");
}

#[test]
fn empty_inputs() {
    assert!(cut(b"", &hp()).unwrap().chunks.is_empty());
    assert!(cut(b"  \n", &grbl()).unwrap().chunks.is_empty());
    let p = cut(b"IN;", &hp()).unwrap();
    assert_eq!(p.chunks.len(), 1);
    assert!(!p.chunks[0].draws);
}

#[test]
fn gcode_cuts_at_rapid_after_feed() {
    let src = "G21\nG90 ; absolute\nM5\nG0 X0 Y0\nM3 S90\nG1 X10 Y0 F1000\nG1 X10 Y10\nM5\nG0 X20 Y20\nM3 S90\n(comment)\nG1 X30 Y20\nM5\n\nG0 X0 Y0\n";
    let p = cut(src.as_bytes(), &grbl()).unwrap();
    let parts: Vec<&str> = p.chunks.iter().map(|c| text(&c.bytes)).collect();
    assert_eq!(
        parts,
        ["G21\nG90\nM5\nG0 X0 Y0\nM3 S90\nG1 X10 Y0 F1000\nG1 X10 Y10\nM5\n", "G0 X20 Y20\nM3 S90\nG1 X30 Y20\nM5\n", "G0 X0 Y0\n"]
    );
    assert_eq!(text(&p.pen_up), "M5\n");
    assert_eq!(text(&p.chunks[1].resume), "M5\nG21\nG90\nF1000\nG90\nG0 X10 Y10\n");
    assert!(!p.chunks[2].draws);
    let at = |x: f64, y: f64| Some(PenAt { pos: DVec2::new(x, y), down: false, z: None });
    assert_eq!(p.chunks.iter().map(|c| c.end).collect::<Vec<_>>(), [at(10.0, 10.0), at(30.0, 20.0), at(0.0, 0.0)]);
    // Work offsets: the position GRBL reports is no longer the text's.
    let p = cut(b"G0 X1 Y1\nM3\nG1 X2 Y2\nG0 X5 Y5\nG92 X0 Y0\nG1 X6 Y6\n", &grbl()).unwrap();
    assert_eq!(p.chunks.iter().map(|c| c.end).collect::<Vec<_>>(), [at(2.0, 2.0), None]);
}

#[test]
fn gcode_errors_name_the_offset() {
    let e = cut(b"G0 X1\nG1 X# Y2\n", &grbl()).unwrap_err();
    assert_eq!(e.offset, 9, "{e}");
    let e = cut(b"G0 X1\nG1 Xabc\n", &grbl()).unwrap_err();
    assert!(e.to_string().starts_with("G-code byte"), "{e}");
}

/// Drawings with pen changes, dots, long strokes, hidden lines.
fn drawings() -> Vec<Drawing> {
    let mut out = Vec::new();
    let mut d = Drawing::new(297.0, 210.0);
    let pts = |v: &[(f64, f64)]| Polyline::new(v.iter().map(|&(x, y)| DVec2::new(x, y)).collect());
    d.layer_mut(1, LineKind::Visible).polylines.push(pts(&[(20.0, 20.0), (100.0, 80.0), (120.0, 30.0)]));
    d.layer_mut(1, LineKind::Visible).polylines.push(pts(&[(50.0, 50.0), (50.001, 50.0)]));
    d.layer_mut(2, LineKind::Visible).polylines.push(pts(&[(10.0, 190.0), (200.0, 10.0)]));
    let wave: Vec<(f64, f64)> = (0..300).map(|i| (10.0 + i as f64 * 0.9, 100.0 + 40.0 * (i as f64 * 0.1).sin())).collect();
    d.layer_mut(2, LineKind::Visible).polylines.push(pts(&wave));
    d.layer_mut(3, LineKind::Visible).polylines.push(pts(&[(280.0, 200.0), (250.0, 180.0)]));
    out.push(d);
    out.push(Drawing::new(297.0, 210.0));
    // The first stroke's end is a pen change.
    let mut d = Drawing::new(297.0, 210.0);
    d.layer_mut(1, LineKind::Visible).polylines.push(pts(&[(20.0, 20.0), (100.0, 80.0)]));
    d.layer_mut(2, LineKind::Visible).polylines.push(pts(&[(10.0, 190.0), (200.0, 10.0)]));
    d.layer_mut(2, LineKind::Visible).polylines.push(pts(&[(30.0, 190.0), (220.0, 10.0)]));
    out.push(d);
    // Hidden lines (HP-GL dashes them with its line type, G-code cuts them
    // into strokes), one turning corners inside its dashes and gaps, and
    // solid lines after them on the same pen.
    let mut d = Drawing::new(297.0, 210.0);
    d.layer_mut(1, LineKind::Visible).polylines.push(pts(&[(20.0, 20.0), (100.0, 20.0)]));
    d.layer_mut(2, LineKind::Hidden).polylines.push(pts(&[(20.0, 40.0), (61.3, 40.0), (61.3, 42.2), (63.0, 43.0), (140.0, 90.0)]));
    d.layer_mut(2, LineKind::Hidden).polylines.push(pts(&[(150.0, 150.0), (150.0, 150.7)]));
    d.layer_mut(2, LineKind::Visible).polylines.push(pts(&[(200.0, 20.0), (210.0, 120.0)]));
    out.push(d);
    out
}

/// Every chunk from `from` on, after the resume prefix of chunk `from`: what
/// the device is sent when plotting goes on from there after an interruption.
pub(crate) fn resumed_at(p: &Program, from: usize) -> Vec<u8> {
    let mut out = p.chunks[from].resume.clone();
    for c in &p.chunks[from..] {
        out.extend_from_slice(&c.bytes);
    }
    out
}

/// What the daemon makes of an emitted HP-GL file (it cuts the text it is
/// given): the file's bytes, one drawing chunk per stroke, each with the
/// stroke's pen and ending where the stroke does, and each resuming, after
/// an interruption, to draw exactly what the file draws from there on.
#[test]
fn an_emitted_hpgl_file_cuts_into_its_strokes() {
    for d in drawings() {
        for relative in [false, true] {
            let mut profile = hp();
            profile.velocity_cm_s = Some(38.0);
            profile.max_instruction_bytes = 120;
            let e = emit(&d, &profile, &EmitOptions { relative, ..EmitOptions::default() }).unwrap();
            let c = cut(e.text.as_bytes(), &profile).unwrap();
            assert_eq!(text(&c.bytes()), e.text.replace('\n', ""), "the chunks are the file's instructions, no line feeds between");
            let strokes = hpgl::parse(e.text.as_bytes()).unwrap().strokes;
            assert_eq!(c.chunks.iter().filter(|c| c.draws).count(), strokes.len(), "one chunk per stroke");
            for (k, stroke) in strokes.iter().enumerate() {
                let chunk = &c.chunks[k];
                assert!(chunk.draws, "chunk {k}");
                assert_eq!(chunk.pen, Some(stroke.pen), "chunk {k}");
                assert_eq!(chunk.end.map(|e| e.pos), stroke.points.last().copied(), "chunk {k}");
                let resumed = hpgl::parse(&resumed_at(&c, k)).unwrap().strokes;
                assert_eq!(resumed, strokes[k..], "resumed at chunk {k} (relative: {relative})");
            }
            let last = c.chunks.last().unwrap();
            assert!(!last.draws && text(&last.bytes).ends_with("PU;SP0;"), "{:?}", text(&last.bytes));
        }
    }
}

/// The same for G-code. A file written for a sender pauses at pen changes
/// (`M0`); the daemon pauses itself and cuts the pauses out, so cutting
/// either file gives one program.
#[test]
fn an_emitted_gcode_file_cuts_into_its_strokes() {
    for name in ["grbl-servo", "grbl-z"] {
        let profile = DeviceProfile::builtin(name).unwrap();
        let g = profile.gcode.clone().unwrap();
        let read = gcode::ParseOptions::for_profile(&profile);
        for d in drawings() {
            let file = emit(&d, &profile, &EmitOptions::default()).unwrap();
            assert_eq!(file.text.contains("M0 (plotd: insert pen"), d.layers.len() > 1, "{}", file.text);
            let e = emit(&d, &profile, &EmitOptions { pen_change_pauses: false, ..EmitOptions::default() }).unwrap();
            let c = cut(e.text.as_bytes(), &profile).unwrap();
            assert_eq!(cut(file.text.as_bytes(), &profile).unwrap(), c, "{name}");
            // The cutter keeps the lines as GRBL reads them: the comment naming
            // the device and paper is the one line plotd writes that it drops.
            let lines: Vec<&str> = e.text.lines().filter(|l| !l.starts_with('(')).collect();
            assert_eq!(text(&c.bytes()), lines.join("\n") + "\n", "{name}");
            if d.stroke_count() > 0 {
                assert_eq!(text(&c.pen_up).trim_end(), g.pen_up, "{name}: a tool change or pause is not part of lifting the pen");
            }
            let strokes = gcode::parse(&e.text, &read).unwrap().strokes;
            assert_eq!(c.chunks.iter().filter(|c| c.draws).count(), strokes.len(), "{name}: one chunk per stroke");
            for (k, stroke) in strokes.iter().enumerate() {
                let chunk = &c.chunks[k];
                assert!(chunk.draws, "{name} chunk {k}");
                assert_eq!(chunk.pen, Some(stroke.pen), "{name} chunk {k}");
                assert_eq!(chunk.end.map(|e| e.pos), stroke.points.last().copied(), "{name} chunk {k}");
                // A resumed job starts with pen 1 as far as the reader knows:
                // the board keeps the pen it has, so only the lines count.
                let resumed = gcode::parse(text(&resumed_at(&c, k)), &read).unwrap().strokes;
                let points = |s: &[plotcode::Stroke]| s.iter().map(|s| s.points.clone()).collect::<Vec<_>>();
                assert_eq!(points(&resumed), points(&strokes[k..]), "{name}: resumed at chunk {k}");
            }
        }
    }
}

/// Fault 11: the daemon's ETA (the seconds of the chunks it cuts the
/// emitted file into, counted down) and the render estimate
/// (`stats.seconds`) are one plot-time model, on every device: pen lifts
/// and drops whether a servo or a Z axis moves the pen, the device's own
/// dashes, the moves the file makes and no others.
#[test]
fn chunk_seconds_add_up_to_the_render_estimate() {
    let mut apart = Vec::new();
    for name in DeviceProfile::builtin_names() {
        let profile = DeviceProfile::builtin(name).unwrap();
        for (i, d) in drawings().iter().enumerate() {
            for relative in [false, true] {
                let e = emit(d, &profile, &EmitOptions { relative, ..EmitOptions::default() }).unwrap();
                // An EBB program waits for its pen to be up (the servo's
                // raise time) before anything moves, strokes or none.
                let waits = profile.protocol == plotcode::Protocol::Ebb;
                assert_eq!(e.stats.seconds > 0.0, d.stroke_count() > 0 || waits, "{name} drawing {i}");
                let seconds = cut(e.text.as_bytes(), &profile).unwrap().seconds_from(0);
                if (seconds - e.stats.seconds).abs() > 1e-9 * e.stats.seconds {
                    apart.push(format!(
                        "{name} drawing {i} (relative: {relative}): cut {seconds:.4} s, render estimate {:.4} s",
                        e.stats.seconds
                    ));
                }
            }
        }
    }
    assert!(apart.is_empty(), "{}", apart.join("\n"));
}
