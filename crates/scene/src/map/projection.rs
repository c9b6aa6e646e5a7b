//! From data coordinates to the ground plane.
//!
//! A map's outline and its places share one [`Placement`]: an optional
//! lon/lat projection to "map units", then a uniform `scale` and an `offset`
//! that put map units onto world x, y at z = 0. Map units of the lon/lat
//! projections are degrees of longitude at the equator, so the same `scale`
//! suits planar data drawn in degrees.

use glam::DVec2;
use serde::Deserialize;

/// How coordinates in a data file become map units.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Projection {
    /// The data are already planar map units (x, y); nothing is projected.
    #[default]
    Planar,
    /// Plate carrée: x = longitude, y = latitude, both in degrees.
    Equirectangular,
    /// Spherical Mercator: x = longitude, y = the Mercator ordinate in
    /// degree units, so scale is true at the equator.
    Mercator,
}

/// Mercator stretches to infinity at the poles; data beyond this latitude
/// (the usual web-map cut-off) are refused rather than drawn off the page.
pub const MERCATOR_MAX_LAT: f64 = 85.051_128_779_806_59;

impl Projection {
    /// Map units of a data point, or why it has none. For the lon/lat
    /// projections `p` is (longitude, latitude) in degrees.
    ///
    /// # Errors
    /// A non-finite coordinate; a latitude outside [-90, 90] (or outside
    /// ±[`MERCATOR_MAX_LAT`] for Mercator).
    pub fn project(self, p: DVec2) -> Result<DVec2, String> {
        if !p.is_finite() {
            return Err(format!("coordinate ({}, {}) is not a finite number", p.x, p.y));
        }
        match self {
            Projection::Planar => Ok(p),
            Projection::Equirectangular => {
                check_lat(p.y, 90.0)?;
                Ok(p)
            }
            Projection::Mercator => {
                check_lat(p.y, MERCATOR_MAX_LAT)?;
                let phi = p.y.to_radians();
                let y = (std::f64::consts::FRAC_PI_4 + phi * 0.5).tan().ln().to_degrees();
                Ok(DVec2::new(p.x, y))
            }
        }
    }

    /// True when data coordinates are (longitude, latitude).
    #[must_use]
    pub fn is_geographic(self) -> bool {
        self != Projection::Planar
    }
}

fn check_lat(lat: f64, max: f64) -> Result<(), String> {
    if lat.abs() > max {
        Err(format!("latitude {lat} is outside [-{max}, {max}]"))
    } else {
        Ok(())
    }
}

/// Projection, then `scale`, then `offset`: data coordinates to world x, y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Data to map units.
    pub projection: Projection,
    /// World units per map unit, > 0.
    pub scale: f64,
    /// World position of map-unit origin.
    pub offset: DVec2,
}

impl Default for Placement {
    fn default() -> Self {
        Placement { projection: Projection::Planar, scale: 1.0, offset: DVec2::ZERO }
    }
}

impl Placement {
    /// World x, y of a data point given in the projection's coordinates.
    ///
    /// # Errors
    /// As [`Projection::project`].
    pub fn place(&self, p: DVec2) -> Result<DVec2, String> {
        Ok(self.place_map_units(self.projection.project(p)?))
    }

    /// World x, y of a point already in map units.
    #[must_use]
    pub fn place_map_units(&self, m: DVec2) -> DVec2 {
        self.offset + self.scale * m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planar_and_equirectangular_are_identity() {
        let p = DVec2::new(12.5, -40.0);
        assert_eq!(Projection::Planar.project(p), Ok(p));
        assert_eq!(Projection::Equirectangular.project(p), Ok(p));
        // Planar data are not latitudes: large y is fine.
        assert!(Projection::Planar.project(DVec2::new(0.0, 1000.0)).is_ok());
    }

    #[test]
    fn mercator_is_true_at_equator_and_stretches_north() {
        let m = |lat: f64| Projection::Mercator.project(DVec2::new(10.0, lat)).unwrap();
        assert!(m(0.0).y.abs() < 1e-12);
        assert_eq!(m(0.0).x, 10.0);
        // Near the equator one degree of latitude is one map unit.
        assert!((m(0.01).y - 0.01).abs() < 1e-8);
        // Symmetric, and stretched towards the pole.
        assert!((m(60.0).y + m(-60.0).y).abs() < 1e-9);
        assert!(m(60.0).y > 60.0);
        // ln(tan(45 + 30)) in degrees: a known value.
        assert!((m(60.0).y - 75.456_129_290_216_5).abs() < 1e-6, "{}", m(60.0).y);
    }

    #[test]
    fn bad_latitudes_and_nan_are_errors() {
        assert!(Projection::Mercator.project(DVec2::new(0.0, 89.0)).is_err());
        assert!(Projection::Mercator.project(DVec2::new(0.0, MERCATOR_MAX_LAT)).is_ok());
        assert!(Projection::Equirectangular.project(DVec2::new(0.0, -90.5)).is_err());
        assert!(Projection::Planar.project(DVec2::new(f64::NAN, 0.0)).is_err());
        assert!(Projection::Equirectangular.project(DVec2::new(f64::INFINITY, 0.0)).is_err());
    }

    #[test]
    fn placement_scales_then_offsets() {
        let pl = Placement { projection: Projection::Planar, scale: 2.0, offset: DVec2::new(1.0, -1.0) };
        assert_eq!(pl.place(DVec2::new(3.0, 4.0)), Ok(DVec2::new(7.0, 7.0)));
    }
}
