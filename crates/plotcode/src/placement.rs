//! Page fitting: where a drawing's page lands in a device's plotting area.
//!
//! The drawing's page (millimetres, origin bottom-left, y up) is centred on the
//! plotting area of one paper, turned a quarter turn when the page and the
//! area disagree about landscape, and kept at true size when its ink fits. Ink
//! that would cross the hard-clip limits is never clipped: the whole drawing is
//! scaled down about the page centre until it fits, and the [`Placement`] says
//! so (`scale < 1`), for the caller to report.

use crate::emit::{EmitError, EmitOptions};
use crate::profile::{DeviceProfile, Paper};
use strokes::{DVec2, Drawing};

/// The affine map from page millimetres to device units chosen for one emit.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// The paper the drawing is placed on.
    pub paper: String,
    /// Whether the page was turned a quarter turn (counter-clockwise) to match
    /// the plotting area's orientation.
    pub rotated: bool,
    /// Scale factor from page to paper; 1 is true size, below 1 means the
    /// drawing was scaled down to fit.
    pub scale: f64,
    page: DVec2,
    area_center: DVec2,
    unit_mm: f64,
    y_sign: f64,
}

/// Two points of the same page closer than this (mm) count as equal when
/// matching a page to a paper size.
const PAPER_MATCH_MM: f64 = 1.0;

impl Placement {
    /// True size, no rotation, page = the paper's sheet oriented like its
    /// plotting area. Used to read device files back onto a page.
    #[must_use]
    pub fn true_size(profile: &DeviceProfile, paper: &Paper) -> Placement {
        let (aw, ah) = paper.area_mm(profile.unit_mm);
        let [a, b] = paper.page_mm;
        let page = if (aw >= ah) == (a >= b) { DVec2::new(a, b) } else { DVec2::new(b, a) };
        Placement::new(profile, paper, page, false, 1.0, DVec2::ZERO)
    }

    /// `offset`: mm along the device's axes (the profile's origin offset).
    fn new(profile: &DeviceProfile, paper: &Paper, page: DVec2, rotated: bool, scale: f64, offset: DVec2) -> Placement {
        let lo = DVec2::new(paper.x_range[0], paper.y_range[0]);
        let hi = DVec2::new(paper.x_range[1], paper.y_range[1]);
        Placement {
            paper: paper.name.clone(),
            rotated,
            scale,
            page,
            area_center: (lo + hi) / 2.0 + offset / profile.unit_mm,
            unit_mm: profile.unit_mm,
            y_sign: if profile.y_up { 1.0 } else { -1.0 },
        }
    }

    /// Whether the drawing had to be scaled down to fit.
    #[must_use]
    pub fn scaled_down(&self) -> bool {
        self.scale < 1.0
    }

    /// The page size in millimetres this placement maps from.
    #[must_use]
    pub fn page_mm(&self) -> (f64, f64) {
        (self.page.x, self.page.y)
    }

    /// Device coordinates (unrounded) of a page point.
    #[must_use]
    pub fn to_device(&self, p: DVec2) -> DVec2 {
        let mut q = p - self.page / 2.0;
        if self.rotated {
            q = DVec2::new(-q.y, q.x);
        }
        q *= self.scale / self.unit_mm;
        self.area_center + DVec2::new(q.x, self.y_sign * q.y)
    }

    /// The page point of a device point (the inverse of [`Placement::to_device`]).
    #[must_use]
    pub fn to_page(&self, d: DVec2) -> DVec2 {
        let off = d - self.area_center;
        let mut q = DVec2::new(off.x, self.y_sign * off.y) * (self.unit_mm / self.scale);
        if self.rotated {
            q = DVec2::new(q.y, -q.x);
        }
        q + self.page / 2.0
    }
}

