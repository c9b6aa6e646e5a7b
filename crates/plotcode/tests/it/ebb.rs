//! The EBB planner's output checked by an interpreter of its own: the
//! emitted commands run through the firmware's documented rules (EggBot
//! `docs/ebb.html`: `LM`'s accumulator stepping every 40 µs tick, `SM`'s
//! constant rates, `SP`'s waits, `EM` zeroing the counters), tick by tick,
//! sharing no code with plotcode's planner or its `LM` arithmetic. What it
//! checks: every stroke's vertices are reached (the whole-step positions the
//! page points round to, within one step of the unrounded ones), nothing
//! strays from the strokes, the speed and acceleration limits hold, corners
//! are taken no faster than the cornering tolerance allows, the steps add up
//! exactly (the carriage ends at home), and the render's estimate is the
//! time the firmware takes.

use crate::path;
use crate::program::resumed_at;

use plotcode::{cut, emit, DeviceProfile, EmitOptions};
use proptest::prelude::*;
use strokes::{DVec2, Drawing, LineKind, Polyline};

const STEP: i64 = 1 << 31;
const TICKS_PER_S: f64 = 25_000.0;

/// One motion command as the firmware ran it.
#[derive(Clone, Debug)]
struct Motion {
    /// Motor counters after it.
    to: [i64; 2],
    pen_down: bool,
    /// Path speed (steps/s) at the first and last tick (SM: its one speed).
    v_start: f64,
    v_end: f64,
    /// Path acceleration (steps/s^2) within the command (LM), 0 for SM.
    accel: f64,
    /// A move of at most two steps on each motor at a steady rate.
    tiny_steady: bool,
    /// How many ticks it ran (SM: its milliseconds in ticks).
    ticks: u64,
    /// Where the motion command came in the program (index of commands).
    index: usize,
}

/// A program run through the firmware's rules.
#[derive(Debug, Default)]
struct Run {
    motions: Vec<Motion>,
    /// Pen-down strokes: the counters after the pen went down and after each
    /// move while down.
    strokes: Vec<Vec<[i64; 2]>>,
    /// Each stroke's moves, indices into `motions`, in order.
    stroke_motions: Vec<Vec<usize>>,
    /// Where the program leaves the counters.
    end: [i64; 2],
    seconds: f64,
}

/// The per-tick rate (as a fraction of 2^31 a tick) of an LM axis at a tick.
fn steps_per_s(rate_per_tick: i64) -> f64 {
    rate_per_tick as f64 / STEP as f64 * TICKS_PER_S
}

/// Path speed from the two motor rates: x = (m1 + m2) / 2, y = (m1 - m2) / 2.
fn path_speed(f1: f64, f2: f64) -> f64 {
    ((f1 * f1 + f2 * f2) / 2.0).sqrt()
}

/// One LM axis, tick by tick: rate starts at Rate - Accel/2, then each tick
/// rate += Accel, accumulator += rate, a step when it reaches 2^31. Returns
/// (ticks to the last step, rate at the first tick, rate at the last tick).
fn lm_axis(rate: i64, steps: i64, accel: i64) -> (u64, i64, i64) {
    if steps == 0 {
        return (0, 0, 0);
    }
    let (mut r, mut acc, mut made, mut k) = (rate - accel / 2, 0_i64, 0_i64, 0_u64);
    let mut first = None;
    while made < steps.abs() {
        k += 1;
        r += accel;
        assert!(r >= 0, "LM rate went negative: {rate},{steps},{accel}");
        assert!(r < STEP, "LM rate above one step a tick: {rate},{steps},{accel}");
        assert!(k < 50_000_000, "LM never finishes: {rate},{steps},{accel}");
        first.get_or_insert(r);
        acc += r;
        if acc >= STEP {
            acc -= STEP;
            made += 1;
        }
    }
    (k, first.unwrap(), r)
}

