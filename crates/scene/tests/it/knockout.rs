//! Knockout text (issue 40, item 3): a `[[text]]` with `knockout = true`
//! is drawn whole over the picture and every other line is cut under it,
//! by the rule README states: the region is the convex hull of the text's
//! points, each widened to an octagon of radius a third of the hull's least
//! width. The judge builds that region itself (gift wrapping, not the
//! code's monotone chain) and samples the lines.

use glam::DVec2;
use scene::render::render;
use scene::Scene;
use std::path::Path;
use strokes::Drawing;

const SURFACE: &str = r#"
[camera]
eye = [5.0, -6.5, 4.0]
target = [0.0, 0.0, 0.0]
fov_deg = 35.0
frame = "fov"

[[surface]]
z = "0.8 * exp(-x^2 - y^2)"
x = { from = -2.0, to = 2.0, steps = 16 }
y = { from = -2.0, to = 2.0, steps = 16 }
lines = "both"
"#;

const TEXTS: &str = r#"
[[text]]
text = "KNOCK"
at = [120.0, 100.0]
size = 8.0
angle_deg = 20.0
pen = 2
knockout = KO

[[text]]
text = "peak"
world = [0.0, 0.6, 0.5]
size = 0.4
pen = 3
knockout = KO
"#;

fn drawing(toml: &str) -> Drawing {
    render(Scene::from_toml(toml, Path::new("knockout.toml")).unwrap()).unwrap()
}

fn lines_of(d: &Drawing, pen: u32) -> Vec<Vec<DVec2>> {
    d.layers.iter().filter(|l| l.pen == pen).flat_map(|l| l.polylines.iter().map(|p| p.points.clone())).collect()
}

/// Counter-clockwise hull by gift wrapping (Jarvis march).
fn hull(points: &[DVec2]) -> Vec<DVec2> {
    let start = *points.iter().min_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y))).unwrap();
    let mut out = vec![start];
    loop {
        let p = *out.last().unwrap();
        let mut q = points[0];
        for &r in points {
            let turn = (q - p).perp_dot(r - p);
            if q == p || turn < 0.0 || (turn == 0.0 && (r - p).length() > (q - p).length()) {
                q = r;
            }
        }
        if q == start {
            return out;
        }
        out.push(q);
    }
}