/// Chooses the paper and computes the placement of `drawing` on `profile`.
///
/// # Errors
/// [`EmitError::UnknownPaper`] when `opts.paper` names no paper of the profile,
/// [`EmitError::NonFinite`] for NaN or infinite coordinates,
/// [`EmitError::BadOptions`] when the margin leaves no room.
pub fn place(drawing: &Drawing, profile: &DeviceProfile, opts: &EmitOptions) -> Result<Placement, EmitError> {
    check_finite(drawing)?;
    let paper = choose_paper(drawing, profile, opts)?;
    let (aw, ah) = paper.area_mm(profile.unit_mm);
    let (w, h) = (drawing.width_mm, drawing.height_mm);
    if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
        return Err(EmitError::BadOptions(format!("the drawing's page is {w} x {h} mm")));
    }
    let rotated = (w > h && aw < ah) || (w < h && aw > ah);
    let page = DVec2::new(w, h);
    // Room either side of the centre, less the margin. Range limits are whole
    // units, so a point inside them never rounds outside.
    // A drawing moved by the plotter's origin offset keeps the same room
    // on its far side: the nearer limit bounds it.
    let offset = DVec2::from(profile.origin_offset_mm);
    if !offset.is_finite() {
        return Err(EmitError::BadOptions(format!("the origin offset {:?} mm is not a distance", profile.origin_offset_mm)));
    }
    let half = DVec2::new(aw, ah) / 2.0 - DVec2::splat(opts.margin_mm);
    if opts.margin_mm.is_nan() || opts.margin_mm < 0.0 || half.x <= 0.0 || half.y <= 0.0 {
        return Err(EmitError::BadOptions(format!(
            "a margin of {} mm leaves no room on {} ({aw:.1} x {ah:.1} mm)",
            opts.margin_mm, paper.name
        )));
    }
    let half = half - offset.abs();
    if half.x <= 0.0 || half.y <= 0.0 {
        return Err(EmitError::BadOptions(format!(
            "an origin offset of ({}, {}) mm leaves no room on {} ({aw:.1} x {ah:.1} mm)",
            offset.x, offset.y, paper.name
        )));
    }
    let mut scale = 1.0;
    if let (Some((lo, hi)), true) = (drawing.bounds(), opts.scale_to_fit) {
        let c = page / 2.0;
        let (mut ex, mut ey) = (0.0_f64, 0.0_f64);
        for corner in [lo, hi, DVec2::new(lo.x, hi.y), DVec2::new(hi.x, lo.y)] {
            let mut q = corner - c;
            if rotated {
                q = DVec2::new(-q.y, q.x);
            }
            ex = ex.max(q.x.abs());
            ey = ey.max(q.y.abs());
        }
        if ex > half.x {
            scale = f64::min(scale, half.x / ex);
        }
        if ey > half.y {
            scale = f64::min(scale, half.y / ey);
        }
    }
    Ok(Placement::new(profile, paper, page, rotated, scale, offset))
}

fn check_finite(drawing: &Drawing) -> Result<(), EmitError> {
    for layer in &drawing.layers {
        for (i, poly) in layer.polylines.iter().enumerate() {
            if let Some(k) = poly.points.iter().position(|p| !p.is_finite()) {
                return Err(EmitError::NonFinite { pen: layer.pen, polyline: i, point: k });
            }
        }
    }
    Ok(())
}

