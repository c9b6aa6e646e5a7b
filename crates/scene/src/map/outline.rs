//! Map outlines: GeoJSON (Polygon, MultiPolygon, LineString, MultiLineString,
//! in Features, FeatureCollections and GeometryCollections) or Bramall's CSV
//! format (`x, y, pen_up` per row), read into polylines in map units.

use super::error::MapError;
use super::limits;
use super::projection::Projection;
use geojson::{GeoJson, Geometry, GeometryValue, Position};
use glam::DVec2;
use std::path::Path;

/// An outline: open or closed polylines in map units (already projected).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outline {
    /// Each polyline has at least two points; closed rings repeat the first.
    pub polylines: Vec<Vec<DVec2>>,
}

impl Outline {
    /// Reads `path`: GeoJSON when it ends in `.geojson` or `.json`, Bramall's
    /// CSV otherwise.
    ///
    /// # Errors
    /// The file cannot be read, is too large, is malformed (the error says
    /// where), or holds a coordinate the projection refuses.
    pub fn load(path: &Path, projection: Projection, files: &dyn crate::resolver::Resolver) -> Result<Outline, MapError> {
        let text = limits::read_text(path, files)?;
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if ext == "geojson" || ext == "json" {
            parse_geojson(&text, path, projection)
        } else {
            parse_csv(&text, path, projection)
        }
    }

    /// Number of points over all polylines.
    #[must_use]
    pub fn point_count(&self) -> usize {
        self.polylines.iter().map(Vec::len).sum()
    }
}

/// Parses GeoJSON text; `path` only names the file in errors.
///
/// # Errors
/// Syntax errors (with line and column), rings shorter than four positions or
/// not closed, line strings shorter than two, non-finite or unprojectable
/// coordinates (with the JSON path of the value).
pub fn parse_geojson(text: &str, path: &Path, projection: Projection) -> Result<Outline, MapError> {
    let gj: GeoJson = serde_json::from_str(text).map_err(|e| MapError::GeoJsonSyntax {
        path: path.to_owned(),
        line: e.line(),
        column: e.column(),
        // serde quotes unknown names whole: a short excerpt of its message.
        message: crate::excerpt::excerpt_of(&e.to_string(), 200),
    })?;
    let mut w = Walker { path, projection, out: Outline::default(), points: 0 };
    match &gj {
        GeoJson::Geometry(g) => w.geometry(g, "geometry".to_owned())?,
        GeoJson::Feature(f) => {
            if let Some(g) = &f.geometry {
                w.geometry(g, "geometry".to_owned())?;
            }
        }
        GeoJson::FeatureCollection(fc) => {
            for (i, f) in fc.features.iter().enumerate() {
                if let Some(g) = &f.geometry {
                    w.geometry(g, format!("features[{i}].geometry"))?;
                }
            }
        }
    }
    Ok(w.out)
}

struct Walker<'a> {
    path: &'a Path,
    projection: Projection,
    out: Outline,
    points: usize,
}

impl Walker<'_> {
    fn err(&self, at: String, message: impl Into<String>) -> MapError {
        MapError::GeoJsonGeometry { path: self.path.to_owned(), at, message: message.into() }
    }

    fn geometry(&mut self, g: &Geometry, at: String) -> Result<(), MapError> {
        let c = format!("{at}.coordinates");
        match &g.value {
            // Points carry no outline; places come from the symbols CSV.
            GeometryValue::Point { .. } | GeometryValue::MultiPoint { .. } => Ok(()),
            GeometryValue::LineString { coordinates } => self.line(coordinates, c, false),
            GeometryValue::MultiLineString { coordinates } => {
                for (i, l) in coordinates.iter().enumerate() {
                    self.line(l, format!("{c}[{i}]"), false)?;
                }
                Ok(())
            }
            GeometryValue::Polygon { coordinates } => self.polygon(coordinates, &c),
            GeometryValue::MultiPolygon { coordinates } => {
                for (i, p) in coordinates.iter().enumerate() {
                    self.polygon(p, &format!("{c}[{i}]"))?;
                }
                Ok(())
            }
            GeometryValue::GeometryCollection { geometries } => {
                for (i, g) in geometries.iter().enumerate() {
                    self.geometry(g, format!("{at}.geometries[{i}]"))?;
                }
                Ok(())
            }
        }
    }

    fn polygon(&mut self, rings: &[Vec<Position>], at: &str) -> Result<(), MapError> {
        if rings.is_empty() {
            return Err(self.err(at.to_owned(), "a Polygon needs at least one ring"));
        }
        for (i, r) in rings.iter().enumerate() {
            self.line(r, format!("{at}[{i}]"), true)?;
        }
        Ok(())
    }

    fn line(&mut self, pos: &[Position], at: String, ring: bool) -> Result<(), MapError> {
        let min = if ring { 4 } else { 2 };
        if pos.len() < min {
            let what = if ring { "a linear ring" } else { "a LineString" };
            return Err(self.err(at, format!("{what} needs at least {min} positions, found {}", pos.len())));
        }
        self.points += pos.len();
        if self.points > limits::MAX_OUTLINE_POINTS {
            return Err(MapError::Limit {
                path: self.path.to_owned(),
                message: format!("more than {} outline points", limits::MAX_OUTLINE_POINTS),
            });
        }
        let mut pts = Vec::with_capacity(pos.len());
        for (j, p) in pos.iter().enumerate() {
            let s = p.as_slice();
            // geojson accepts any array of numbers as a position; x and y are
            // needed, extra ones (altitude) are ignored.
            if s.len() < 2 {
                return Err(self.err(format!("{at}[{j}]"), format!("a position needs two numbers (x, y), found {}", s.len())));
            }
            let q = self.projection.project(DVec2::new(s[0], s[1])).map_err(|m| self.err(format!("{at}[{j}]"), m))?;
            pts.push(q);
        }
        if ring && pts.first() != pts.last() {
            return Err(self.err(at, "a linear ring must end where it starts (RFC 7946 3.1.6)"));
        }
        self.out.polylines.push(pts);
        Ok(())
    }
}

