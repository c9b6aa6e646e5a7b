//! Frame sequences: symbol values interpolated between data columns, and the
//! camera moved along keyframes, as in Bramall's movies.
//!
//! Frame `i` of `n` sits at time `t = i / (n - 1)` (a single frame at t = 0).
//! Interpolation is written `(1 - t) a + t b`, so the first and last frames
//! reproduce the start and end columns exactly, bit for bit.

use super::error::MapError;
use super::limits::MAX_FRAMES;
use super::spec::AnimationSpec;
use glam::DVec3;
use hiddenline::camera::{Camera, CameraError};

/// Where the symbol values of each frame come from.
#[derive(Clone, Debug, PartialEq)]
pub enum ValueSource {
    /// One column for every frame (only the camera moves).
    Fixed(String),
    /// Linear from the first column to the second over the whole sequence.
    Between(String, String),
    /// One column per time step, spread evenly over the frames; piecewise
    /// linear in between.
    Steps(Vec<String>),
}

/// A validated `[animation]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// Number of frames, >= 1.
    pub frames: usize,
    /// Value columns (the symbols' own `value` column when `None`).
    pub values: Option<ValueSource>,
    /// Camera keyframes `(frame, eye, target)`, frames strictly increasing.
    pub keys: Vec<(usize, DVec3, Option<DVec3>)>,
}

impl Animation {
    /// Validates an `[animation]` table.
    ///
    /// # Errors
    /// `frames` out of 1..=[`MAX_FRAMES`]; `from` without `to` (or the reverse);
    /// both `from`/`to` and `columns`; an empty `columns`; camera keys out of
    /// order, past the last frame, or not finite.
    pub fn from_spec(spec: &AnimationSpec) -> Result<Animation, MapError> {
        let bad = |key, msg: String| MapError::spec("animation", key, msg);
        if spec.frames == 0 || spec.frames > MAX_FRAMES {
            return Err(bad("frames", format!("{} is outside 1..={MAX_FRAMES}", spec.frames)));
        }
        let values = match (&spec.from, &spec.to, &spec.columns) {
            (None, None, None) => None,
            (Some(a), Some(b), None) => Some(ValueSource::Between(a.clone(), b.clone())),
            (None, None, Some(c)) if c.is_empty() => return Err(bad("columns", "needs at least one column".into())),
            (None, None, Some(c)) if c.len() == 1 => Some(ValueSource::Fixed(c[0].clone())),
            (None, None, Some(c)) => Some(ValueSource::Steps(c.clone())),
            (_, _, Some(_)) => return Err(bad("columns", "give either `from`/`to` or `columns`, not both".into())),
            (Some(_), None, _) => return Err(bad("to", "`from` needs a `to` column".into())),
            (None, Some(_), _) => return Err(bad("from", "`to` needs a `from` column".into())),
        };
        let mut keys = Vec::with_capacity(spec.camera.len());
        for (i, k) in spec.camera.iter().enumerate() {
            let eye = DVec3::from_array(k.eye);
            let target = k.target.map(DVec3::from_array);
            if crate::tolerance::beyond_limit(eye).is_some() || target.is_some_and(|t| crate::tolerance::beyond_limit(t).is_some()) {
                let max = crate::tolerance::MAX_COORDINATE;
                return Err(bad("camera", format!("key {i}: eye/target must be finite and within ±{max:e}")));
            }
            if k.frame >= spec.frames {
                return Err(bad("camera", format!("key {i}: frame {} is past the last frame {}", k.frame, spec.frames - 1)));
            }
            if keys.last().is_some_and(|&(f, _, _)| f >= k.frame) {
                return Err(bad("camera", format!("key {i}: frames must strictly increase (frame {})", k.frame)));
            }
            keys.push((k.frame, eye, target));
        }
        Ok(Animation { frames: spec.frames, values, keys })
    }

    /// Time of frame `i` in [0, 1].
    #[must_use]
    pub fn time(&self, frame: usize) -> f64 {
        if self.frames <= 1 {
            0.0
        } else {
            frame.min(self.frames - 1) as f64 / (self.frames - 1) as f64
        }
    }

    /// The data columns a places file must provide, given the symbols' own
    /// `value` column.
    #[must_use]
    pub fn columns(&self, own: &str) -> Vec<String> {
        match &self.values {
            None => vec![own.to_owned()],
            Some(ValueSource::Fixed(c)) => vec![c.clone()],
            Some(ValueSource::Between(a, b)) => vec![a.clone(), b.clone()],
            Some(ValueSource::Steps(c)) => c.clone(),
        }
    }

    /// The value at `frame` from one place's column values (as ordered by
    /// [`Animation::columns`]).
    #[must_use]
    pub fn value(&self, values: &[f64], frame: usize) -> f64 {
        interpolate(values, self.time(frame))
    }

