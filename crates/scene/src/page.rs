//! The sheet of paper and how the picture is framed on it.
//!
//! A page has a size, an orientation and a margin; the drawable area is the
//! page less the margin on every side. Two framings ([`Frame`]):
//!
//! - `fit` (default): the whole drawing (its bounding box in device space) is
//!   scaled uniformly, aspect kept, to fill the drawable area, and centred.
//! - `fov`: the camera's frame is the picture's frame. Device space `y` in
//!   `[-1, 1]` (the vertical field of view, or the orthographic height) maps
//!   to the drawable height, `x` spans the drawable aspect, and every line is
//!   clipped exactly at the frame's edges (on its parameter, so visible
//!   intervals stay exact).
//!
//! Page space is millimetres, origin bottom-left, y up; device space is also
//! y up, so the map is a scale and a translation.

use glam::DVec2;
use serde::Deserialize;
use thiserror::Error;

/// How the picture is placed on the page.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Frame {
    /// Scale the whole drawing to the drawable area.
    #[default]
    Fit,
    /// The camera's field of view is the frame; lines are clipped at it.
    Fov,
}

/// A paper size as written in the scene file: a name or `[w_mm, h_mm]`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum PaperSpec {
    /// `"A4"`, `"A3"`, `"letter"` (case-insensitive).
    Named(String),
    /// Width and height in millimetres.
    Custom([f64; 2]),
}

/// The `[page]` table as written in the scene file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PageSpec {
    /// Paper size; default A4.
    #[serde(default)]
    pub size: Option<PaperSpec>,
    /// Long side horizontal. Default true for named sizes; custom sizes are
    /// taken as written unless this is given.
    #[serde(default)]
    pub landscape: Option<bool>,
    /// Margin on every side, mm; default 10.
    #[serde(default)]
    pub margin_mm: Option<f64>,
}

/// Why a page description cannot be used.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PageError {
    /// An unknown paper name.
    #[error("unknown paper size {0:?} (expected A4, A3, letter or [w_mm, h_mm])")]
    UnknownSize(String),
    /// A non-positive or non-finite size.
    #[error("paper size [{0}, {1}] must be finite and > 0")]
    BadSize(f64, f64),
    /// A margin that leaves nothing to draw on.
    #[error("margin_mm = {margin} leaves no drawable area on a {width} x {height} mm page")]
    BadMargin {
        /// The margin.
        margin: f64,
        /// Page width.
        width: f64,
        /// Page height.
        height: f64,
    },
}

/// A validated page.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Page {
    /// Width, mm.
    pub width_mm: f64,
    /// Height, mm.
    pub height_mm: f64,
    /// Margin on every side, mm.
    pub margin_mm: f64,
}

/// A similarity from device space to page space: `page = device * scale + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Millimetres per device unit.
    pub scale: f64,
    /// Page position of the device origin.
    pub offset: DVec2,
}

impl Placement {
    /// Page position of device point `p`.
    #[must_use]
    pub fn apply(&self, p: DVec2) -> DVec2 {
        p * self.scale + self.offset
    }
}

impl Default for Page {
    /// A4 landscape, 10 mm margin.
    fn default() -> Self {
        Page { width_mm: 297.0, height_mm: 210.0, margin_mm: 10.0 }
    }
}

