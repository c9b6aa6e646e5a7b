//! The explicit limits and tolerances of map scenes, in one place.
//!
//! Limits keep a hostile or mistaken input from eating the machine: each is
//! far above any real map and is reported as an error naming the file.

use super::error::MapError;
use crate::resolver::{ReadError, Resolver};
use std::path::Path;

/// Largest data file (outline, places, symbol OBJ) read, in bytes.
pub const MAX_FILE_BYTES: u64 = 256 * 1024 * 1024;
/// Most outline points in one `[[map]]`.
pub const MAX_OUTLINE_POINTS: usize = 10_000_000;
/// Most places (rows) in one `[[symbols]]` file.
pub const MAX_PLACES: usize = 200_000;
/// Most frames in one `[animation]`.
pub const MAX_FRAMES: usize = 1_000_000;
/// Sides of a `cylinder` symbol: at least a triangle, at most what a pen can
/// still show as facets.
pub const CYLINDER_SEGMENTS: std::ops::RangeInclusive<u32> = 3..=256;
/// Most vertices of a symbol OBJ (each placed once per place per frame).
pub const MAX_SHAPE_VERTICES: usize = 10_000;

/// Relative tolerance, as a fraction of a symbol OBJ's diameter, within which
/// a vertex counts as lying on a face plane. OBJ files carry 6-7 significant
/// digits, so anything tighter would call round-off "not convex".
pub const SHAPE_PLANE_TOL: f64 = 1e-6;
/// Two faces of a symbol whose unit normals' dot product exceeds `1 -` this
/// are coplanar: the edge between them (a triangulation diagonal) is not drawn.
pub const COPLANAR_DOT_TOL: f64 = 1e-9;
/// A symbol whose height is below this fraction of its footprint width is
/// flat: only its footprint is drawn, because a solid that thin has faces the
/// engine cannot tell apart in depth.
pub const FLAT_HEIGHT_FRACTION: f64 = 1e-9;

/// Reads a whole UTF-8 data file through `files`, refusing files over
/// [`MAX_FILE_BYTES`].
///
/// # Errors
/// The file cannot be opened or read, is not served, is too large, or is not UTF-8.
pub fn read_text(path: &Path, files: &dyn Resolver) -> Result<String, MapError> {
    let io = |source| MapError::Io { path: path.to_owned(), source };
    let bytes = files.read(path, MAX_FILE_BYTES).map_err(|e| match e {
        ReadError::Io(e) => io(e),
        ReadError::TooLarge { size, limit } => {
            MapError::Limit { path: path.to_owned(), message: format!("file is {size} bytes, more than the limit of {limit}") }
        }
        ReadError::Refused(message) => MapError::Refused { key: None, path: path.to_owned(), message },
    })?;
    String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to())))
    })
}
