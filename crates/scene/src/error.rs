//! What can be wrong with a scene: a typed error naming the file, the line and
//! the field.

use hiddenline::camera::CameraError;
use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

/// A scene (or a mesh file it names) that cannot be used.
///
/// Displays as `FILE:LINE: FIELD: what is wrong`, each part present when known.
#[derive(Debug, Error)]
pub struct SceneError {
    /// The file at fault: the scene file, or a mesh file it names.
    pub file: PathBuf,
    /// 1-based line in `file`, when known.
    pub line: Option<usize>,
    /// The scene field at fault, e.g. `polygon[1].outer[2]`, when there is one.
    pub field: Option<String>,
    /// What is wrong.
    pub kind: SceneErrorKind,
}

/// The kinds of [`SceneError`].
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SceneErrorKind {
    /// The file could not be read.
    #[error("cannot read the file: {0}")]
    Io(#[source] std::io::Error),
    /// A file is larger than the explicit limit.
    #[error("file is {size} bytes, more than the limit of {limit}")]
    FileTooLarge {
        /// Its size.
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// The file is not served: the scene is read from files sent with a job
    /// and this one was not, or its path is absolute or leaves the scene's
    /// directory.
    #[error("{0}")]
    Refused(String),
    /// Malformed TOML, an unknown key, or a value of the wrong type.
    #[error("{0}")]
    Toml(String),
    /// A mesh file named by the scene cannot be opened or has no known format.
    #[error("mesh file {}: {reason}", crate::excerpt::shown_path(path))]
    MeshFile {
        /// The mesh file's path.
        path: PathBuf,
        /// Why it cannot be used.
        reason: String,
    },
    /// A mesh file that is not a valid OBJ.
    #[error("invalid OBJ file: {0}")]
    Obj(String),
    /// An OBJ face refers to a vertex that does not exist.
    #[error("face refers to vertex {index}, but the file has {count} vertices")]
    ObjIndexOutOfRange {
        /// The index as written (1-based, negative counts from the end).
        index: i64,
        /// Vertices defined before the face.
        count: usize,
    },
    /// A mesh file that is not a valid STL.
    #[error("invalid STL file: {0}")]
    Stl(String),
    /// A mesh path whose extension is neither `.obj` nor `.stl`.
    #[error("unknown mesh format (expected a .obj or .stl file)")]
    UnknownMeshFormat,
    /// A NaN or infinite number.
    #[error("{0} is not a finite number")]
    NotFinite(f64),
    /// A coordinate beyond [`crate::tolerance::MAX_COORDINATE`] (in world
    /// space, after transforms).
    #[error("{0:e} is beyond the limit of ±{max:e} for world coordinates (after transforms)", max = crate::tolerance::MAX_COORDINATE)]
    TooFar(f64),
    /// An inline polygon that is not planar.
    #[error("polygon is not planar: a vertex lies {deviation:.3e} from its plane (tolerance {tolerance:.3e})")]
    NonPlanar {
        /// Largest distance of a vertex from the polygon's plane.
        deviation: f64,
        /// The allowed distance.
        tolerance: f64,
    },
    /// Too few points for the object.
    #[error("needs at least {need} points, has {got}")]
    TooFewPoints {
        /// The minimum.
        need: usize,
        /// What was given.
        got: usize,
    },
    /// Too many of something.
    #[error("{what}: {count} is more than the limit of {limit}")]
    TooMany {
        /// What was counted.
        what: &'static str,
        /// How many.
        count: usize,
        /// The limit.
        limit: usize,
    },
    /// The camera cannot be built.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// Neither or both of `fov_deg` and `ortho_height`.
    #[error("give exactly one of camera.fov_deg (perspective) and camera.ortho_height (orthographic)")]
    Projection,
    /// A value outside its allowed range.
    #[error("{0}")]
    OutOfRange(String),
    /// A map table (`[[map]]`, `[[symbols]]`, `[[labels]]`, `[animation]`)
    /// or a data file it names cannot be used; the error names the file and
    /// the row, column or position.
    #[error(transparent)]
    Map(#[from] crate::map::MapError),
    /// No objects at all, or nothing left after skipping degenerate faces.
    #[error("the scene is empty: it has no objects to draw")]
    Empty,
}

impl SceneError {
    /// An error in `file` with no line or field yet.
    pub fn new(file: impl Into<PathBuf>, kind: SceneErrorKind) -> Self {
        SceneError { file: file.into(), line: None, field: None, kind }
    }

    /// The same error at `line`.
    #[must_use]
    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }

    /// The same error naming `field`.
    #[must_use]
    pub fn in_field(mut self, field: impl Into<String>) -> Self {
        self.field = Some(field.into());
        self
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", crate::excerpt::shown_path(&self.file))?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(field) = &self.field {
            write!(f, ": {field}")?;
        }
        write!(f, ": {}", self.kind)
    }
}

/// 1-based line number of byte `offset` in `text`.
#[must_use]
pub fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_file_line_and_field() {
        let e = SceneError::new("a.toml", SceneErrorKind::NotFinite(f64::NAN)).at_line(3).in_field("polygon[0].outer[1]");
        assert_eq!(e.to_string(), "a.toml:3: polygon[0].outer[1]: NaN is not a finite number");
        let e = SceneError::new("b.toml", SceneErrorKind::Empty);
        assert_eq!(e.to_string(), "b.toml: the scene is empty: it has no objects to draw");
    }

    #[test]
    fn lines_count_from_one() {
        assert_eq!(line_of("a\nb\nc", 0), 1);
        assert_eq!(line_of("a\nb\nc", 2), 2);
        assert_eq!(line_of("a\nb\nc", 99), 3);
        assert_eq!(line_of("", 0), 1);
    }
}
