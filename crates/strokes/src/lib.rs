//! 2-D drawings to ordered pen strokes, and how long they take to plot.
//!
//! This crate is the middle of plotd's pipeline: it takes the visible lines
//! of a scene (or any 2-D drawing: an SVG, an HP-GL file read back) as a
//! [`Drawing`] in page millimetres and hands back the same lines as few, long,
//! well-ordered pen strokes. It knows nothing of scenes, cameras, hidden lines
//! or device languages, and does no I/O.
//!
//! The main types:
//! - [`Drawing`], [`Layer`], [`Polyline`], [`LineKind`]: the 2-D drawing, the
//!   currency between the hidden-line side and `plotcode`.
//! - [`optimize`] and [`StrokeOptions`]: chaining and ordering, per layer.
//! - [`MotionModel`] and [`PlotStats`]: how long a drawing takes to plot.
//! - [`Dash`]: how hidden lines are dashed on paper.
//! - [`font`]: single-stroke lettering in the Hershey fonts, as 2-D lines.
//! - [`occult`]: 2-D occlusion, lines hidden under later filled shapes.
//! - [`crowding`]: how much of a drawing's ink lies closer than a pen's
//!   width to a parallel line (a drawing too dense for its pen).
//!
//! # Chaining and ordering
//!
//! After hidden-line removal a drawing is thousands to millions of short
//! segments, and plot time is dominated by pen lifts and pen-up travel. This
//! crate turns any set of 2-D polylines into few, long, well-ordered strokes:
//!
//! 1. [`simplify()`]: drop every vertex that lies within
//!    [`SIMPLIFY_TOLERANCE_MM`] (a micrometre, the resolution of the output)
//!    of the straight segment that replaces it: most of a fine surface's
//!    grid crossings, which every later stage would otherwise pay for.
//! 2. [`dedupe()`]: remove every part of a segment that lies within
//!    [`StrokeOptions::tolerance_mm`] of a nearly parallel segment kept
//!    before it (longest first), so no place is drawn twice: the horizon of a
//!    surface seen edge-on, T-junctions, duplicate faces, 2-D inputs that
//!    overlap themselves. Stacks of segments on one line (a shape drawn
//!    10,000 times over) are cut in one sort first, so they cost no pairs.
//!    A fold's tip (a line turning back into itself, up to
//!    [`dedupe::FOLD_TIP_MM`]) stays: cutting it would cost a pen lift.
//!    Then [`rejoin`] draws again the removed overlaps that join two loose
//!    ends (within [`rejoin::REJOIN_MAX_MM`] a joint and
//!    [`rejoin::REJOIN_SHARE`] of the layer): one stroke fewer each.
//! 3. [`chain`]: snap the polylines' end points that lie within
//!    [`StrokeOptions::tolerance_mm`] of each other onto one vertex, build the
//!    graph whose edges are the polylines, drop duplicate and zero-length
//!    straight segments, and decompose every connected piece into the
//!    minimum number of pen-down strokes (an Euler-path decomposition: one
//!    stroke per pair of odd-degree vertices, one closed stroke for a
//!    component whose vertices all have even degree). A polyline is joined at
//!    its ends only, never split inside. Where pieces join, vertices are
//!    simplified again.
//! 4. [`order`]: choose the order, the direction and, for closed strokes, the
//!    start point: greedy nearest neighbour from the home position (searched
//!    in a uniform grid of cells, or a kiddo k-d tree when the points crowd
//!    into few cells), then 2-opt and Or-opt moves (with stroke reversal) on
//!    nearest-neighbour candidate lists until no move helps, then kicks
//!    (short runs of the tour swapped, kept only when a descent from there
//!    ends shorter) until the work budget ([`StrokeOptions::improve_budget`])
//!    is spent.
//!
//! [`optimize`] does them all, per layer (a plotter draws one pen at a time).
//!
//! **Nothing drawn changes but what was drawn twice**: only how the lines are
//! grouped into strokes, directed and ordered, overlaps drawn once, and
//! vertices dropped where the line goes straight on within a micrometre.
//! Vertices move by at most the snapping tolerance, every removed point lies
//! within the tolerance of a kept line, and a stroke shorter than the
//! tolerance survives as a dot.
//!
//! **Results are deterministic**: the budget counts work, not wall-clock time
//! (this crate reads no clocks), so the same input always gives the same output.
//!
//! ```
//! use strokes::{DVec2, Drawing, LineKind, Polyline};
//! let mut d = Drawing::new(100.0, 100.0);
//! let l = d.layer_mut(1, LineKind::Visible);
//! // Two segments that share an endpoint become one stroke.
//! l.polylines.push(Polyline::new(vec![DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0)]));
//! l.polylines.push(Polyline::new(vec![DVec2::new(10.0, 10.0), DVec2::new(10.0, 0.0)]));
//! let out = strokes::optimize(d, &strokes::StrokeOptions::default());
//! assert_eq!(out.stroke_count(), 1);
//! ```

