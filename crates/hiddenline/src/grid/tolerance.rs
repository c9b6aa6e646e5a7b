//! Every tolerance of the grid engine, in one place.
//!
//! The engine's predicates are floating-point, not exact; each one below says
//! what it decides and why its size is safe. All are relative, so the engine
//! behaves the same whatever the scale of the scene.

/// Two radial positions on the same ray (see [`super::horizon`]) closer than
/// this, relative to their size, count as equal: a line lying exactly on the
/// horizon is drawn (touching is not hiding). Small enough to stay far below a
/// pen width on any page, large enough to absorb the round-off of intersecting
/// two lines that were computed from the same projected vertices.
pub const RADIAL_EQ: f64 = 1e-9;

/// A segment whose direction deviates from the ray through it by less than
/// this (sine of the angle) is treated as radial: its key range has no width
/// and it is tested on a single ray. Eye exactly above a grid line produces such
/// edges; the generic key-interval code would divide by nearly zero on them.
pub const RADIAL_SIN: f64 = 1e-10;

/// A pole (the vanishing point of verticals) farther than this from the
/// picture centre, in device units (the picture spans about [-1, 1]), is
/// treated as being at infinity: rays become parallel. The angular error this
/// makes across the picture is below 1e-6, far under a pen width, and it keeps
/// the keys of nearly horizontal perspective views well conditioned.
pub const FAR_POLE: f64 = 1e6;

/// An orthographic view whose vertical direction projects shorter than this
/// (device units per world unit) looks straight down or up: no facet can hide
/// another, and the pole is undefined.
pub const STRAIGHT_DOWN: f64 = 1e-12;

/// A polygon counts as containing the pole when the pole is inside it or
/// within this distance (relative to the polygon's size) of its boundary.
pub const POLE_CONTAINS: f64 = 1e-12;

/// Consecutive visible pieces whose end and start are closer than this
/// (device units, relative to the picture size of about 1) are joined into one
/// polyline.
pub const JOIN: f64 = 1e-9;

/// A visible gap shorter than this (as a fraction of the grid edge) between
/// two hidden intervals is round-off, not a visible piece: the two intervals
/// end and start on the same ray, computed from two horizon pieces. Far below
/// anything a pen can draw, far above the round-off of those computations.
pub const SLIVER: f64 = 1e-12;

/// A convex cell whose doubled signed screen area exceeds this, relative to
/// the square of its size, has a clear orientation: its far chain is the one
/// running counter-clockwise from its smallest key. Thinner cells (seen
/// edge-on) decide by comparing radii on a ray instead. Far above the
/// round-off of the area of four projected points.
pub const ORIENTED: f64 = 1e-9;

/// A bound on the round-off of a key (see [`super::horizon`]): absolute for
/// the pseudo-angles of a finite pole (they lie in `[-2, 2]`), relative to
/// the size of the coordinates for the keys of parallel rays. Only used to
/// keep a quick test on the safe side of the exact one it stands in for.
pub const KEY_ROUNDOFF: f64 = 1e-14;
