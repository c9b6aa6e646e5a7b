//! Hidden lines are dashed on the device, not only in the SVG preview: HP-GL
//! by the plotter's own line type (`LT`), G-code (and HP-GL devices without
//! line types) by dashes cut as strokes, at the drawing's dash and gap in
//! millimetres on paper; the plot-time estimate counts every dash's lift.

use plotcode::{cut, emit, DeviceProfile, EmitOptions};
use strokes::{DVec2, Dash, Drawing, LineKind, Polyline};

/// A visible 200 mm line (pen 1) and a hidden 200 mm line (pen 2) on A4.
fn drawing(dash: Dash) -> Drawing {
    let mut d = Drawing::new(297.0, 210.0);
    d.hidden_dash = dash;
    let line = |y: f64| Polyline::new(vec![DVec2::new(48.5, y), DVec2::new(248.5, y)]);
    d.layer_mut(1, LineKind::Visible).polylines.push(line(150.0));
    d.layer_mut(2, LineKind::Hidden).polylines.push(line(60.0));
    d
}

fn lengths_mm(plot: &plotcode::Plot, pen: u32, unit_mm: f64) -> Vec<f64> {
    plot.strokes.iter().filter(|s| s.pen == pen).map(|s| s.points.windows(2).map(|w| w[0].distance(w[1])).sum::<f64>() * unit_mm).collect()
}

#[test]
fn hpgl_dashes_hidden_lines_with_its_line_type_at_the_dash_length_on_paper() {
    let hp = DeviceProfile::builtin("hp7475a").unwrap();
    let e = emit(&drawing(Dash::default()), &hp, &EmitOptions::default()).unwrap();
    // P1, P2 at A4's hard-clip corners: a 5 mm period (3.5 + 1.5) is this
    // percentage of their diagonal; 70 % drawn is line type 3.
    let diagonal_mm = (11040.0f64.hypot(7721.0)) * 0.02488;
    let percent = 100.0 * 5.0 / diagonal_mm;
    assert!(e.text.starts_with("IN;IP0,0,11040,7721;\n"), "{}", e.text);
    let lt = format!("LT3,{};", (percent * 1e4).round() / 1e4);
    let hidden_at = e.text.find("SP2;").unwrap();
    assert!(e.text[hidden_at..].starts_with(&format!("SP2;\n{lt}\nPU")), "{}", e.text);
    assert!(e.text.ends_with("LT;PU;SP0;\n"), "solid again at the end: {}", e.text);
    assert!(!e.text[..hidden_at].contains("LT"), "visible lines are solid: {}", e.text);
    // Two strokes in the file; the estimate counts the 40 dashes the device
    // draws of the hidden one, each a lift and a drop.
    let c = cut(e.text.as_bytes(), &hp).unwrap();
    assert_eq!(c.chunks.iter().filter(|c| c.draws).count(), 2);
    assert_eq!(e.stats.pen_lifts, 41);
    // The chunks' seconds (the daemon's ETA) are the same estimate.
    assert!((c.seconds_from(0) - e.stats.seconds).abs() < 1e-9, "{} vs {}", c.seconds_from(0), e.stats.seconds);
    // A device that lost its state mid-line is put back in the line type.
    let hidden_chunk = c.chunks.iter().find(|c| c.pen == Some(2)).unwrap();
    let resume = String::from_utf8(hidden_chunk.resume.clone()).unwrap();
    assert!(resume.contains("IP0,0,11040,7721;") && resume.contains(&lt), "{resume}");
    // 50 % drawn is line type 2.
    let e2 = emit(&drawing(Dash { dash_mm: 2.0, gap_mm: 2.0 }), &hp, &EmitOptions::default()).unwrap();
    assert!(e2.text.contains(&format!("LT2,{};", (100.0 * 4.0 / diagonal_mm * 1e4).round() / 1e4)), "{}", e2.text);
}