/// The paper named in the options (`--paper`); else the one whose sheet is
/// the drawing's page (a scene with `size = "A3"`); else the profile's
/// `default_paper`.
fn choose_paper<'a>(drawing: &Drawing, profile: &'a DeviceProfile, opts: &EmitOptions) -> Result<&'a Paper, EmitError> {
    if let Some(name) = &opts.paper {
        return profile.paper_named(name).ok_or_else(|| EmitError::UnknownPaper {
            name: name.clone(),
            device: profile.name.clone(),
            known: profile.paper_names().iter().map(|s| (*s).to_owned()).collect(),
        });
    }
    let (w, h) = (drawing.width_mm.max(drawing.height_mm), drawing.width_mm.min(drawing.height_mm));
    let sheet = |p: &Paper| (p.page_mm[0].max(p.page_mm[1]), p.page_mm[0].min(p.page_mm[1]));
    if let Some(p) = profile.paper.iter().find(|p| {
        let (a, b) = sheet(p);
        (a - w).abs() < PAPER_MATCH_MM && (b - h).abs() < PAPER_MATCH_MM
    }) {
        return Ok(p);
    }
    // Not a sheet of this device: the paper its user keeps loaded. Guessing
    // a smaller sheet that would hold the page (letter for a 200 x 150 mm
    // drawing) sends the plot to paper that is not in the plotter.
    Ok(profile.paper_named(&profile.default_paper).expect("validated: the default paper exists"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use strokes::{LineKind, Polyline};

    fn drawing(w: f64, h: f64, pts: &[(f64, f64)]) -> Drawing {
        let mut d = Drawing::new(w, h);
        d.layer_mut(1, LineKind::Visible).polylines.push(Polyline::new(pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect()));
        d
    }

    #[test]
    fn a4_landscape_on_hp7475a_true_size_and_centred() {
        let p = DeviceProfile::builtin("hp7475a").unwrap();
        let d = drawing(297.0, 210.0, &[(20.0, 20.0), (277.0, 190.0)]);
        let pl = place(&d, &p, &EmitOptions::default()).unwrap();
        assert_eq!(pl.paper, "A4");
        assert!(!pl.rotated && pl.scale == 1.0);
        // The page centre lands on the area centre.
        let c = pl.to_device(DVec2::new(148.5, 105.0));
        assert!((c - DVec2::new(5520.0, 3860.5)).length() < 1e-9);
        // 10 mm on the page is 10 mm on the paper.
        let a = pl.to_device(DVec2::new(20.0, 20.0));
        let b = pl.to_device(DVec2::new(30.0, 20.0));
        assert!(((b.x - a.x) * p.unit_mm - 10.0).abs() < 1e-9);
        assert!((pl.to_page(a) - DVec2::new(20.0, 20.0)).length() < 1e-9);
    }

    #[test]
    fn portrait_page_is_turned_and_big_ink_scaled_down() {
        let p = DeviceProfile::builtin("hp7475a").unwrap();
        // Ink to the page edges: 297 mm does not fit in the 192 mm high area.
        let d = drawing(210.0, 297.0, &[(0.0, 0.0), (210.0, 297.0)]);
        let pl = place(&d, &p, &EmitOptions::default()).unwrap();
        assert!(pl.rotated);
        assert!(pl.scaled_down() && pl.scale > 0.6 && pl.scale < 1.0, "{}", pl.scale);
        for q in [DVec2::new(0.0, 0.0), DVec2::new(210.0, 297.0), DVec2::new(0.0, 297.0)] {
            let dv = pl.to_device(q).round();
            assert!(dv.x >= 0.0 && dv.x <= 11040.0 && dv.y >= 0.0 && dv.y <= 7721.0, "{dv}");
            assert!((pl.to_page(pl.to_device(q)) - q).length() < 1e-9);
        }
        // Page-up (+y) points along device +x... or -x; either way a quarter turn:
        let up = pl.to_device(DVec2::new(105.0, 200.0)) - pl.to_device(DVec2::new(105.0, 100.0));
        assert!(up.y.abs() < 1e-9 && up.x.abs() > 1.0);
    }

    /// A plotter's origin offset moves every point by it, along the
    /// device's axes; one that would push ink past a limit scales the
    /// drawing down to fit, and one that leaves no room is refused.
    #[test]
    fn the_origin_offset_moves_the_drawing_and_keeps_it_inside_the_limits() {
        let mut p = DeviceProfile::builtin("hp7475a").unwrap();
        let d = drawing(297.0, 210.0, &[(40.0, 30.0), (257.0, 180.0)]);
        let at = place(&d, &p, &EmitOptions::default()).unwrap();
        p.origin_offset_mm = [10.0, 5.0];
        let moved = place(&d, &p, &EmitOptions::default()).unwrap();
        assert_eq!(moved.scale, 1.0);
        for q in [DVec2::new(40.0, 30.0), DVec2::new(257.0, 180.0)] {
            let shift = (moved.to_device(q) - at.to_device(q)) * p.unit_mm;
            assert!((shift - DVec2::new(10.0, 5.0)).length() < 1e-9, "{shift}");
        }
        // Ink to the page's edges, moved 40 mm: scaled down, still inside.
        let full = drawing(297.0, 210.0, &[(0.0, 0.0), (297.0, 210.0)]);
        p.origin_offset_mm = [40.0, -3.0];
        let pl = place(&full, &p, &EmitOptions::default()).unwrap();
        assert!(pl.scaled_down());
        for q in [DVec2::new(0.0, 0.0), DVec2::new(297.0, 210.0)] {
            let dv = pl.to_device(q).round();
            assert!(dv.x >= 0.0 && dv.x <= 11040.0 && dv.y >= 0.0 && dv.y <= 7721.0, "{dv}");
        }
        p.origin_offset_mm = [300.0, 0.0];
        let e = place(&d, &p, &EmitOptions::default()).unwrap_err().to_string();
        assert!(e.contains("origin offset of (300, 0) mm leaves no room"), "{e}");
    }

    #[test]
    fn paper_choice() {
        let p = DeviceProfile::builtin("hp7475a").unwrap();
        let opts = EmitOptions::default();
        assert_eq!(place(&drawing(420.0, 297.0, &[]), &p, &opts).unwrap().paper, "A3");
        assert_eq!(place(&drawing(215.9, 279.4, &[]), &p, &opts).unwrap().paper, "letter");
        // Any other page goes on the default paper (scaled down when its ink
        // does not fit), never on a sheet guessed from its size.
        assert_eq!(place(&drawing(200.0, 150.0, &[]), &p, &opts).unwrap().paper, "A4");
        assert_eq!(place(&drawing(400.0, 290.0, &[]), &p, &opts).unwrap().paper, "A4");
        assert_eq!(place(&drawing(2000.0, 1000.0, &[]), &p, &opts).unwrap().paper, "A4");
        let named = EmitOptions { paper: Some("a3".into()), ..EmitOptions::default() };
        assert_eq!(place(&drawing(297.0, 210.0, &[]), &p, &named).unwrap().paper, "A3");
        let bad = EmitOptions { paper: Some("B5".into()), ..EmitOptions::default() };
        let e = place(&drawing(297.0, 210.0, &[]), &p, &bad).unwrap_err().to_string();
        assert!(e.contains("B5") && e.contains("A4, A3, letter, tabloid"), "{e}");
    }

    #[test]
    fn centre_origin_and_bad_input() {
        let p = DeviceProfile::builtin("hp7585b").unwrap();
        let d = drawing(841.0, 594.0, &[(420.5, 297.0), (430.5, 297.0)]);
        let pl = place(&d, &p, &EmitOptions::default()).unwrap();
        assert!(pl.to_device(DVec2::new(420.5, 297.0)).length() < 1e-9);
        let nan = drawing(297.0, 210.0, &[(1.0, 1.0), (f64::NAN, 2.0)]);
        assert!(matches!(place(&nan, &p, &EmitOptions::default()), Err(EmitError::NonFinite { point: 1, .. })));
        let fat = EmitOptions { margin_mm: 500.0, ..EmitOptions::default() };
        assert!(matches!(place(&d, &p, &fat), Err(EmitError::BadOptions(_))));
        assert!(matches!(place(&drawing(0.0, 210.0, &[]), &p, &EmitOptions::default()), Err(EmitError::BadOptions(_))));
    }
}