impl Page {
    /// Validates a `[page]` table.
    ///
    /// # Errors
    /// Unknown paper name, bad size, margin too large or negative.
    pub fn from_spec(spec: &PageSpec) -> Result<Page, PageError> {
        let (w, h, named) = match &spec.size {
            None => (210.0, 297.0, true),
            Some(PaperSpec::Named(n)) => match n.to_ascii_lowercase().as_str() {
                "a4" => (210.0, 297.0, true),
                "a3" => (297.0, 420.0, true),
                "letter" => (215.9, 279.4, true),
                _ => return Err(PageError::UnknownSize(n.clone())),
            },
            Some(PaperSpec::Custom([w, h])) => (*w, *h, false),
        };
        if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
            return Err(PageError::BadSize(w, h));
        }
        let (w, h) = match spec.landscape.or(named.then_some(true)) {
            Some(true) => (w.max(h), w.min(h)),
            Some(false) => (w.min(h), w.max(h)),
            None => (w, h),
        };
        let margin = spec.margin_mm.unwrap_or(10.0);
        if !(margin >= 0.0 && 2.0 * margin < w.min(h)) {
            return Err(PageError::BadMargin { margin, width: w, height: h });
        }
        Ok(Page { width_mm: w, height_mm: h, margin_mm: margin })
    }

    /// Drawable area as (bottom-left, top-right), mm.
    #[must_use]
    pub fn drawable(&self) -> (DVec2, DVec2) {
        let m = DVec2::splat(self.margin_mm);
        (m, DVec2::new(self.width_mm, self.height_mm) - m)
    }

    /// `frame = "fit"`: the placement that scales the device-space box
    /// `bounds` to the drawable area, aspect kept, centred. A box of zero
    /// size (a point, or nothing drawn) keeps scale 1 around the centre.
    #[must_use]
    pub fn fit(&self, bounds: Option<(DVec2, DVec2)>) -> Placement {
        let (lo, hi) = self.drawable();
        let centre = (lo + hi) * 0.5;
        let Some((blo, bhi)) = bounds else {
            return Placement { scale: 1.0, offset: centre };
        };
        let size = bhi - blo;
        let room = hi - lo;
        let scale = match (size.x > 0.0, size.y > 0.0) {
            (true, true) => (room.x / size.x).min(room.y / size.y),
            (true, false) => room.x / size.x,
            (false, true) => room.y / size.y,
            (false, false) => 1.0,
        };
        Placement { scale, offset: centre - (blo + bhi) * 0.5 * scale }
    }

    /// `frame = "fov"`: the device-space window the page shows (x spans the
    /// drawable aspect, y spans [-1, 1]) and the placement mapping it onto the
    /// drawable area.
    #[must_use]
    pub fn fov(&self) -> ((DVec2, DVec2), Placement) {
        let (lo, hi) = self.drawable();
        let room = hi - lo;
        let aspect = room.x / room.y;
        let window = (DVec2::new(-aspect, -1.0), DVec2::new(aspect, 1.0));
        (window, Placement { scale: room.y * 0.5, offset: (lo + hi) * 0.5 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(size: Option<PaperSpec>, landscape: Option<bool>, margin: Option<f64>) -> PageSpec {
        PageSpec { size, landscape, margin_mm: margin }
    }

    #[test]
    fn sizes_and_orientation() {
        assert_eq!(Page::from_spec(&spec(None, None, None)).unwrap(), Page::default());
        let p = Page::from_spec(&spec(Some(PaperSpec::Named("a3".into())), Some(false), Some(5.0))).unwrap();
        assert_eq!((p.width_mm, p.height_mm, p.margin_mm), (297.0, 420.0, 5.0));
        let p = Page::from_spec(&spec(Some(PaperSpec::Named("Letter".into())), None, None)).unwrap();
        assert_eq!((p.width_mm, p.height_mm), (279.4, 215.9));
        let p = Page::from_spec(&spec(Some(PaperSpec::Custom([100.0, 150.0])), None, None)).unwrap();
        assert_eq!((p.width_mm, p.height_mm), (100.0, 150.0));
        let p = Page::from_spec(&spec(Some(PaperSpec::Custom([100.0, 150.0])), Some(true), None)).unwrap();
        assert_eq!((p.width_mm, p.height_mm), (150.0, 100.0));
    }

    #[test]
    fn bad_pages() {
        assert!(matches!(Page::from_spec(&spec(Some(PaperSpec::Named("B5".into())), None, None)), Err(PageError::UnknownSize(_))));
        assert!(matches!(Page::from_spec(&spec(Some(PaperSpec::Custom([0.0, 1.0])), None, None)), Err(PageError::BadSize(..))));
        assert!(matches!(Page::from_spec(&spec(None, None, Some(105.0))), Err(PageError::BadMargin { .. })));
        assert!(matches!(Page::from_spec(&spec(None, None, Some(-1.0))), Err(PageError::BadMargin { .. })));
        assert!(matches!(Page::from_spec(&spec(None, None, Some(f64::NAN))), Err(PageError::BadMargin { .. })));
    }

    #[test]
    fn fit_fills_one_dimension_and_centres() {
        let page = Page::default(); // drawable 277 x 190 from (10, 10)
        let pl = page.fit(Some((DVec2::new(-1.0, -1.0), DVec2::new(1.0, 1.0))));
        assert_eq!(pl.scale, 95.0);
        assert_eq!(pl.apply(DVec2::new(0.0, 0.0)), DVec2::new(148.5, 105.0));
        assert_eq!(pl.apply(DVec2::new(1.0, 1.0)), DVec2::new(243.5, 200.0));
        // A horizontal line fills the width.
        let pl = page.fit(Some((DVec2::new(2.0, 3.0), DVec2::new(4.0, 3.0))));
        assert_eq!(pl.apply(DVec2::new(2.0, 3.0)), DVec2::new(10.0, 105.0));
        // Nothing drawn, or a point: no panic, centred.
        assert_eq!(page.fit(None).apply(DVec2::ZERO), DVec2::new(148.5, 105.0));
        let p = DVec2::new(5.0, 5.0);
        assert_eq!(page.fit(Some((p, p))).apply(p), DVec2::new(148.5, 105.0));
    }

    #[test]
    fn fov_window_matches_the_drawable_area() {
        let page = Page::default();
        let ((lo, hi), pl) = page.fov();
        assert_eq!(pl.apply(lo), DVec2::new(10.0, 10.0));
        assert!((pl.apply(hi) - DVec2::new(287.0, 200.0)).length() < 1e-9);
    }
}