fn run(text: &str) -> Run {
    let mut out = Run::default();
    let (mut at, mut pen_down) = ([0_i64; 2], false);
    let mut stroke: Option<Vec<[i64; 2]>> = None;
    let mut stroke_motions: Vec<usize> = Vec::new();
    for (index, cmd) in text.split('\r').filter(|c| !c.is_empty()).enumerate() {
        let mut w = cmd.split(',');
        let name = w.next().unwrap();
        let n: Vec<i64> = w.map(|v| v.parse().unwrap_or_else(|_| panic!("{cmd}"))).collect();
        let from = at;
        match name {
            "SC" | "SL" => {}
            "EM" => at = [0, 0],
            "SP" => {
                pen_down = n[0] == 0;
                out.seconds += n.get(1).copied().unwrap_or(0) as f64 / 1000.0;
                if pen_down && stroke.is_none() {
                    stroke = Some(vec![at]);
                } else if !pen_down && stroke.is_some() {
                    out.strokes.extend(stroke.take());
                    out.stroke_motions.push(std::mem::take(&mut stroke_motions));
                }
            }
            "LM" => {
                assert_eq!(n.len(), 7, "{cmd}");
                assert_eq!(n[6], 3, "accumulators cleared: {cmd}");
                let (k1, a1, b1) = lm_axis(n[0], n[1], n[2]);
                let (k2, a2, b2) = lm_axis(n[3], n[4], n[5]);
                let ticks = k1.max(k2);
                out.seconds += ticks as f64 / TICKS_PER_S;
                at = [at[0] + n[1], at[1] + n[4]];
                let unit_accel = TICKS_PER_S * TICKS_PER_S / STEP as f64;
                let (acc1, acc2) = (n[2] as f64 * unit_accel * f64::from(n[1] != 0), n[5] as f64 * unit_accel * f64::from(n[4] != 0));
                out.motions.push(Motion {
                    to: at,
                    pen_down,
                    v_start: path_speed(steps_per_s(a1), steps_per_s(a2)),
                    v_end: path_speed(steps_per_s(b1), steps_per_s(b2)),
                    accel: path_speed(acc1, acc2),
                    tiny_steady: n[2] == 0 && n[5] == 0 && n[1].abs() <= 2 && n[4].abs() <= 2,
                    ticks,
                    index,
                });
            }
            "SM" => {
                let ms = n[0] as f64;
                assert!(ms >= 1.0, "{cmd}");
                out.seconds += ms / 1000.0;
                at = [at[0] + n[1], at[1] + n[2]];
                let f = |s: i64| s.abs() as f64 * 1000.0 / ms;
                for s in [n[1], n[2]] {
                    assert!(s == 0 || (1.31..=25_000.0).contains(&f(s)), "SM rate out of the 2.x range: {cmd}");
                }
                let v = path_speed(f(n[1]), f(n[2]));
                let tiny_steady = n[1].abs() <= 2 && n[2].abs() <= 2;
                let ticks = (ms * TICKS_PER_S / 1000.0) as u64;
                out.motions.push(Motion { to: at, pen_down, v_start: v, v_end: v, accel: 0.0, tiny_steady, ticks, index });
            }
            other => panic!("a command the checker does not know: {other}"),
        }
        if at != from {
            if let Some(s) = &mut stroke {
                s.push(at);
                stroke_motions.push(out.motions.len() - 1);
            }
        }
    }
    if stroke.is_some() {
        out.stroke_motions.push(stroke_motions);
    }
    out.strokes.extend(stroke);
    out.end = at;
    out
}

fn xy(m: [i64; 2]) -> DVec2 {
    DVec2::new((m[0] + m[1]) as f64 / 2.0, (m[0] - m[1]) as f64 / 2.0)
}

/// The limits an AxiDraw profile states, in steps.
struct Limits {
    down_speed: f64,
    up_speed: f64,
    down_accel: f64,
    up_accel: f64,
    cornering: f64,
}

fn limits(p: &DeviceProfile) -> Limits {
    let e = p.ebb.as_ref().unwrap();
    let s = 1.0 / p.unit_mm;
    Limits {
        down_speed: p.pen_down_speed_mm_s * s,
        up_speed: p.pen_up_speed_mm_s * s,
        down_accel: e.pen_down_acceleration_mm_s2 * s,
        up_accel: e.pen_up_acceleration_mm_s2 * s,
        cornering: e.cornering_mm * s,
    }
}

/// The strokes the drawing should give: each polyline's page points on the
/// device (unrounded), a hidden line as its dashes, with its layer (pen and
/// kind: strokes of one layer that meet once rounded are drawn as one).
fn wanted(d: &Drawing, e: &plotcode::Emitted) -> Vec<((u32, LineKind), Vec<DVec2>)> {
    let mut out = Vec::new();
    for layer in &d.layers {
        for poly in &layer.polylines {
            let pieces =
                if layer.kind == LineKind::Hidden { d.hidden_dash.cut(&poly.points, e.placement.scale) } else { vec![poly.points.clone()] };
            for piece in pieces {
                out.push(((layer.pen, layer.kind), piece.iter().map(|&p| e.placement.to_device(p)).collect()));
            }
        }
    }
    out
}

