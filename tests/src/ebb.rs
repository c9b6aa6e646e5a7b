//! What an EiBotBoard drew, against what its program draws: plotsim's EBB
//! records millimetres from home with y up, and may report a straight run of
//! blocks as one line, so strokes are compared point by point within a motor
//! step rather than exactly.

/// One step of an AxiDraw at 1/16 microstepping, mm.
pub const STEP_MM: f64 = 0.0125;

/// The strokes `text` (an AxiDraw program) draws, in the record's
/// millimetres (device steps from home, y towards the operator, turned y up).
#[must_use]
pub fn planned_strokes(text: &str) -> Vec<Vec<[f64; 2]>> {
    crate::strokes_of(text, "axidraw")
        .into_iter()
        .map(|(_, points)| points.iter().map(|p| [p[0] * STEP_MM, -p[1] * STEP_MM]).collect())
        .collect()
}

/// The strokes the simulator recorded.
#[must_use]
pub fn drawn_strokes(sim: &plotsim::Simulator) -> Vec<Vec<[f64; 2]>> {
    sim.record().strokes.into_iter().map(|s| s.points).collect()
}

fn distance(p: &[f64; 2], q: &[f64; 2]) -> f64 {
    (p[0] - q[0]).hypot(p[1] - q[1])
}

/// Whether `p` is within a step of one of `points`.
#[must_use]
pub fn near(p: &[f64; 2], points: &[[f64; 2]]) -> bool {
    points.iter().any(|q| distance(p, q) <= STEP_MM)
}

/// Whether a drawn stroke is a planned one within `mm`: each point of
/// either within `mm` of a point of the other.
#[must_use]
pub fn same_stroke_within(drawn: &[[f64; 2]], planned: &[[f64; 2]], mm: f64) -> bool {
    let near = |p: &[f64; 2], points: &[[f64; 2]]| points.iter().any(|q| distance(p, q) <= mm);
    planned.iter().all(|p| near(p, drawn)) && drawn.iter().all(|p| near(p, planned))
}

/// Whether `p` is within a step of the polyline through `points`.
fn on(p: &[f64; 2], points: &[[f64; 2]]) -> bool {
    let to_segment = |a: &[f64; 2], b: &[f64; 2]| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 == 0.0 { 0.0 } else { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) };
        distance(p, &[a[0] + t * dx, a[1] + t * dy])
    };
    near(p, points) || points.windows(2).any(|w| to_segment(&w[0], &w[1]) <= STEP_MM)
}

/// Whether a drawn stroke is a planned one: each point of either within a
/// step of a point of the other.
#[must_use]
pub fn same_stroke(drawn: &[[f64; 2]], planned: &[[f64; 2]]) -> bool {
    same_stroke_within(drawn, planned, STEP_MM)
}

/// Whether a drawn stroke is the start of a planned one, perhaps all of it:
/// it starts where the planned one does and stays on its line.
#[must_use]
pub fn start_of(drawn: &[[f64; 2]], planned: &[[f64; 2]]) -> bool {
    !drawn.is_empty() && !planned.is_empty() && distance(&drawn[0], &planned[0]) <= STEP_MM && drawn.iter().all(|p| on(p, planned))
}

/// Checks that `drawn` is `planned` drawn once, in order, except for at most
/// `max_repeats` strokes drawn again at interruptions: a repeat is the whole
/// or the start of the planned stroke it precedes or of the one just drawn.
/// Returns the number of repeats.
///
/// # Panics
/// With the first difference.
pub fn assert_drawn_once(drawn: &[Vec<[f64; 2]>], planned: &[Vec<[f64; 2]>], max_repeats: usize) -> usize {
    let (mut i, mut repeats) = (0, 0);
    for (j, d) in drawn.iter().enumerate() {
        if planned.get(i).is_some_and(|w| same_stroke(d, w)) {
            i += 1;
        } else if planned.get(i).is_some_and(|w| start_of(d, w)) || i.checked_sub(1).is_some_and(|k| start_of(d, &planned[k])) {
            repeats += 1;
        } else {
            panic!("stroke {j} drawn ({d:?}) is not planned stroke {i} ({:?})", planned.get(i));
        }
    }
    assert_eq!(i, planned.len(), "only {i} of {} strokes drawn", planned.len());
    assert!(repeats <= max_repeats, "{repeats} strokes repeated, at most {max_repeats} allowed");
    repeats
}

/// A scene of `n` short zig-zag strokes apart from each other, seen from
/// above: a job long enough to interrupt, whose strokes are told apart by
/// where they are.
#[must_use]
pub fn zigzags(n: usize) -> String {
    let mut t = String::from("[camera]\neye = [0.0, 0.0, 10.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\northo_height = 12.0\n");
    for k in 0..n {
        let (x, y) = ((k % 6) as f64 * 2.5 - 7.0, (k / 6) as f64 * 2.0 - 5.0);
        t += &format!(
            "[[polyline]]\npoints = [[{x}, {y}, 0], [{}, {}, 0], [{}, {y}, 0], [{}, {}, 0]]\n",
            x + 0.6,
            y + 1.2,
            x + 1.2,
            x + 1.8,
            y + 1.2
        );
    }
    t
}