/// Signed distance from `q` to the convex ring: negative inside.
fn signed_distance(ring: &[DVec2], q: DVec2) -> f64 {
    let mut inside = f64::NEG_INFINITY;
    let mut outside = f64::INFINITY;
    for i in 0..ring.len() {
        let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
        let d = b - a;
        let t = ((q - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
        outside = outside.min((a + d * t - q).length());
        // Left of every edge: inside; the largest (least negative) margin.
        inside = inside.max(-d.normalize().perp_dot(q - a));
    }
    if inside < 0.0 {
        inside
    } else {
        outside
    }
}

/// The region README describes for a text's strokes.
fn region(text: &[Vec<DVec2>]) -> Vec<DVec2> {
    let pts: Vec<DVec2> = text.iter().flatten().copied().collect();
    let h = hull(&pts);
    let width = (0..h.len())
        .map(|i| {
            let (a, b) = (h[i], h[(i + 1) % h.len()]);
            h.iter().map(|&p| (b - a).normalize().perp_dot(p - a).abs()).fold(0.0, f64::max)
        })
        .fold(f64::INFINITY, f64::min);
    let m = width / 3.0;
    let widened: Vec<DVec2> =
        h.iter().flat_map(|&p| (0..8).map(move |k| p + DVec2::from_angle(f64::from(k) * std::f64::consts::FRAC_PI_4) * m)).collect();
    hull(&widened)
}

/// Points along `lines` every `step` mm, ends included.
fn samples(lines: &[Vec<DVec2>], step: f64) -> Vec<DVec2> {
    let mut out = Vec::new();
    for l in lines {
        for w in l.windows(2) {
            let n = ((w[1] - w[0]).length() / step).ceil().max(1.0) as usize;
            out.extend((0..=n).map(|k| w[0].lerp(w[1], k as f64 / n as f64)));
        }
    }
    out
}

fn distance_to(lines: &[Vec<DVec2>], q: DVec2) -> f64 {
    lines
        .iter()
        .flat_map(|l| l.windows(2))
        .map(|w| {
            let d = w[1] - w[0];
            let t = if d.length_squared() > 0.0 { ((q - w[0]).dot(d) / d.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
            (w[0] + d * t - q).length()
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn knockout_texts_are_whole_and_the_lines_under_them_cut_by_the_rule() {
    let plain = drawing(&format!("{SURFACE}{}", TEXTS.replace("KO", "false")));
    let knocked = drawing(&format!("{SURFACE}{}", TEXTS.replace("KO", "true")));
    // Fixed frame: a text alone lands where it does beside the surface.
    let alone = drawing(&format!("{}{}", SURFACE.split("[[surface]]").next().unwrap(), TEXTS.replace("KO", "true")));
    let (page_text, world_text) = (lines_of(&knocked, 2), lines_of(&knocked, 3));
    assert_eq!(page_text, lines_of(&plain, 2), "the page text is drawn as it was");
    assert_eq!(world_text, lines_of(&alone, 3), "the 3-D text is drawn whole, as with nothing in front of it");
    let hidden: f64 = samples(&lines_of(&plain, 3), 0.05).len() as f64 / samples(&world_text, 0.05).len() as f64;
    assert!(hidden < 0.99, "the surface hides part of the 3-D text when it is not a knockout ({hidden})");

    let regions = [region(&page_text), region(&world_text)];
    let surface_before = lines_of(&plain, 1);
    let surface_after = lines_of(&knocked, 1);
    // Nothing of the surface under a region.
    for q in samples(&surface_after, 0.05) {
        for r in &regions {
            assert!(signed_distance(r, q) > -1e-6, "a surface line passes under a knockout text at {q}");
        }
    }
    // Everything of the surface outside the regions is kept.
    let mut cut = 0;
    for q in samples(&surface_before, 0.2) {
        if regions.iter().all(|r| signed_distance(r, q) > 1e-6) {
            assert!(distance_to(&surface_after, q) < 1e-6, "a surface line was cut outside the regions at {q}");
        } else {
            cut += 1;
        }
    }
    assert!(cut > 10, "the texts stand over the surface's lines ({cut} samples under them)");
}

#[test]
fn the_bundled_maps_labels_knock_out_the_lines_under_them() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/map.toml"));
    let text = std::fs::read_to_string(path).unwrap();
    let labelled = |knockout: bool| {
        // Large names: no place around a town is clear of every line.
        let toml = text.replace("[[labels]]", &format!("[[labels]]\nheight = 1.2\nknockout = {knockout}"));
        // The labels on a pen of their own, to tell them apart.
        let toml = toml.rsplit_once("pen = 2").map(|(a, b)| format!("{a}pen = 3{b}")).unwrap();
        render(Scene::from_toml(&toml, path).unwrap()).unwrap()
    };
    let length = |lines: &[Vec<DVec2>]| lines.iter().flat_map(|l| l.windows(2)).map(|w| (w[1] - w[0]).length()).sum::<f64>();
    let (plain, knocked) = (labelled(false), labelled(true));
    let labels = lines_of(&knocked, 3);
    assert!(length(&labels) >= length(&lines_of(&plain, 3)) - 1e-9, "knockout labels are drawn whole");
    let others = |d: &Drawing| [lines_of(d, 1), lines_of(d, 2)].concat();
    assert!(length(&others(&knocked)) < length(&others(&plain)) - 1.0, "the lines under some label are cut");
    for q in samples(&others(&knocked), 0.05) {
        assert!(distance_to(&labels, q) > 1e-3, "a line runs through a label's stroke at {q}");
    }
}