#![deny(missing_docs)]

pub mod dash;
pub mod dedupe;
pub mod density;
pub mod drawing;
pub mod font;
pub mod occult;
pub mod plot_time;
pub mod rejoin;
pub mod simplify;

mod cells;
mod chain;
mod euler;
mod graph;
mod improve;
mod nearest;
mod order;
mod snap;
mod spatial;
mod stacks;

pub use chain::chain;
pub use dedupe::Deduped;

/// [`dedupe::dedupe`] after the stacks step has cut the stacks of segments on one
/// line, so that no pair is formed per two copies of a line drawn many times
/// over, then [`rejoin`]: the removed pieces that join loose ends drawn
/// again (drawn on from a kept polyline ending at one of the loose ends, no
/// longer in `removed` nor counted in `removed_mm`). What [`optimize`] runs.
#[must_use]
pub fn dedupe(polylines: Vec<Polyline>, tol: f64) -> Deduped {
    let (polylines, stacked_mm) = stacks::collapsed(polylines, if tol > 0.0 { tol } else { 0.0 });
    let mut once = dedupe::dedupe(polylines, tol);
    once.removed_mm += stacked_mm;
    let chosen = rejoin::rejoin(&mut once.polylines, &once.removed, tol);
    once.removed_mm -= chosen.iter().map(|&i| once.removed[i].0.distance(once.removed[i].1)).sum::<f64>();
    let mut drop = chosen.into_iter().peekable();
    let mut i = 0;
    once.removed.retain(|_| {
        let gone = drop.next_if_eq(&i).is_some();
        i += 1;
        !gone
    });
    once
}
pub use order::{order, order_nearest_neighbour};

pub use dash::Dash;
pub use density::{crowding, PenCrowding};
pub use drawing::{Drawing, Layer, LineKind, Polyline};
pub use glam::DVec2;
pub use plot_time::{MotionModel, PlotStats};
pub use simplify::{simplify, simplify_polylines, SIMPLIFY_TOLERANCE_MM};

/// Default snapping tolerance in page millimetres: endpoints closer than this
/// are one vertex. Far below any pen width (0.3 mm is a fine pen), far above
/// the floating-point noise of the hidden-line engine's output.
pub const DEFAULT_TOLERANCE_MM: f64 = 0.01;

/// Smallest travel saving (mm) that counts as an improvement; below this,
/// floating-point noise could make the improver cycle.
pub const MIN_GAIN_MM: f64 = 1e-9;

/// Default work budget of the improvement phase, per stroke; see
/// [`StrokeOptions::improve_budget`]. Enough for the improver to run out of
/// moves on typical drawings of up to some 10^5 strokes; the rest goes to
/// kicks (on 20,000 random segments, some 2 % less travel than the local
/// optimum, for about 0.3 s of CPU).
pub const DEFAULT_BUDGET_PER_STROKE: u64 = 400;

/// Cap on the default work budget, so that a drawing of millions of strokes
/// is ordered in seconds (each unit costs tens of nanoseconds).
pub const DEFAULT_BUDGET_CAP: u64 = 10_000_000;

