//! The places of a `[[symbols]]` table: a CSV with a header naming `name`,
//! the coordinates (`x`, `y` in map units, or `lon`, `lat` in degrees) and one
//! or more value columns. Columns may come in any order; extra ones are kept
//! out of the way until an `[animation]` asks for them.

use super::error::MapError;
use super::limits;
use super::outline::csv_error;
use glam::DVec2;
use std::path::{Path, PathBuf};

/// How a places file gives its coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coords {
    /// `x`, `y`: map units, not projected.
    Planar,
    /// `lon`, `lat`: degrees, projected like the map.
    LonLat,
}

/// One row of a places file.
#[derive(Clone, Debug, PartialEq)]
pub struct Place {
    /// The `name` field (used by labels).
    pub name: String,
    /// Coordinates as written in the file.
    pub at: DVec2,
    /// 1-based line of the row in the file, for error messages.
    pub row: u64,
    /// One value per requested column, in the order asked for.
    pub values: Vec<f64>,
}

/// A loaded places file.
#[derive(Clone, Debug, PartialEq)]
pub struct Places {
    /// The file, for error messages.
    pub path: PathBuf,
    /// Whether coordinates are planar or lon/lat.
    pub coords: Coords,
    /// The value columns read, in order.
    pub columns: Vec<String>,
    /// The rows.
    pub places: Vec<Place>,
}

impl Places {
    /// Reads `path`, keeping the value columns named in `columns`.
    ///
    /// # Errors
    /// As [`Places::parse`], or the file cannot be read.
    pub fn load(path: &Path, columns: &[String], files: &dyn crate::resolver::Resolver) -> Result<Places, MapError> {
        let text = limits::read_text(path, files)?;
        Places::parse(&text, path, columns)
    }

    /// Parses CSV text; `path` only names the file in errors.
    ///
    /// # Errors
    /// A header without `name` and `x`,`y` or `lon`,`lat`, or without a
    /// requested value column; a row with a missing field, a field that is not
    /// a number, or a negative value (symbol heights cannot be negative). The
    /// error names the row and the column.
    pub fn parse(text: &str, path: &Path, columns: &[String]) -> Result<Places, MapError> {
        let mut rd = crate::data_csv::reader(text, true);
        let header = rd.headers().map_err(|e| csv_error(path, &e))?.clone();
        let find = |name: &str| header.iter().position(|h| h.eq_ignore_ascii_case(name));
        let head_err = |message: String| MapError::Csv { path: path.to_owned(), row: 1, column: None, message };
        let name_col = find("name").ok_or_else(|| head_err("the header has no `name` column".into()))?;
        let (coords, cx, cy, nx, ny) = match (find("x"), find("y"), find("lon"), find("lat")) {
            (Some(x), Some(y), _, _) => (Coords::Planar, x, y, "x", "y"),
            (_, _, Some(x), Some(y)) => (Coords::LonLat, x, y, "lon", "lat"),
            _ => return Err(head_err("the header needs `x` and `y`, or `lon` and `lat`".into())),
        };
        let mut vcols = Vec::with_capacity(columns.len());
        for c in columns {
            vcols.push(find(c).ok_or_else(|| head_err(format!("the header has no value column `{}`", crate::excerpt::excerpt(c))))?);
        }
        let mut places = Vec::new();
        for rec in rd.records() {
            let rec = rec.map_err(|e| csv_error(path, &e))?;
            if rec.iter().all(str::is_empty) {
                continue;
            }
            let row = rec.position().map_or(0, csv::Position::line);
            if places.len() >= limits::MAX_PLACES {
                return Err(MapError::Limit { path: path.to_owned(), message: format!("more than {} places", limits::MAX_PLACES) });
            }
            let field = |i: usize, col: &str| -> Result<&str, MapError> {
                rec.get(i).filter(|f| !f.is_empty()).ok_or_else(|| MapError::Csv {
                    path: path.to_owned(),
                    row,
                    column: Some(col.to_owned()),
                    message: format!("missing `{col}`"),
                })
            };
            let number = |i: usize, col: &str| -> Result<f64, MapError> {
                let f = field(i, col)?;
                let bad = |message: String| MapError::Csv { path: path.to_owned(), row, column: Some(col.to_owned()), message };
                let v: f64 = f.parse().map_err(|_| bad(format!("`{}` is not a number", crate::excerpt::excerpt(f))))?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(bad(format!("`{}` is not a finite number", crate::excerpt::excerpt(f))))
                }
            };
            let name = field(name_col, "name")?.to_owned();
            let at = DVec2::new(number(cx, nx)?, number(cy, ny)?);
            let mut values = Vec::with_capacity(vcols.len());
            for (&i, c) in vcols.iter().zip(columns) {
                let v = number(i, c)?;
                if v < 0.0 {
                    return Err(MapError::Csv {
                        path: path.to_owned(),
                        row,
                        column: Some(c.clone()),
                        message: format!("value {v} is negative: symbol heights must be >= 0"),
                    });
                }
                values.push(v);
            }
            places.push(Place { name, at, row, values });
        }
        Ok(Places { path: path.to_owned(), coords, columns: columns.to_vec(), places })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, cols: &[&str]) -> Result<Places, MapError> {
        let cols: Vec<String> = cols.iter().map(|s| (*s).to_owned()).collect();
        Places::parse(text, Path::new("p.csv"), &cols)
    }

    #[test]
    fn reads_planar_and_lonlat_in_any_column_order() {
        let p = parse("name,x,y,value\nA,1,2,3.5\nB, 4 ,5,0\n", &["value"]).unwrap();
        assert_eq!(p.coords, Coords::Planar);
        assert_eq!(p.places.len(), 2);
        assert_eq!(p.places[1].at, DVec2::new(4.0, 5.0));
        assert_eq!(p.places[0].values, vec![3.5]);
        assert_eq!(p.places[1].row, 3);
        let p = parse("v1970,lat,name,lon,v2000\n1,45,\"Oslo, N\",10,2\n", &["v1970", "v2000"]).unwrap();
        assert_eq!(p.coords, Coords::LonLat);
        assert_eq!(p.places[0].name, "Oslo, N");
        assert_eq!(p.places[0].at, DVec2::new(10.0, 45.0));
        assert_eq!(p.places[0].values, vec![1.0, 2.0]);
    }

    #[test]
    fn bad_rows_are_named() {
        let e = parse("name,x,y,value\nA,1,2,3\nB,1,,3\n", &["value"]).unwrap_err();
        assert!(matches!(&e, MapError::Csv { row: 3, column: Some(c), .. } if c == "y"), "{e}");
        let e = parse("name,x,y,value\nA,1,2\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("row 2") && e.to_string().contains("`value`"), "{e}");
        let e = parse("name,x,y,value\nA,1,2,lots\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("`lots` is not a number"), "{e}");
        let e = parse("name,x,y,value\nA,1,2,-4\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("negative"), "{e}");
        let e = parse("name,x,y,value\nA,1,2,NaN\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
        let e = parse("name,x,y\nA,1,2\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("no value column `value`"), "{e}");
        let e = parse("name,east,north,value\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("`lon` and `lat`"), "{e}");
        let e = parse("x,y,value\n", &["value"]).unwrap_err();
        assert!(e.to_string().contains("`name`"), "{e}");
    }

    #[test]
    fn empty_table_is_fine() {
        assert!(parse("name,x,y,value\n", &["value"]).unwrap().places.is_empty());
    }
}
