//! A job's pen map (`submit --pens 1=3,2=1`): which of the plotter's pens
//! draws each pen the job names, so a drawing made for one carousel plots
//! with the pens another holds. A pen the map leaves out is drawn with its
//! own number. Read from the command line, checked against the plotter at
//! submit, kept in the job's record, and applied to the drawing before it
//! is emitted (scenes and SVG drawings: HP-GL and G-code are sent as
//! written, so a map for them is refused).

use plotcode::DeviceProfile;
use std::collections::BTreeMap;
use thiserror::Error;

/// Job pen -> plotter pen.
pub type PenMap = BTreeMap<u32, u32>;

/// Most pairs one map may hold: more than any carousel has pens.
pub const MAX_PAIRS: usize = 64;

/// Why a pen map cannot be used.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum PenMapError {
    /// A pair that is not `JOB=PLOTTER` with two pen numbers from 1.
    #[error("--pens: `{0}` is not JOB=PLOTTER with pens from 1 (such as 1=3)")]
    NotAPair(String),
    /// A job pen mapped twice.
    #[error("--pens: pen {0} is mapped twice")]
    Twice(u32),
    /// More pairs than [`MAX_PAIRS`].
    #[error("--pens: {0} pairs, at most {MAX_PAIRS}")]
    TooMany(usize),
    /// A pen the plotter does not have.
    #[error("--pens {from}={to}: the {device} has pens 1 to {pens}, no pen {to}")]
    NoSuchPen {
        /// The job's pen.
        from: u32,
        /// The plotter pen it was mapped to.
        to: u32,
        /// The plotter's device.
        device: String,
        /// How many pens it holds.
        pens: u32,
    },
    /// A map for command text, which is sent as written.
    #[error("--pens: {0} is sent as written; only scenes and SVG drawings have their pens mapped")]
    SentAsWritten(&'static str),
}

/// A map on the wire and in the spool: a list of `[job, plotter]` pairs
/// (JSON's keys are strings, and serde's tagged and flattened types read
/// no number from one). A request may give the command line's text
/// instead (`"1=3,2=1"`, what the web page's field holds), read by
/// [`parse`] with its errors.
pub mod as_pairs {
    use super::PenMap;
    use serde::de::{self, SeqAccess, Visitor};
    use serde::{Deserializer, Serialize, Serializer};

    /// Writes `map` as `[[1, 3], [2, 1]]`.
    ///
    /// # Errors
    /// The serializer's.
    pub fn serialize<S: Serializer>(map: &PenMap, s: S) -> Result<S::Ok, S::Error> {
        map.iter().map(|(&from, &to)| [from, to]).collect::<Vec<_>>().serialize(s)
    }

    /// Reads `[[1, 3], [2, 1]]`, or `"1=3,2=1"`.
    ///
    /// # Errors
    /// The deserializer's, or a pen mapped twice; for text, [`super::parse`]'s.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<PenMap, D::Error> {
        d.deserialize_any(PairsOrText)
    }

    struct PairsOrText;

    impl<'de> Visitor<'de> for PairsOrText {
        type Value = PenMap;

        fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("pairs [[job pen, plotter pen], ...] or text \"1=3,2=1\"")
        }

        fn visit_str<E: de::Error>(self, text: &str) -> Result<PenMap, E> {
            super::parse(text).map_err(|e| E::custom(e.to_string().replacen("--pens", "pens", 1)))
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<PenMap, A::Error> {
            let mut map = PenMap::new();
            while let Some([from, to]) = seq.next_element::<[u32; 2]>()? {
                if map.insert(from, to).is_some() {
                    return Err(de::Error::custom(format!("pens: pen {from} is mapped twice")));
                }
            }
            Ok(map)
        }
    }
}

/// Reads `1=3,2=1`.
///
/// # Errors
/// [`PenMapError`] naming the pair that is wrong.
pub fn parse(text: &str) -> Result<PenMap, PenMapError> {
    let mut map = PenMap::new();
    for pair in text.split(',').map(str::trim) {
        let pen = |s: &str| s.trim().parse::<u32>().ok().filter(|&p| p >= 1);
        let Some((from, to)) = pair.split_once('=').and_then(|(a, b)| Some((pen(a)?, pen(b)?))) else {
            return Err(PenMapError::NotAPair(pair.to_owned()));
        };
        if map.insert(from, to).is_some() {
            return Err(PenMapError::Twice(from));
        }
    }
    check_size(&map)?;
    Ok(map)
}

fn check_size(map: &PenMap) -> Result<(), PenMapError> {
    if map.len() > MAX_PAIRS {
        return Err(PenMapError::TooMany(map.len()));
    }
    Ok(())
}

