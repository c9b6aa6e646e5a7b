//! Why a map scene cannot be loaded: every error names the file and where in
//! it (row, column, byte offset or JSON path) the trouble is.

use std::path::PathBuf;
use thiserror::Error;

/// An error while loading or lowering `[[map]]`, `[[symbols]]`, `[[labels]]`
/// or `[animation]`.
#[derive(Debug, Error)]
pub enum MapError {
    /// A file could not be read.
    #[error("{}: cannot read: {source}", crate::excerpt::shown_path(path))]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A CSV file is malformed: a missing field, a value that is not a number.
    #[error("{}: row {row}{}: {message}", crate::excerpt::shown_path(path), column.as_ref().map(|c| format!(", column `{c}`")).unwrap_or_default())]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line number in the file.
        row: u64,
        /// Column name (or number) at fault, when one is.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A GeoJSON file is not JSON, or not GeoJSON.
    #[error("{}: line {line}, column {column}: invalid GeoJSON: {message}", crate::excerpt::shown_path(path))]
    GeoJsonSyntax {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A GeoJSON geometry parses but cannot be used (a ring too short, an
    /// unsupported geometry type, a non-finite coordinate).
    #[error("{}: at {at}: {message}", crate::excerpt::shown_path(path))]
    GeoJsonGeometry {
        /// The file.
        path: PathBuf,
        /// JSON path of the offending value, e.g. `features[3].geometry.coordinates[0][2]`.
        at: String,
        /// What is wrong.
        message: String,
    },
    /// A coordinate cannot be projected (latitude out of range for Mercator,
    /// or not finite).
    #[error("{}: {at}: {message}", crate::excerpt::shown_path(path))]
    Projection {
        /// The file holding the coordinate.
        path: PathBuf,
        /// Where in the file (row or JSON path).
        at: String,
        /// What is wrong.
        message: String,
    },
    /// A symbol OBJ is unusable (empty, open, or not convex).
    #[error("{}: symbol shape: {message}", crate::excerpt::shown_path(path))]
    Shape {
        /// The OBJ file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A scene-file key has a value that cannot be used.
    #[error("{table}: `{key}`: {message}")]
    Spec {
        /// The table, e.g. `symbols[1]` or `animation`.
        table: String,
        /// The key.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A file the resolver does not serve (the daemon reads only the files
    /// sent with a job).
    #[error("{}{}: {message}", key.as_ref().map(|k| format!("{k}: ")).unwrap_or_default(), crate::excerpt::shown_path(path))]
    Refused {
        /// The scene key naming the file, e.g. `map[0].outline`, when known.
        key: Option<String>,
        /// The path as the scene names it.
        path: PathBuf,
        /// Why it is not served.
        message: String,
    },
    /// A file exceeds one of the explicit limits in [`crate::map::limits`].
    #[error("{}: {message}", crate::excerpt::shown_path(path))]
    Limit {
        /// The file.
        path: PathBuf,
        /// Which limit, and the value found.
        message: String,
    },
}

impl MapError {
    /// Names the scene key (`table.key`) in a [`MapError::Refused`].
    pub(crate) fn keyed(self, table: &str, key: &str) -> MapError {
        match self {
            MapError::Refused { path, message, .. } => MapError::Refused { key: Some(format!("{table}.{key}")), path, message },
            other => other,
        }
    }
    pub(crate) fn spec(table: impl Into<String>, key: &'static str, message: impl Into<String>) -> MapError {
        MapError::Spec { table: table.into(), key, message: message.into() }
    }
}
