//! Tables of numbers from CSV files: surface heights and ridgeline profiles.
//!
//! Rows are y (or profiles), columns are x. When the top-left cell is empty or
//! not a number, the first row holds the x coordinates and the first column the
//! y coordinates. Blank lines and lines starting with `#` are skipped.

use thiserror::Error;

/// A CSV table that cannot be used; `line` and `column` are 1-based.
#[derive(Clone, Debug, Error, PartialEq)]
#[error("line {line}, column {column}: {message}")]
pub struct TableError {
    /// Line in the file.
    pub line: u64,
    /// Column (field) on that line.
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

/// The most cells a table may have.
pub const MAX_CELLS: usize = hiddenline::grid::MAX_GRID_POINTS;

/// A parsed table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// x coordinates from the header row, if there is one.
    pub xs: Option<Vec<f64>>,
    /// y coordinates from the header column, if there is one.
    pub ys: Option<Vec<f64>>,
    /// The numbers, one `Vec` per row, all the same length.
    pub rows: Vec<Vec<f64>>,
}

fn number(cell: &str, line: u64, column: usize) -> Result<f64, TableError> {
    let v: f64 =
        cell.parse().map_err(|_| TableError { line, column, message: format!("`{}` is not a number", crate::excerpt::excerpt(cell)) })?;
    if !v.is_finite() {
        return Err(TableError { line, column, message: format!("`{}` is not a finite number", crate::excerpt::excerpt(cell)) });
    }
    Ok(v)
}

/// Parses CSV text.
///
/// # Errors
/// Malformed CSV, a non-numeric cell, a ragged row (each naming line and
/// column), no data rows, or more than [`MAX_CELLS`] cells.
pub fn parse(text: &str) -> Result<Table, TableError> {
    let mut rd = crate::data_csv::reader(text, false);
    let mut table = Table::default();
    let mut header = false;
    let mut width: Option<usize> = None;
    let mut cells = 0usize;
    for (n, rec) in rd.records().enumerate() {
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            TableError { line, column: 0, message: e.to_string() }
        })?;
        let line = rec.position().map_or(n as u64 + 1, |p| p.line());
        if rec.iter().all(str::is_empty) {
            continue;
        }
        if n == 0 && rec.get(0).is_some_and(|c| c.parse::<f64>().is_err()) {
            header = true;
            let xs = rec.iter().enumerate().skip(1).map(|(i, c)| number(c, line, i + 1)).collect::<Result<Vec<_>, _>>()?;
            width = Some(xs.len());
            table.xs = Some(xs);
            table.ys = Some(Vec::new());
            continue;
        }
        let first = usize::from(header);
        let got = rec.len() - first;
        match width {
            None => width = Some(got),
            Some(w) if w != got => {
                return Err(TableError {
                    line,
                    column: if got < w { rec.len() + 1 } else { w + first + 1 },
                    message: format!("row has {got} values, expected {w} like the first row"),
                })
            }
            Some(_) => {}
        }
        if header {
            let y = number(rec.get(0).unwrap_or(""), line, 1)?;
            table.ys.as_mut().expect("header").push(y);
        }
        let row = rec.iter().enumerate().skip(first).map(|(i, c)| number(c, line, i + 1)).collect::<Result<Vec<_>, _>>()?;
        cells += row.len();
        if cells > MAX_CELLS {
            return Err(TableError { line, column: 1, message: format!("more than {MAX_CELLS} values") });
        }
        table.rows.push(row);
    }
    if table.rows.is_empty() {
        return Err(TableError { line: 1, column: 1, message: "no rows of numbers".into() });
    }
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_and_with_header() {
        let t = parse("1, 2, 3\n4,5,6\n").unwrap();
        assert_eq!(t.rows, vec![vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]]);
        assert_eq!(t.xs, None);
        let t = parse("# comment\n, 0, 0.5\n10, 1, 2\n\n20, 3, 4\n").unwrap();
        assert_eq!(t.xs, Some(vec![0.0, 0.5]));
        assert_eq!(t.ys, Some(vec![10.0, 20.0]));
        assert_eq!(t.rows, vec![vec![1.0, 2.0], vec![3.0, 4.0]]);
        let t = parse("y\\x,0,1\n0,5,6\n").unwrap();
        assert_eq!(t.rows, vec![vec![5.0, 6.0]]);
    }

    #[test]
    fn bad_tables_name_line_and_column() {
        let check = |text: &str, line: u64, column: usize, msg: &str| {
            let e = parse(text).unwrap_err();
            assert_eq!((e.line, e.column), (line, column), "{text:?}: {e}");
            assert!(e.message.contains(msg), "{text:?}: {e}");
        };
        check("1,2,3\n4,x,6\n", 2, 2, "`x` is not a number");
        check("1,2,3\n4,5\n", 2, 3, "2 values, expected 3");
        check("1,2,3\n4,5,6,7\n", 2, 4, "4 values, expected 3");
        check(",0,1\n0,1,2\nabc,1,2\n", 3, 1, "`abc`");
        check(",0,q\n", 1, 3, "`q`");
        check("1,nan\n", 1, 2, "not a finite");
        check("# only a comment\n", 1, 1, "no rows");
    }
}