/// Checks everything the module doc lists; `sm` for firmware below 2.7.0.
fn check(profile: &DeviceProfile, d: &Drawing) -> Result<(), TestCaseError> {
    let e = emit(d, profile, &EmitOptions::default()).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let r = run(&e.text);
    let lim = limits(profile);
    let sm = !e.text.contains("LM,");
    // The steps add up: back home exactly.
    prop_assert_eq!(r.end, [0, 0]);
    // The estimate is the firmware's time.
    prop_assert!(
        (r.seconds - e.stats.seconds).abs() <= 1e-9 * r.seconds.max(1.0),
        "firmware {} s, estimate {} s",
        r.seconds,
        e.stats.seconds
    );
    // Every stroke, vertex by vertex.
    let want = wanted(d, &e);
    let mut joined: Vec<((u32, LineKind), Vec<DVec2>)> = Vec::new();
    for (layer, w) in want {
        let mut rounded: Vec<DVec2> = Vec::new();
        for p in &w {
            if rounded.last() != Some(&p.round()) {
                rounded.push(p.round());
            }
        }
        match joined.last_mut() {
            _ if rounded.is_empty() => {}
            // A stroke that starts where the one before it ended, in its
            // layer, goes on from it: no lift to nowhere.
            Some((last_layer, last)) if *last_layer == layer && last.last() == rounded.first() => last.extend_from_slice(&rounded[1..]),
            _ => joined.push((layer, rounded)),
        }
    }
    let want: Vec<Vec<DVec2>> = joined.into_iter().map(|(_, w)| w).collect();
    prop_assert_eq!(r.strokes.len(), want.len(), "stroke count");
    for (k, (got, w)) in r.strokes.iter().zip(&want).enumerate() {
        let got: Vec<DVec2> = got.iter().map(|&m| xy(m)).collect();
        // Each vertex, in order, exactly at its whole-step position, and
        // nothing further than a step from the stroke.
        let follows = path::follows(&got, w, 1.0);
        prop_assert!(follows.is_ok(), "stroke {k}: {}", follows.unwrap_err());
        prop_assert_eq!(got.first(), w.first());
        prop_assert_eq!(got.last(), w.last());
    }
    // Speeds and accelerations.
    let tol = 1.0 + 1e-3;
    // SM's slices are whole steps: a step more on each motor in a slice of
    // at least 12.5 ms is 80 steps/s.
    let speed_slack = if sm { 81.0 } else { 0.0 };
    for m in &r.motions {
        let (v, a) = if m.pen_down { (lim.down_speed, lim.down_accel) } else { (lim.up_speed, lim.up_accel) };
        prop_assert!(m.v_start.max(m.v_end) <= v * tol + speed_slack, "too fast: {m:?}");
        prop_assert!(m.accel <= a * tol, "accelerates too hard: {m:?}");
    }
    if !sm {
        for w in r.motions.windows(2) {
            let (p, q) = (&w[0], &w[1]);
            let a = if p.pen_down || q.pen_down { lim.up_accel.max(lim.down_accel) } else { lim.up_accel };
            // At rest: slow enough to stop within a step.
            let rest = (2.0 * a).sqrt();
            let tick = 2.0 * a / TICKS_PER_S + 1e-6 * p.v_end.max(q.v_start);
            if q.index != p.index + 1 || p.pen_down != q.pen_down {
                prop_assert!(p.v_end <= rest && (q.v_start <= rest || q.tiny_steady), "not at rest at a pen move: {p:?} {q:?}");
            } else if !(p.tiny_steady || q.tiny_steady) {
                // Continuous, or a stop on both sides (a full reversal). A
                // command of k ticks has its speed to within 1/k (its length
                // is whole ticks).
                let whole_ticks = p.v_end / p.ticks as f64 + q.v_start / q.ticks as f64;
                let continuous = (p.v_end - q.v_start).abs() <= tick + whole_ticks + 1.0;
                prop_assert!(continuous || (p.v_end <= rest && q.v_start <= rest), "speed jumps: {p:?} {q:?}");
            }
        }
        // Corners: at each inner vertex, no faster than the junction allows
        // (the move that arrives there, the vertices taken in order).
        for (moves, w) in r.stroke_motions.iter().zip(&want) {
            let mut arriving = moves.iter().map(|&i| &r.motions[i]);
            for i in 1..w.len().saturating_sub(1) {
                let (d_in, d_out) = ((w[i] - w[i - 1]).normalize(), (w[i + 1] - w[i]).normalize());
                let half_angle_sine = ((1.0 + d_in.dot(d_out)) / 2.0).sqrt();
                let limit = if half_angle_sine >= 1.0 - 1e-9 {
                    lim.down_speed
                } else {
                    (lim.down_accel * lim.cornering * half_angle_sine / (1.0 - half_angle_sine)).sqrt().min(lim.down_speed)
                };
                let Some(m) = arriving.find(|m| xy(m.to) == w[i]) else {
                    return Err(TestCaseError::fail(format!("no move ends at vertex {}", w[i])));
                };
                // A full reversal stops: within a step's speed; any other
                // corner at its speed.
                let slack = if limit == 0.0 { (2.0 * lim.down_accel).sqrt() } else { limit * 1e-3 + 1.0 };
                prop_assert!(m.v_end <= limit + slack, "corner at {} taken at {} > {limit}", w[i], m.v_end);
            }
        }
    }
    Ok(())
}