/// Checks a map for a job in `language` (`Some`: command text in that
/// language, sent as written) for `device`: every pen it draws with is one
/// the device holds (a device with one pen takes any: a person puts in the
/// pen asked for).
///
/// # Errors
/// [`PenMapError::NoSuchPen`] naming the pair; [`PenMapError::TooMany`];
/// [`PenMapError::SentAsWritten`] for command text.
pub fn check(map: &PenMap, language: Option<&'static str>, device: &DeviceProfile) -> Result<(), PenMapError> {
    check_size(map)?;
    match language {
        _ if map.is_empty() => return Ok(()),
        Some(language) => return Err(PenMapError::SentAsWritten(language)),
        None => {}
    }
    if device.pens <= 1 {
        return Ok(());
    }
    match map.iter().find(|(_, &to)| to == 0 || to > device.pens) {
        Some((&from, &to)) => Err(PenMapError::NoSuchPen { from, to, device: device.name.clone(), pens: device.pens }),
        None => Ok(()),
    }
}

/// `drawing` with each layer's pen mapped.
#[must_use]
pub fn mapped(mut drawing: strokes::Drawing, map: &PenMap) -> strokes::Drawing {
    for layer in &mut drawing.layers {
        layer.pen = map.get(&layer.pen).copied().unwrap_or(layer.pen);
    }
    drawing
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_map_is_read_and_its_mistakes_named() {
        assert_eq!(parse("1=3, 2=1").unwrap(), PenMap::from([(1, 3), (2, 1)]));
        assert_eq!(parse("1=3,1=2").unwrap_err(), PenMapError::Twice(1));
        for bad in ["1", "1=", "a=2", "0=1", "1=0", "1=-2", ""] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains("is not JOB=PLOTTER"), "{bad}: {e}");
        }
        let long = (1..=65).map(|p| format!("{p}=1")).collect::<Vec<_>>().join(",");
        assert_eq!(parse(&long).unwrap_err(), PenMapError::TooMany(65));
    }

    /// A submit's `pens` on the wire: the pairs, or the command line's
    /// text (the web page's field), refused with the text's mistake named.
    #[test]
    fn a_submit_gives_its_map_as_pairs_or_as_the_command_lines_text() {
        use crate::protocol::Request;
        let pens = |value: serde_json::Value| {
            let line = serde_json::json!({"cmd": "submit", "kind": "svg", "content": "<svg/>", "pens": value});
            serde_json::from_value::<Request>(line).map(|r| match r {
                Request::Submit { pens, .. } => pens,
                other => panic!("{other:?}"),
            })
        };
        let want = PenMap::from([(1, 3), (2, 1)]);
        assert_eq!(pens(serde_json::json!([[1, 3], [2, 1]])).unwrap(), want);
        assert_eq!(pens(serde_json::json!(" 1=3, 2=1 ")).unwrap(), want);
        let e = pens(serde_json::json!("1=x")).unwrap_err().to_string();
        assert!(e.starts_with("pens: `1=x` is not JOB=PLOTTER"), "{e}");
        let e = pens(serde_json::json!("1=3,1=2")).unwrap_err().to_string();
        assert!(e.starts_with("pens: pen 1 is mapped twice"), "{e}");
        let e = pens(serde_json::json!([[1, 3], [1, 2]])).unwrap_err().to_string();
        assert!(e.starts_with("pens: pen 1 is mapped twice"), "{e}");
        assert!(pens(serde_json::json!(7)).is_err());
        // Written as pairs, always.
        let r = Request::Submit {
            kind: crate::spool::JobKind::Svg,
            plotter: None,
            name: None,
            content: String::new(),
            files: BTreeMap::new(),
            same_sheet: false,
            copies: 1,
            pens: want,
            occult: None,
        };
        assert_eq!(serde_json::to_value(r).unwrap()["pens"], serde_json::json!([[1, 3], [2, 1]]));
    }

    #[test]
    fn a_pen_the_carousel_lacks_is_refused_naming_it() {
        let hp = DeviceProfile::builtin("hp7475a").unwrap();
        assert!(check(&PenMap::from([(1, 6), (2, 1)]), None, &hp).is_ok());
        let e = check(&PenMap::from([(1, 3), (2, 7)]), None, &hp).unwrap_err().to_string();
        assert_eq!(e, "--pens 2=7: the hp7475a has pens 1 to 6, no pen 7");
        // One pen: a person puts in whichever is asked for.
        assert!(check(&PenMap::from([(1, 9)]), None, &DeviceProfile::builtin("grbl-servo").unwrap()).is_ok());
        // Command text is sent as written.
        let e = check(&PenMap::from([(1, 2)]), Some("HP-GL"), &hp).unwrap_err().to_string();
        assert!(e.contains("HP-GL is sent as written"), "{e}");
        assert!(check(&PenMap::new(), Some("HP-GL"), &hp).is_ok());
    }

    #[test]
    fn each_layer_is_drawn_with_its_mapped_pen() {
        let layer = |pen| strokes::Layer { pen, ..strokes::Layer::default() };
        let drawing = strokes::Drawing { layers: vec![layer(1), layer(2), layer(4)], ..strokes::Drawing::default() };
        let pens: Vec<u32> = mapped(drawing, &PenMap::from([(1, 3), (2, 1)])).layers.iter().map(|l| l.pen).collect();
        assert_eq!(pens, [3, 1, 4]);
    }
}
