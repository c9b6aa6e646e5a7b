//! Map data readers never panic, whatever the bytes.

use proptest::prelude::*;
use scene::map::outline::{parse_csv, parse_geojson};
use scene::map::{Places, Projection};
use std::path::Path;

fn projections() -> impl Strategy<Value = Projection> {
    prop_oneof![Just(Projection::Planar), Just(Projection::Equirectangular), Just(Projection::Mercator)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn outline_readers_never_panic(text in "[-0-9.,e\\n#a-z \"{}\\[\\]:]{0,200}", p in projections()) {
        let _ = parse_csv(&text, Path::new("o.csv"), p);
        let _ = parse_geojson(&text, Path::new("o.geojson"), p);
    }

    #[test]
    fn geojson_shaped_input_never_panics(
        coords in proptest::collection::vec((-200.0f64..200.0, -100.0f64..100.0), 0..8),
        kind in prop_oneof![Just("LineString"), Just("Polygon"), Just("MultiLineString"), Just("MultiPolygon"), Just("Point")],
        p in projections(),
    ) {
        let pts: Vec<String> = coords.iter().map(|(x, y)| format!("[{x},{y}]")).collect();
        let ring = format!("[{}]", pts.join(","));
        for c in [ring.clone(), format!("[{ring}]"), format!("[[{ring}]]")] {
            let text = format!(r#"{{"type":"{kind}","coordinates":{c}}}"#);
            let _ = parse_geojson(&text, Path::new("o.geojson"), p);
        }
    }

    #[test]
    fn places_reader_never_panics(body in "[-0-9.,a-zA-Z\\n\" ]{0,200}") {
        let cols = vec!["value".to_string()];
        let _ = Places::parse(&format!("name,x,y,value\n{body}"), Path::new("p.csv"), &cols);
        let _ = Places::parse(&body, Path::new("p.csv"), &cols);
    }
}
