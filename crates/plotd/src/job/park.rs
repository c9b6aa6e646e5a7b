//! Where a one-pen plotter's head waits while a person changes the pen:
//! the corner of the device's reach farthest from the drawing, pen up.
//!
//! Why a corner of the reach and not the origin: the origin is one of the
//! corners, but drawings are often placed against it (and a plotter's
//! offset moves them over it), so parked there the pen could rest over the
//! drawing and the person would reach in over wet ink. The corner farthest
//! from the drawing's box is off it unless the drawing fills the whole
//! reach, and it leaves the most room around the pen. Among corners as far,
//! the origin's comes first.

use plotcode::{DeviceProfile, Program};
use strokes::DVec2;

/// The park point for `program` on `device`, mm from the origin (as
/// `plotd move` takes it); the origin when the program inks nothing whose
/// place is known.
#[must_use]
pub fn point(program: &Program, device: &DeviceProfile) -> [f64; 2] {
    let Some((lo, hi)) = program.inked_bounds() else { return [0.0, 0.0] };
    let (lo, hi) = (lo * device.unit_mm, hi * device.unit_mm);
    let (r_lo, r_hi) = plotcode::control::manual::reach_mm(device);
    let corners = [r_lo, DVec2::new(r_hi.x, r_lo.y), r_hi, DVec2::new(r_lo.x, r_hi.y)];
    // How far a corner is from the box: 0 inside it.
    let away = |c: DVec2| (lo - c).max(c - hi).max(DVec2::ZERO).length();
    let best = corners.iter().copied().fold(corners[0], |best, c| if away(c) > away(best) { c } else { best });
    [best.x, best.y]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_park_is_the_reach_corner_farthest_from_the_drawing() {
        let device = DeviceProfile::builtin("grbl-servo").unwrap();
        let near_origin = plotcode::cut(b"G21 G90\nG0 X10 Y10\nM3 S1000\nG1 X60 Y40 F3000\nM5\n", &device).unwrap();
        assert_eq!(point(&near_origin, &device), [420.0, 297.0]);
        let far = plotcode::cut(b"G21 G90\nG0 X300 Y200\nM3 S1000\nG1 X400 Y280 F3000\nM5\n", &device).unwrap();
        assert_eq!(point(&far, &device), [0.0, 0.0], "the origin, off a drawing far from it");
    }
}
