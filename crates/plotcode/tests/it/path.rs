//! Whether a path a device took is a stroke: shared by the tests that read
//! an EBB's moves back (their block ends lie between the vertices).

use strokes::DVec2;

/// Distance from `p` to the segment `a`-`b`.
pub fn dist_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let t = if d.length_squared() == 0.0 { 0.0 } else { ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0) };
    (a + d * t - p).length()
}

/// Whether `got` passes through every vertex of `want` exactly, in order,
/// and strays nowhere further than `tol` from `want`'s segments; what is
/// wrong if not.
pub fn follows(got: &[DVec2], want: &[DVec2], tol: f64) -> Result<(), String> {
    let mut from = 0;
    for v in want {
        match got[from..].iter().position(|g| g == v) {
            Some(at) => from += at,
            None => return Err(format!("vertex {v} not reached after point {from} of {got:?}")),
        }
    }
    for g in got {
        let off = match want {
            [only] => (*g - *only).length(),
            _ => want.windows(2).map(|s| dist_to_segment(*g, s[0], s[1])).fold(f64::INFINITY, f64::min),
        };
        if off > tol {
            return Err(format!("{g} is {off} off the stroke {want:?}"));
        }
    }
    Ok(())
}
