//! Every tolerance the hidden-line engine and its reference checker use, in one
//! place, with the reason for its value.
//!
//! Which predicates are exact and which use a tolerance:
//! - Event positions along a line (crossings with projected face boundaries,
//!   piercings of face planes) are computed, not tested: no tolerance.
//! - "Is this point on that plane?" uses [`PLANE_REL`] times the scene size
//!   (world units). A point within it is *in* the plane and is never hidden by
//!   that face: this is the coplanar rule (see [`crate::engine`]).
//! - "Is this screen point inside that face?" is even-odd with holes, and a
//!   point within [`SCREEN_EPS`] of the face's projected boundary counts as
//!   inside (faces are closed sets), so lines running exactly behind a shared
//!   edge of two faces do not leak through the crack between them.
//! - Faces whose projection has (almost) no area are seen edge-on and hide
//!   nothing ([`EDGE_ON_REL`]).

/// Points closer than this times the scene size (the diagonal of the bounding
/// box of the model and the eye) to a face's plane lie *in* the plane. f64
/// carries ~16 digits; after a transform or two of mesh data about 12 remain,
/// and coplanar faces from CAD or triangulated quads agree to ~1e-12 relative.
/// 1e-9 leaves three orders of magnitude either side.
pub const PLANE_REL: f64 = 1e-9;

/// Device-space distance (the picture is 2 units tall) under which a point
/// counts as on a projected face boundary, two events along a line merge, and
/// visible pieces are dropped as slivers. 1e-9 of the picture height is far
/// below a plotter step (about 1e-5 of an A4 page) and far above the rounding
/// noise of projecting coordinates of magnitude up to 1e4 (near-plane points).
pub const SCREEN_EPS: f64 = 1e-9;

/// A face whose projected area is below this times the square of its projected
/// perimeter is seen edge-on (a needle on screen) and hides nothing: a sight
/// ray that lies in a plane meets no face in it. Relative, so the test does not
/// depend on the face's size or distance.
pub const EDGE_ON_REL: f64 = 1e-12;

/// Sample spacing of the brute-force reference, as a fraction of the drawing's
/// diagonal: a quarter of [`COMPARE_TOL`], so a sample grid never misses a
/// feature the comparison tolerance would see.
pub const REFERENCE_SPACING: f64 = 2.5e-4;

/// Distance, as a fraction of the drawing's diagonal, within which a drawn
/// point counts as matching a reference point (issue 2: 0.1 %).
pub const COMPARE_TOL: f64 = 1e-3;

/// Hard cap on reference samples per line, so a line that runs off towards
/// the near plane (device length in the thousands) cannot exhaust memory.
pub const REFERENCE_MAX_SAMPLES_PER_LINE: usize = 200_000;
