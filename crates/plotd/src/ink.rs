//! What a drawing asks of its pens: the ink each one lays down, and a
//! warning when a pen's lines lie so close together that they run into a
//! solid band ([`strokes::crowding`]).
//!
//! The pen's width is `plotd render --pen-width` today; a plotter's pen
//! table gives it per pen later: [`crowding_warnings`] takes it per pen.

use strokes::{Drawing, PenCrowding};

/// Pen width when none is given, mm: the fine fibre-tip pens of the HP
/// plotters, and a common fine-liner.
pub const DEFAULT_PEN_WIDTH_MM: f64 = 0.3;

/// A pen whose ink lies closer than its width to a parallel line for more
/// than this share of its length gets a warning: a fifth of a drawing
/// running together shows as black patches. With a 0.3 mm pen the bundled
/// surface (60 x 60) has none, the map's small labels 12 %, the same
/// surface at 200 x 200 19 % and at 400 x 400 49 %.
pub const CROWDED_SHARE_WARNING: f64 = 0.2;

/// One warning per pen whose lines crowd (more than
/// [`CROWDED_SHARE_WARNING`] of its ink closer than its width to a
/// parallel line): how much, and what would help.
#[must_use]
pub fn crowding_warnings(drawing: &Drawing, width_mm: impl Fn(u32) -> f64) -> Vec<String> {
    strokes::crowding(drawing, width_mm).iter().filter(|c| c.crowded_share > CROWDED_SHARE_WARNING).map(warning).collect()
}

fn warning(c: &PenCrowding) -> String {
    let mut advice = Vec::new();
    if let Some(n) = c.spacing_factor() {
        advice.push(format!("fewer lines (`every = {n}` on a [[surface]] draws one grid line in {n})"));
    }
    advice.push("a coarser grid or larger text".to_string());
    match c.median_gap_mm {
        Some(gap) => advice.push(format!("a pen finer than {gap:.2} mm")),
        None => advice.push("a finer pen".to_string()),
    }
    format!(
        "pen {}: {:.0} % of its {:.1} m of ink lies closer than the pen's width ({:.2} mm) to a parallel line \
         (median gap {:.2} mm) and will plot as a solid band; try {}",
        c.pen,
        c.crowded_share * 100.0,
        c.ink_mm / 1000.0,
        c.width_mm,
        c.median_gap_mm.unwrap_or(0.0),
        advice.join(", or ")
    )
}

/// `, ink: pen 1 500.0 mm, pen 2 331.6 mm` (each pen's visible and hidden
/// lines, in order of first use) when the drawing uses more than one pen;
/// with one, the summary's drawn length is its ink.
#[must_use]
pub fn per_pen(drawing: &Drawing) -> String {
    let mut pens: Vec<(u32, f64)> = Vec::new();
    for layer in &drawing.layers {
        let mm: f64 = layer.polylines.iter().map(strokes::Polyline::length).sum();
        match pens.iter_mut().find(|(pen, _)| *pen == layer.pen) {
            Some((_, total)) => *total += mm,
            None => pens.push((layer.pen, mm)),
        }
    }
    if pens.len() < 2 {
        return String::new();
    }
    let each: Vec<String> = pens.iter().map(|(pen, mm)| format!("pen {pen} {mm:.1} mm")).collect();
    format!(", ink: {}", each.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use strokes::{DVec2, LineKind, Polyline};

    fn line(d: &mut Drawing, pen: u32, kind: LineKind, y: f64, len: f64) {
        d.layer_mut(pen, kind).polylines.push(Polyline::new(vec![DVec2::new(10.0, y), DVec2::new(10.0 + len, y)]));
    }

    #[test]
    fn ink_per_pen_only_for_several_pens() {
        let mut d = Drawing::new(297.0, 210.0);
        line(&mut d, 1, LineKind::Visible, 10.0, 50.0);
        assert_eq!(per_pen(&d), "");
        line(&mut d, 2, LineKind::Visible, 20.0, 30.0);
        line(&mut d, 1, LineKind::Hidden, 30.0, 5.5);
        assert_eq!(per_pen(&d), ", ink: pen 1 55.5 mm, pen 2 30.0 mm");
    }

    #[test]
    fn crowded_pens_are_warned_with_advice() {
        let mut d = Drawing::new(297.0, 210.0);
        for k in 0..40 {
            line(&mut d, 2, LineKind::Visible, 20.0 + 0.1 * f64::from(k), 100.0);
        }
        line(&mut d, 1, LineKind::Visible, 150.0, 100.0);
        let w = crowding_warnings(&d, |_| 0.3);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("pen 2: 100 % of its 4.0 m of ink lies closer than the pen's width (0.30 mm)"), "{}", w[0]);
        assert!(w[0].contains("(median gap 0.10 mm)") && w[0].contains("`every = 3` on a [[surface]]"), "{}", w[0]);
        assert!(w[0].ends_with("or a pen finer than 0.10 mm"), "{}", w[0]);
        assert!(crowding_warnings(&d, |_| 0.05).is_empty());
    }

    /// The bundled surface at `steps` x `steps`, drawing one line in `every`.
    fn surface(steps: usize, every: usize) -> Drawing {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/surface.toml")).unwrap();
        let text = text.replace("steps = 60", &format!("steps = {steps}")).replace("lines = \"both\"", &format!("every = {every}"));
        scene::render(scene::Scene::from_toml(&text, std::path::Path::new("surface.toml")).unwrap()).unwrap()
    }

    /// Issue 40: a 400 x 400 surface is 99 m of ink on A4 and plots solid
    /// black with a 0.3 mm pen; nothing warned.
    #[test]
    fn a_400_by_400_surface_warns_for_a_fine_pen() {
        let w = crowding_warnings(&surface(400, 1), |_| DEFAULT_PEN_WIDTH_MM);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].starts_with("pen 1: ") && w[0].contains("`every = "), "{}", w[0]);
        // The bundled 60 x 60 surface does not, nor the 400 x 400 one drawing
        // one line in 8 (50 x 50 lines, hidden by all 400 x 400 cells).
        assert!(crowding_warnings(&surface(60, 1), |_| DEFAULT_PEN_WIDTH_MM).is_empty());
        assert!(crowding_warnings(&surface(400, 8), |_| DEFAULT_PEN_WIDTH_MM).is_empty());
    }
}