/// Parses Bramall's outline CSV: rows `x, y, pen_up`, where `pen_up` = 1
/// lifts the pen before moving to the point (starting a new line) and 0 joins
/// the point to the one before. An optional header row and `#` comments are
/// allowed. `path` only names the file in errors.
///
/// # Errors
/// A row with fewer than three fields, a field that is not a number, a flag
/// other than 0 or 1 (the error names the row and column), or a coordinate
/// the projection refuses.
pub fn parse_csv(text: &str, path: &Path, projection: Projection) -> Result<Outline, MapError> {
    let mut rd = crate::data_csv::reader(text, false);
    let mut out = Outline::default();
    let mut current: Vec<DVec2> = Vec::new();
    let mut first = true;
    let mut count = 0usize;
    for rec in rd.records() {
        let rec = rec.map_err(|e| csv_error(path, &e))?;
        let row = rec.position().map_or(0, csv::Position::line);
        if rec.iter().all(str::is_empty) {
            continue;
        }
        let err = |column: &str, message: String| MapError::Csv { path: path.to_owned(), row, column: Some(column.to_owned()), message };
        if first {
            first = false;
            // A header row: its first field is not a number.
            if rec.get(0).is_some_and(|f| f.parse::<f64>().is_err()) {
                continue;
            }
        }
        let mut nums = [0.0; 3];
        for (k, name) in ["x", "y", "pen_up"].iter().enumerate() {
            let f = rec.get(k).filter(|f| !f.is_empty()).ok_or_else(|| err(name, format!("missing `{name}` (rows are x, y, pen_up)")))?;
            nums[k] = f.parse().map_err(|_| err(name, format!("`{}` is not a number", crate::excerpt::excerpt(f))))?;
        }
        let pen_up = nums[2] == 1.0;
        if !pen_up && nums[2] != 0.0 {
            return Err(err("pen_up", format!("pen_up must be 0 or 1, found {}", nums[2])));
        }
        count += 1;
        if count > limits::MAX_OUTLINE_POINTS {
            return Err(MapError::Limit {
                path: path.to_owned(),
                message: format!("more than {} outline points", limits::MAX_OUTLINE_POINTS),
            });
        }
        let p = projection.project(DVec2::new(nums[0], nums[1])).map_err(|m| MapError::Projection {
            path: path.to_owned(),
            at: format!("row {row}"),
            message: m,
        })?;
        if pen_up {
            flush(&mut current, &mut out);
        }
        current.push(p);
    }
    flush(&mut current, &mut out);
    Ok(out)
}

/// Ends the current line; a lone point draws nothing.
fn flush(current: &mut Vec<DVec2>, out: &mut Outline) {
    if current.len() >= 2 {
        out.polylines.push(std::mem::take(current));
    } else {
        current.clear();
    }
}