/// How [`optimize`], [`chain`] and [`order`] work.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeOptions {
    /// Endpoints closer than this (page mm) are joined.
    pub tolerance_mm: f64,
    /// Drop the vertices where a line goes straight on, within
    /// [`SIMPLIFY_TOLERANCE_MM`] ([`simplify()`]): before [`dedupe()`], and
    /// where [`chain`] joins pieces.
    pub simplify: bool,
    /// Where the pen starts and ends each layer (page mm).
    pub home: DVec2,
    /// Run 2-opt / Or-opt after the nearest-neighbour tour.
    pub improve: bool,
    /// Work budget of the improvement phase: move evaluations plus strokes
    /// moved in the tour; all of it is spent (what the local moves leave goes
    /// to kicks). `None` means [`DEFAULT_BUDGET_PER_STROKE`] times the
    /// number of strokes, at most [`DEFAULT_BUDGET_CAP`]. Work, not time, so
    /// results never depend on the machine's speed.
    pub improve_budget: Option<u64>,
}

impl Default for StrokeOptions {
    fn default() -> Self {
        StrokeOptions { tolerance_mm: DEFAULT_TOLERANCE_MM, simplify: true, home: DVec2::ZERO, improve: true, improve_budget: None }
    }
}

/// Removes overlaps from, chains and orders every layer of `drawing`; layers
/// keep their order, pens and kinds. Each layer's tour starts and ends at
/// [`StrokeOptions::home`].
///
/// The stages, for whoever changes them: [`simplify()`] each polyline (when
/// [`StrokeOptions::simplify`]), then [`dedupe()`] (its output draws
/// each place once, a subset of the input's segments cut where overlaps
/// start and end, pieces meeting exactly at their cut points), then
/// [`chain`], then [`order`].
///
/// Takes the drawing by value: [`dedupe()`] moves the polylines it leaves
/// whole into its output instead of copying them, so a large drawing is
/// never held twice (issue #19's memory target).
#[must_use]
pub fn optimize(drawing: Drawing, options: &StrokeOptions) -> Drawing {
    optimize_beside(drawing, options, |_| ()).0
}

/// [`optimize`], and `beside` run on the drawing's final lines: chained,
/// not yet ordered (the same segments as the result's, grouped and ordered
/// otherwise). It runs on the other core while the strokes are ordered,
/// whose improver takes one: what `plotd render` measures the pens'
/// crowding with ([`crowding`]).
pub fn optimize_beside<R: Send>(drawing: Drawing, options: &StrokeOptions, beside: impl FnOnce(&Drawing) -> R + Send) -> (Drawing, R) {
    let Drawing { width_mm, height_mm, layers, hidden_dash } = drawing;
    let mut spent = Vec::with_capacity(layers.len());
    let layers = layers
        .into_iter()
        .map(|layer| {
            let mut polylines = layer.polylines;
            if options.simplify {
                simplify_polylines(&mut polylines);
            }
            let once = dedupe(polylines, options.tolerance_mm);
            let polylines = order::drawable_in_page_order(chain(&once.polylines, options));
            spent.push(once);
            Layer { polylines, ..layer }
        })
        .collect();
    let chained = Drawing { width_mm, height_mm, layers, hidden_dash };
    // The strokes hold copies of the pieces: those are freed (a free per
    // piece, 20 ms for a 2000 x 2000 surface's 263,000) on the other core
    // too, while the one-threaded improver runs.
    let (plans, beside) = rayon::join(
        || chained.layers.iter().map(|l| order::plan(&l.polylines, options)).collect::<Vec<_>>(),
        || {
            drop(spent);
            beside(&chained)
        },
    );
    let Drawing { width_mm, height_mm, layers, hidden_dash } = chained;
    let layers = layers
        .into_iter()
        .zip(plans)
        .map(|(layer, plan)| Layer { polylines: order::applied(&plan, layer.polylines, options), ..layer })
        .collect();
    (Drawing { width_mm, height_mm, layers, hidden_dash }, beside)
}

/// Pen-up travel (mm) of `strokes` in their given order from `home` and back.
#[must_use]
pub fn travel(strokes: &[crate::Polyline], home: DVec2) -> f64 {
    let mut at = home;
    let mut total = 0.0;
    for p in strokes {
        let (Some(s), Some(e)) = (p.start(), p.end()) else { continue };
        total += at.distance(s);
        at = e;
    }
    total + at.distance(home)
}

#[cfg(test)]
mod tests;