#[test]
fn gcode_cuts_hidden_lines_into_dashes_and_the_estimate_counts_their_lifts() {
    let g = DeviceProfile::builtin("grbl-servo").unwrap();
    let dash = Dash { dash_mm: 3.0, gap_mm: 2.0 };
    let e = emit(&drawing(dash), &g, &EmitOptions::default()).unwrap();
    let plot = plotcode::gcode::parse(&e.text, &plotcode::gcode::ParseOptions::default()).unwrap();
    // 200 mm in 5 mm periods: 40 dashes of 3 mm, in order along the line.
    let dashes = lengths_mm(&plot, 2, 1.0);
    assert_eq!(dashes.len(), 40);
    assert!(dashes.iter().all(|l| (l - 3.0).abs() < 1e-3), "{dashes:?}");
    let starts: Vec<f64> = plot.strokes.iter().filter(|s| s.pen == 2).map(|s| s.points[0].x).collect();
    assert!(starts.windows(2).all(|w| (w[1] - w[0] - 5.0).abs() < 1e-3), "one run, in order: {starts:?}");
    assert_eq!(lengths_mm(&plot, 1, 1.0), vec![200.0]);
    // One chunk per dash (each resumes on its own), and the estimate counts
    // 41 strokes: 39 more lifts and drops than the hidden line drawn solid.
    assert_eq!(e.stats.strokes, 41);
    assert_eq!(cut(e.text.as_bytes(), &g).unwrap().chunks.iter().filter(|c| c.draws).count(), 41);
    let mut solid = drawing(dash);
    solid.layers[1].kind = LineKind::Visible;
    let s = emit(&solid, &g, &EmitOptions::default()).unwrap();
    let m = g.motion_model();
    let lifts = 39.0 * (m.pen_lift_time + m.pen_drop_time);
    assert!(e.stats.seconds - s.stats.seconds >= lifts, "{} vs {}", e.stats.seconds, s.stats.seconds);
    // Scaled down to fit, the dashes keep their length on paper.
    let mut big = drawing(dash);
    big.layers[0].polylines[0].points[1].x = 548.5;
    let e = emit(&big, &g, &EmitOptions::default()).unwrap();
    assert!(e.placement.scaled_down());
    let plot = plotcode::gcode::parse(&e.text, &plotcode::gcode::ParseOptions::default()).unwrap();
    let dashes = lengths_mm(&plot, 2, 1.0);
    assert!(dashes[..dashes.len() - 1].iter().all(|l| (l - 3.0).abs() < 2e-3), "{dashes:?}");
}

#[test]
fn an_hpgl_device_without_line_types_gets_dashes_as_strokes() {
    let mut hp = DeviceProfile::builtin("hp7475a").unwrap();
    hp.line_types = false;
    let e = emit(&drawing(Dash::default()), &hp, &EmitOptions::default()).unwrap();
    assert!(!e.text.contains("LT") && !e.text.contains("IP"), "{}", e.text);
    let plot = plotcode::hpgl::parse(e.text.as_bytes()).unwrap();
    let dashes = lengths_mm(&plot, 2, hp.unit_mm);
    assert_eq!(dashes.len(), 40);
    // Whole plotter units: within a unit of 3.5 mm.
    assert!(dashes.iter().all(|l| (l - 3.5).abs() < 2.0 * hp.unit_mm), "{dashes:?}");
}

/// The daemon resumes a dashed job from the chunks it cuts the file into:
/// a stroke's resume prefix puts the device back in the stroke's line type
/// (and P1, P2, which its length is a part of), dashed or solid.
#[test]
fn dashed_files_resume_in_their_line_type() {
    let mut d = drawing(Dash::default());
    // Visible again after hidden, on the same pen: `LT;` in between.
    d.layer_mut(2, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(10.0, 10.0), DVec2::new(20.0, 30.0)]));
    for name in ["hp7475a", "hp7585b"] {
        let hp = DeviceProfile::builtin(name).unwrap();
        let e = emit(&d, &hp, &EmitOptions::default()).unwrap();
        let ip = &e.text[e.text.find("IP").unwrap()..];
        let ip = &ip[..=ip.find(';').unwrap()];
        let lt = &e.text[e.text.find("LT3").unwrap()..];
        let lt = &lt[..=lt.find(';').unwrap()];
        let c = cut(e.text.as_bytes(), &hp).unwrap();
        let resumes: Vec<String> = c.chunks.iter().filter(|c| c.draws).map(|c| String::from_utf8_lossy(&c.resume).into_owned()).collect();
        // The pen change and line type before a stroke end the chunk before it.
        assert_eq!(resumes.len(), 3, "{name}");
        assert_eq!(resumes[0], "PU;", "{name}");
        assert!(resumes[1].starts_with(&format!("PU;IN;{ip}SP2;{lt}PA;PU")), "{name}: {}", resumes[1]);
        assert!(resumes[2].starts_with(&format!("PU;IN;{ip}SP2;LT;PA;PU")), "{name}: {}", resumes[2]);
    }
}