fn pts(v: &[(f64, f64)]) -> Polyline {
    Polyline::new(v.iter().map(|&(x, y)| DVec2::new(x, y)).collect())
}

fn axidraw() -> DeviceProfile {
    DeviceProfile::builtin("axidraw").unwrap()
}

fn old_firmware() -> DeviceProfile {
    let mut p = axidraw();
    p.ebb.as_mut().unwrap().firmware = "2.6.5".parse().unwrap();
    p
}

/// A square, a zigzag with full reversals, a dot, two strokes meeting end
/// to start, a hidden line, a long curve and a two-pen drawing.
fn drawings() -> Vec<Drawing> {
    let mut d = Drawing::new(297.0, 210.0);
    let l = d.layer_mut(1, LineKind::Visible);
    l.polylines.push(pts(&[(20.0, 20.0), (120.0, 20.0), (120.0, 120.0), (20.0, 120.0), (20.0, 20.0)]));
    l.polylines.push(pts(&[(150.0, 30.0), (160.0, 30.0), (150.0, 30.0), (160.0, 30.01), (150.0, 30.5)]));
    l.polylines.push(pts(&[(200.0, 200.0), (200.0, 200.0)]));
    l.polylines.push(pts(&[(250.0, 10.0), (250.0125, 10.0)]));
    // A stroke that starts where the one before it ends: no travel between.
    l.polylines.push(pts(&[(40.0, 150.0), (60.0, 150.0)]));
    l.polylines.push(pts(&[(60.0, 150.0), (60.0, 170.0)]));
    let wave: Vec<(f64, f64)> = (0..400).map(|i| (10.0 + i as f64 * 0.7, 150.0 + 30.0 * (i as f64 * 0.05).sin())).collect();
    d.layer_mut(2, LineKind::Visible).polylines.push(pts(&wave));
    d.layer_mut(2, LineKind::Hidden).polylines.push(pts(&[(30.0, 190.0), (280.0, 185.0), (285.0, 60.0)]));
    vec![d, Drawing::new(297.0, 210.0)]
}

#[test]
fn the_firmware_draws_every_stroke_within_the_limits_in_the_estimated_time() {
    for d in drawings() {
        check(&axidraw(), &d).unwrap();
    }
}

#[test]
fn old_firmware_gets_sm_time_slices_that_draw_the_same() {
    for d in drawings() {
        let e = emit(&d, &old_firmware(), &EmitOptions::default()).unwrap();
        assert!(d.stroke_count() == 0 || (e.text.contains("\rSM,") && !e.text.contains("LM,")));
        check(&old_firmware(), &d).unwrap();
    }
}

#[test]
fn the_cube_reproduces_its_strokes_within_a_step() {
    let scene = scene::Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/cube.toml"))).unwrap();
    let mut d = scene::render(scene).unwrap();
    for l in &mut d.layers {
        l.polylines.retain(|p| p.points.len() >= 2);
    }
    check(&axidraw(), &d).unwrap();
    let e = emit(&d, &axidraw(), &EmitOptions::default()).unwrap();
    // 0.0125 mm a step: the whole-step vertices are within 0.009 mm of the page's.
    let r = run(&e.text);
    // (check has matched the strokes one to one; here every page vertex is
    // near what the firmware drew.)
    let drawn: Vec<DVec2> = r.strokes.iter().flatten().map(|&m| xy(m)).collect();
    for (_, want) in wanted(&d, &e) {
        for w in &want {
            let near = drawn.iter().map(|&g| (g - *w).length()).fold(f64::INFINITY, f64::min);
            assert!(near * axidraw().unit_mm <= 0.05, "{w}: {near} steps");
        }
    }
}

