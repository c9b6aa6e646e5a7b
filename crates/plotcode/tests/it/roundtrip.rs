//! Emit, then parse: every shipped profile gives back the strokes it was given,
//! in order, pen by pen, within one device unit. (An EBB's strokes also pass
//! through the points where the planner's speed profile changes, within a
//! step of the line.)

use crate::path;

use plotcode::gcode::ParseOptions;
use plotcode::{DeviceProfile, EmitOptions, Protocol};
use proptest::prelude::*;
use strokes::{DVec2, Drawing, LineKind, Polyline};

/// A random drawing on an A4 or A3 page (either orientation), pens 1..=max_pen.
fn drawings(max_pen: u32) -> impl Strategy<Value = Drawing> {
    let page = prop_oneof![Just((297.0, 210.0)), Just((210.0, 297.0)), Just((420.0, 297.0))];
    let polyline = prop::collection::vec((0.0f64..1.0, 0.0f64..1.0), 2..12);
    let layer = (1..=max_pen, prop::bool::ANY, prop::collection::vec(polyline, 1..6));
    (page, prop::collection::vec(layer, 1..4)).prop_map(|((w, h), layers)| {
        let mut d = Drawing::new(w, h);
        for (pen, hidden, polys) in layers {
            let kind = if hidden { LineKind::Hidden } else { LineKind::Visible };
            let l = d.layer_mut(pen, kind);
            for pts in polys {
                l.polylines.push(Polyline::new(pts.iter().map(|&(u, v)| DVec2::new(u * w, v * h)).collect()));
            }
        }
        d
    })
}

/// What the device should draw: every polyline in device units, pen by pen,
/// in order, consecutive duplicates (after rounding to `step`) removed; a
/// hidden line as its dashes where the device has no line types (G-code).
/// Each with its first point on the page.
fn expected(d: &Drawing, e: &plotcode::Emitted, step: f64, cut_dashes: bool) -> Vec<(u32, Vec<DVec2>, DVec2)> {
    let mut out = Vec::new();
    for layer in &d.layers {
        for poly in &layer.polylines {
            let pieces = if cut_dashes && layer.kind == LineKind::Hidden {
                d.hidden_dash.cut(&poly.points, e.placement.scale)
            } else {
                vec![poly.points.clone()]
            };
            for piece in pieces {
                let mut pts: Vec<DVec2> = Vec::new();
                for &p in &piece {
                    let q = (e.placement.to_device(p) / step).round() * step;
                    if pts.last() != Some(&q) {
                        pts.push(q);
                    }
                }
                if pts.len() == 1 {
                    pts.push(pts[0]);
                }
                out.push((layer.pen, pts, piece[0]));
            }
        }
    }
    out
}

fn parsed(profile: &DeviceProfile, text: &str) -> Vec<(u32, Vec<DVec2>)> {
    let plot = match profile.protocol {
        Protocol::Hpgl => plotcode::hpgl::parse(text.as_bytes()).expect("our HP-GL parses"),
        Protocol::Gcode => plotcode::gcode::parse(text, &ParseOptions::for_profile(profile)).expect("our G-code parses"),
        Protocol::Ebb => plotcode::ebb::parse(text.as_bytes()).expect("our EBB text parses"),
    };
    assert!(plot.warnings.is_empty(), "{:?}", plot.warnings);
    plot.strokes
        .into_iter()
        .map(|s| {
            let mut pts = s.points;
            pts.dedup();
            if pts.len() == 1 {
                pts.push(pts[0]);
            }
            (s.pen, pts)
        })
        .collect()
}

fn check(profile: &DeviceProfile, d: &Drawing, relative: bool) -> Result<(), TestCaseError> {
    let opts = EmitOptions { relative, ..EmitOptions::default() };
    let e = plotcode::emit(d, profile, &opts).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let step = if profile.protocol == Protocol::Gcode { 0.001 } else { 1.0 };
    let want = expected(d, &e, step, profile.protocol != Protocol::Hpgl || !profile.line_types);
    let got = parsed(profile, &e.text);
    prop_assert_eq!(got.len(), want.len(), "stroke count, {}", profile.name);
    for ((gp, g), (wp, w, _)) in got.iter().zip(&want) {
        prop_assert_eq!(gp, wp);
        if profile.protocol == Protocol::Ebb {
            // Every vertex in order, and nothing further than a step off.
            let follows = path::follows(g, w, step);
            prop_assert!(follows.is_ok(), "{}: {}", profile.name, follows.unwrap_err());
            continue;
        }
        prop_assert_eq!(g.len(), w.len());
        for (a, b) in g.iter().zip(w) {
            // One device unit; G-code is far tighter (its unit is 1 mm, we write µm).
            prop_assert!((*a - *b).abs().max_element() <= step * 0.5 + 1e-9, "{} {a} vs {b}", profile.name);
        }
    }
    // And the device units map back to the page within one unit.
    for ((_, g), (_, _, start)) in got.iter().zip(&want) {
        let p0 = e.placement.to_page(g[0]);
        let tol = profile.unit_mm / e.placement.scale;
        prop_assert!((p0 - *start).length() <= tol * 1.5, "{p0} vs {start}");
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn every_profile_round_trips(d in drawings(6)) {
        for name in DeviceProfile::builtin_names() {
            let p = DeviceProfile::builtin(name).unwrap();
            if p.protocol == Protocol::Hpgl {
                check(&p, &d, false)?;
                check(&p, &d, true)?;
            } else {
                check(&p, &d, false)?;
            }
        }
    }
}

#[test]
fn emitting_is_deterministic() {
    let mut d = Drawing::new(297.0, 210.0);
    d.layer_mut(2, LineKind::Visible).polylines.push(Polyline::new(vec![DVec2::new(10.0, 10.0), DVec2::new(100.0, 150.0)]));
    for name in DeviceProfile::builtin_names() {
        let p = DeviceProfile::builtin(name).unwrap();
        let a = plotcode::emit(&d, &p, &EmitOptions::default()).unwrap().text;
        let b = plotcode::emit(&d.clone(), &p, &EmitOptions::default()).unwrap().text;
        assert_eq!(a, b, "{name}");
    }
}