pub(crate) fn csv_error(path: &Path, e: &csv::Error) -> MapError {
    let row = e.position().map_or(0, csv::Position::line);
    MapError::Csv { path: path.to_owned(), row, column: None, message: e.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gj(text: &str) -> Result<Outline, MapError> {
        parse_geojson(text, Path::new("t.geojson"), Projection::Planar)
    }

    #[test]
    fn polygon_multipolygon_and_lines() {
        let o = gj(r#"{"type":"FeatureCollection","features":[
            {"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[0,0],[1,0],[1,1],[0,0]],[[0.2,0.1],[0.3,0.1],[0.3,0.2],[0.2,0.1]]]}},
            {"type":"Feature","properties":{},"geometry":{"type":"MultiPolygon","coordinates":[[[[5,5],[6,5],[6,6],[5,5]]]]}},
            {"type":"Feature","properties":{},"geometry":{"type":"LineString","coordinates":[[0,0],[2,3,100]]}},
            {"type":"Feature","properties":{},"geometry":{"type":"MultiLineString","coordinates":[[[0,0],[1,1]],[[2,2],[3,3]]]}},
            {"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[9,9]}},
            {"type":"Feature","properties":{},"geometry":null}
        ]}"#)
        .unwrap();
        assert_eq!(o.polylines.len(), 6);
        assert_eq!(o.polylines[0].len(), 4);
        assert_eq!(o.polylines[3], vec![DVec2::ZERO, DVec2::new(2.0, 3.0)]);
        assert_eq!(o.point_count(), 4 + 4 + 4 + 2 + 2 + 2);
    }

    #[test]
    fn bare_geometry_and_collection() {
        let o = gj(r#"{"type":"GeometryCollection","geometries":[{"type":"LineString","coordinates":[[0,0],[1,0]]}]}"#).unwrap();
        assert_eq!(o.polylines.len(), 1);
    }

    #[test]
    fn geojson_errors_say_where() {
        let e = gj("{\"type\":\"Polygon\",\n \"coordinates\": [[[0,0],[1,0]").unwrap_err();
        assert!(matches!(e, MapError::GeoJsonSyntax { line: 2, .. }), "{e}");
        let e = gj(r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[0,0],[1,0],[0,0]]]}}]}"#)
            .unwrap_err();
        assert!(e.to_string().contains("features[0].geometry.coordinates[0]"), "{e}");
        assert!(e.to_string().contains("at least 4"), "{e}");
        let e = gj(r#"{"type":"Polygon","coordinates":[[[0,0],[1,0],[1,1],[0,1]]]}"#).unwrap_err();
        assert!(e.to_string().contains("end where it starts"), "{e}");
        let e = gj(r#"{"type":"LineString","coordinates":[[0,0]]}"#).unwrap_err();
        assert!(e.to_string().contains("geometry.coordinates"), "{e}");
        // Issue #20: a position of fewer than two numbers panicked.
        let e = gj(r#"{"type":"LineString","coordinates":[[0,0],[1]]}"#).unwrap_err();
        assert!(e.to_string().contains("geometry.coordinates[1]") && e.to_string().contains("two numbers"), "{e}");
        let e = gj(r#"{"type":"Polygon","coordinates":[[[0,0],[1,0],[],[0,0]]]}"#).unwrap_err();
        assert!(e.to_string().contains("geometry.coordinates[0][2]") && e.to_string().contains("found 0"), "{e}");
        let e = gj(r#"{"type":"Circle","coordinates":[0,0]}"#).unwrap_err();
        assert!(matches!(e, MapError::GeoJsonSyntax { .. }), "{e}");
        let e = parse_geojson(r#"{"type":"LineString","coordinates":[[0,0],[1,89.5]]}"#, Path::new("t.geojson"), Projection::Mercator)
            .unwrap_err();
        assert!(e.to_string().contains("geometry.coordinates[1]") && e.to_string().contains("latitude"), "{e}");
    }

    fn csv(text: &str) -> Result<Outline, MapError> {
        parse_csv(text, Path::new("o.csv"), Projection::Planar)
    }

    #[test]
    fn csv_pen_up_starts_new_lines() {
        let o = csv("x,y,pen_up\n0,0,1\n1,0,0\n1,1,0\n# comment\n5,5,1\n6,5,0\n9,9,1\n").unwrap();
        assert_eq!(o.polylines.len(), 2, "a lone pen-up point draws nothing");
        assert_eq!(o.polylines[0].len(), 3);
        // No header at all, and the first row need not be flagged.
        let o = csv("0,0,0\n1,0,0\n").unwrap();
        assert_eq!(o.polylines, vec![vec![DVec2::ZERO, DVec2::X]]);
        assert_eq!(csv("").unwrap().polylines.len(), 0);
    }

    #[test]
    fn csv_errors_name_row_and_column() {
        let e = csv("x,y,pen_up\n0,0,1\n1,,0\n").unwrap_err();
        assert!(matches!(&e, MapError::Csv { row: 3, column: Some(c), .. } if c == "y"), "{e}");
        let e = csv("0,0,1\n1,abc,0\n").unwrap_err();
        assert!(e.to_string().contains("row 2") && e.to_string().contains("`abc` is not a number"), "{e}");
        let e = csv("0,0,1\n1,1\n").unwrap_err();
        assert!(e.to_string().contains("row 2") && e.to_string().contains("pen_up"), "{e}");
        let e = csv("0,0,2\n").unwrap_err();
        assert!(e.to_string().contains("must be 0 or 1"), "{e}");
        let e = parse_csv("0,0,1\n0,95,0\n", Path::new("o.csv"), Projection::Equirectangular).unwrap_err();
        assert!(e.to_string().contains("row 2") && e.to_string().contains("latitude"), "{e}");
    }
}