/// A random drawing on an A4 page: pens 1..=2, visible or hidden lines.
fn random_drawings() -> impl Strategy<Value = Drawing> {
    let polyline = prop::collection::vec((0.0f64..1.0, 0.0f64..1.0), 2..10);
    let layer = (1..=2u32, prop::bool::ANY, prop::collection::vec(polyline, 1..4));
    prop::collection::vec(layer, 1..3).prop_map(|layers| {
        let mut d = Drawing::new(297.0, 210.0);
        for (pen, hidden, polys) in layers {
            let kind = if hidden { LineKind::Hidden } else { LineKind::Visible };
            for p in polys {
                // Some strokes tiny: a few steps across.
                let scale = if p.len() % 3 == 0 { 0.2 } else { 280.0 };
                d.layer_mut(pen, kind)
                    .polylines
                    .push(pts(&p.iter().map(|&(u, v)| (5.0 + u * scale, 5.0 + v * scale * 0.7)).collect::<Vec<_>>()));
            }
        }
        d
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn random_polylines_keep_to_the_plan(d in random_drawings()) {
        check(&axidraw(), &d)?;
    }

    #[test]
    fn random_polylines_on_old_firmware(d in random_drawings()) {
        check(&old_firmware(), &d)?;
    }
}

/// What a daemon makes of an emitted file: the file's bytes, one drawing
/// chunk per stroke with its pen, ending where the stroke does (in steps);
/// seconds that add up to the estimate; and after an interruption, a resume
/// that draws exactly the rest.
#[test]
fn an_emitted_program_cuts_into_its_strokes_and_resumes() {
    for profile in [axidraw(), old_firmware()] {
        for d in drawings() {
            let e = emit(&d, &profile, &EmitOptions::default()).unwrap();
            let c = cut(e.text.as_bytes(), &profile).unwrap();
            assert_eq!(c.bytes(), e.text.as_bytes(), "the chunks are the file");
            assert!((c.seconds_from(0) - e.stats.seconds).abs() <= 1e-9 * e.stats.seconds.max(1.0));
            let strokes = plotcode::ebb::parse(e.text.as_bytes()).unwrap().strokes;
            assert_eq!(c.chunks.iter().filter(|c| c.draws).count(), strokes.len(), "one chunk per stroke");
            for (k, stroke) in strokes.iter().enumerate() {
                let chunk = &c.chunks[k];
                assert!(chunk.draws);
                assert_eq!(chunk.pen, Some(stroke.pen));
                let end = chunk.end.unwrap();
                assert_eq!((end.pos, end.down), (*stroke.points.last().unwrap(), false));
                assert_eq!(chunk.path.as_ref().unwrap().last(), Some(&end));
                // Resumed at chunk k from anywhere (here: home, its counters
                // kept), the rest is drawn as the file draws it.
                let resumed = plotcode::ebb::parse(&resumed_at(&c, k)).unwrap().strokes;
                let points = |s: &[plotcode::Stroke]| s.iter().map(|s| s.points.clone()).collect::<Vec<_>>();
                assert_eq!(points(&resumed), points(&strokes[k..]), "resumed at chunk {k}");
                let resume = String::from_utf8(chunk.resume.clone()).unwrap();
                assert!(resume.starts_with("SC,4,20641\rSC,5,15248\rSC,11,1618\rSC,12,1079\rSP,1,130\rHM,3200"), "{resume:?}");
                assert!(!resume.contains("EM"), "a resume never moves home: {resume:?}");
            }
            let last = c.chunks.last().unwrap();
            assert!(!last.draws && last.end.unwrap().pos == DVec2::ZERO, "the last chunk goes home");
            assert_eq!(c.pen_up, b"SP,1,130\r");
        }
    }
}

#[test]
fn the_sheet_drawing_is_what_the_program_draws() {
    let d = &drawings()[0];
    let profile = axidraw();
    let (sheet, placement) = plotcode::ebb::on_sheet(d, &profile, &EmitOptions::default()).unwrap();
    assert_eq!((sheet.width_mm, sheet.height_mm, placement.paper.as_str()), (297.0, 210.0, "A4"));
    let e = emit(d, &profile, &EmitOptions::default()).unwrap();
    let drawn = plotcode::ebb::parse(e.text.as_bytes()).unwrap().strokes;
    let on_sheet: Vec<&Polyline> = sheet.layers.iter().flat_map(|l| &l.polylines).collect();
    assert_eq!(on_sheet.len(), drawn.len());
    // In stroke order per pen; each vertex on the sheet is a place the
    // program stops at, home at the top-left corner.
    for poly in on_sheet {
        let device: Vec<DVec2> = poly.points.iter().map(|p| DVec2::new(p.x / 0.0125, (210.0 - p.y) / 0.0125)).collect();
        assert!(drawn.iter().any(|s| device.iter().all(|v| s.points.iter().any(|q| (*q - *v).length() < 1e-6))), "{device:?}");
    }
}
