//! The terrain both render benchmarks draw (scene's engine pipeline and
//! plotd's whole process): a height field of `m` x `m` quads, each split in
//! two triangles, as an OBJ. Shared as a file (`#[path]`), not a library
//! item: it is bench input, not part of any crate's API.

use std::fmt::Write as _;

/// The OBJ text of an `m` x `m` terrain over [-2, 2]^2.
pub fn terrain_obj(m: usize) -> String {
    let mut s = String::with_capacity(64 * m * m);
    for j in 0..=m {
        for i in 0..=m {
            let (x, y) = (i as f64 / m as f64 * 4.0 - 2.0, j as f64 / m as f64 * 4.0 - 2.0);
            let z = 0.3 * (3.0 * x).sin() * (2.0 * y).cos() + 0.05 * (17.0 * x + 11.0 * y).sin();
            let _ = writeln!(s, "v {x} {y} {z}");
        }
    }
    for j in 0..m {
        for i in 0..m {
            let a = j * (m + 1) + i + 1;
            let _ = writeln!(s, "f {} {} {}\nf {} {} {}", a, a + 1, a + m + 2, a, a + m + 2, a + m + 1);
        }
    }
    s
}