    /// The camera of `frame`: `base` with eye and target moved along the
    /// keyframes (held before the first key and after the last).
    ///
    /// # Errors
    /// The moved camera is unusable (e.g. eye on the target).
    pub fn camera(&self, frame: usize, base: &Camera) -> Result<Camera, CameraError> {
        if self.keys.is_empty() {
            return Ok(*base);
        }
        let f = frame.min(self.frames - 1);
        let tgt = |t: Option<DVec3>| t.unwrap_or(base.target);
        let (eye, target) = match self.keys.iter().position(|&(kf, _, _)| kf >= f) {
            Some(0) => (self.keys[0].1, tgt(self.keys[0].2)),
            None => {
                let k = self.keys[self.keys.len() - 1];
                (k.1, tgt(k.2))
            }
            Some(j) => {
                let (f0, e0, t0) = self.keys[j - 1];
                let (f1, e1, t1) = self.keys[j];
                let s = (f - f0) as f64 / (f1 - f0) as f64;
                let lerp = |a: DVec3, b: DVec3| a * (1.0 - s) + b * s;
                (lerp(e0, e1), lerp(tgt(t0), tgt(t1)))
            }
        };
        Camera::new(eye, target, base.up, base.projection)
    }
}

/// Piecewise-linear interpolation of evenly spaced samples at `t` in [0, 1].
/// Exact at the samples.
#[must_use]
pub fn interpolate(values: &[f64], t: f64) -> f64 {
    match values.len() {
        0 => 0.0,
        1 => values[0],
        n => {
            let s = t.clamp(0.0, 1.0) * (n - 1) as f64;
            let i = (s.floor() as usize).min(n - 2);
            let u = s - i as f64;
            (1.0 - u) * values[i] + u * values[i + 1]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::spec::CameraKey;
    use hiddenline::camera::Projection;

    fn spec(frames: usize) -> AnimationSpec {
        AnimationSpec { frames, from: None, to: None, columns: None, camera: Vec::new() }
    }

    #[test]
    fn between_two_columns_is_exact_at_both_ends() {
        let a = Animation::from_spec(&AnimationSpec { from: Some("a".into()), to: Some("b".into()), ..spec(7) }).unwrap();
        assert_eq!(a.columns("value"), vec!["a", "b"]);
        let v = [0.1, 0.7];
        assert_eq!(a.value(&v, 0), 0.1);
        assert_eq!(a.value(&v, 6), 0.7);
        assert!((a.value(&v, 3) - 0.4).abs() < 1e-15);
        assert_eq!(a.value(&v, 100), 0.7, "frames past the end hold");
    }

    #[test]
    fn one_column_per_step() {
        let cols = vec!["y1".to_string(), "y2".into(), "y3".into()];
        let a = Animation::from_spec(&AnimationSpec { columns: Some(cols.clone()), ..spec(5) }).unwrap();
        assert_eq!(a.columns("value"), cols);
        let v = [1.0, 3.0, 2.0];
        let got: Vec<f64> = (0..5).map(|f| a.value(&v, f)).collect();
        assert_eq!(got, vec![1.0, 2.0, 3.0, 2.5, 2.0]);
        assert_eq!(interpolate(&[4.0], 0.3), 4.0);
        let single = Animation::from_spec(&spec(1)).unwrap();
        assert_eq!(single.time(0), 0.0);
        assert_eq!(single.columns("v"), vec!["v"]);
    }

    #[test]
    fn camera_moves_along_keys() {
        let base = Camera::new(DVec3::new(0.0, -10.0, 5.0), DVec3::ZERO, DVec3::Z, Projection::Perspective { fov_deg: 30.0 }).unwrap();
        let keys = vec![
            CameraKey { frame: 2, eye: [10.0, 0.0, 5.0], target: None },
            CameraKey { frame: 6, eye: [0.0, 10.0, 5.0], target: Some([0.0, 0.0, 2.0]) },
        ];
        let a = Animation::from_spec(&AnimationSpec { camera: keys, ..spec(9) }).unwrap();
        assert_eq!(a.camera(0, &base).unwrap().eye, DVec3::new(10.0, 0.0, 5.0));
        let mid = a.camera(4, &base).unwrap();
        assert_eq!(mid.eye, DVec3::new(5.0, 5.0, 5.0));
        assert_eq!(mid.target, DVec3::new(0.0, 0.0, 1.0));
        assert_eq!(a.camera(8, &base).unwrap().eye, DVec3::new(0.0, 10.0, 5.0));
        assert_eq!(Animation::from_spec(&spec(3)).unwrap().camera(1, &base).unwrap(), base);
    }

    #[test]
    fn bad_animation_tables() {
        let cases: Vec<(AnimationSpec, &str)> = vec![
            (spec(0), "frames"),
            (AnimationSpec { from: Some("a".into()), ..spec(3) }, "`from` needs a `to`"),
            (AnimationSpec { to: Some("a".into()), ..spec(3) }, "`to` needs a `from`"),
            (AnimationSpec { columns: Some(vec![]), ..spec(3) }, "at least one"),
            (AnimationSpec { from: Some("a".into()), to: Some("b".into()), columns: Some(vec!["c".into()]), ..spec(3) }, "not both"),
            (AnimationSpec { camera: vec![CameraKey { frame: 3, eye: [1.0; 3], target: None }], ..spec(3) }, "past the last"),
            (
                AnimationSpec {
                    camera: vec![CameraKey { frame: 1, eye: [1.0; 3], target: None }, CameraKey { frame: 1, eye: [2.0; 3], target: None }],
                    ..spec(3)
                },
                "strictly increase",
            ),
            (AnimationSpec { camera: vec![CameraKey { frame: 0, eye: [f64::NAN, 0.0, 0.0], target: None }], ..spec(3) }, "finite"),
        ];
        for (s, want) in cases {
            let e = Animation::from_spec(&s).unwrap_err().to_string();
            assert!(e.contains(want), "{e} should mention {want}");
        }
    }
}
