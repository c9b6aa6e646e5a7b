//! The socket protocol: newline-delimited JSON, one request per line, one
//! reply per line (`watch` replies with a stream of event lines).
//!
//! The full description, with examples, is in `docs/protocol.md`. This module
//! holds the message types and the framing (bytes in, messages out, with
//! "incomplete" a normal outcome); `daemon/server.rs` owns the socket and its buffer.

use crate::spool::{CorruptRecord, JobId, JobKind, JobRecord};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A client's request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Request {
    /// Queue a job. The client sends the file's bytes; the daemon never opens
    /// paths named by a client.
    Submit {
        /// Content kind.
        kind: JobKind,
        /// Target plotter; `None`: the first configured one.
        #[serde(default)]
        plotter: Option<String>,
        /// Name for humans (usually the file name).
        #[serde(default)]
        name: Option<String>,
        /// The file's content.
        content: String,
        /// For a scene: every file it names (outlines, places, meshes, height
        /// tables), by the relative name written in the scene, content in
        /// base64 (standard alphabet, padded). The daemon renders the scene
        /// from these alone.
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
        files: BTreeMap<String, String>,
    },
    /// List jobs. (Braces, not a unit variant: serde lets a unit variant of
    /// a tagged enum ignore unknown fields, and a request with one must be
    /// refused, as every other request's is.)
    Jobs {},
    /// Daemon and plotter status.
    Status {},
    /// Cancel a job: a plotting one stops at the end of its stroke, or
    /// with `now` where the pen is.
    Cancel {
        /// The job.
        id: JobId,
        /// Stop the pen now (the device's buffer dropped, the pen lifted).
        #[serde(default, skip_serializing_if = "is_false")]
        now: bool,
    },
    /// Pause a job (`None`: every active job) at the next stroke boundary,
    /// or with `now` where the pen is (resume draws that stroke again).
    Pause {
        /// The job.
        #[serde(default)]
        id: Option<JobId>,
        /// Stop the pen now (the device's buffer dropped, the pen lifted).
        #[serde(default, skip_serializing_if = "is_false")]
        now: bool,
    },
    /// Resume a paused job (`None`: every paused job).
    Resume {
        /// The job.
        #[serde(default)]
        id: Option<JobId>,
    },
    /// The pen asked for has been inserted on `plotter` (`None`: every plotter).
    PenChanged {
        /// The plotter.
        #[serde(default)]
        plotter: Option<String>,
    },
    /// Stream progress events for one job (`None`: all jobs) until the client
    /// disconnects, or until that job ends.
    Watch {
        /// The job.
        #[serde(default)]
        id: Option<JobId>,
    },
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's signature
fn is_false(b: &bool) -> bool {
    !*b
}

/// What a job looks like to clients.
pub type JobInfo = JobRecord;

/// One plotter's status.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlotterInfo {
    /// Name from the config.
    pub name: String,
    /// Serial port path.
    pub port: String,
    /// Device profile.
    pub device: String,
    /// `online`, `offline` or `unknown` (not opened yet).
    pub link: String,
    /// The job it is working on.
    pub job: Option<JobId>,
}

/// The daemon's reply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "reply", rename_all = "kebab-case")]
pub enum Reply {
    /// The job is in the spool (durably) under this id.
    Submitted {
        /// The new job's id.
        id: JobId,
    },
    /// The job list.
    Jobs {
        /// Jobs by id.
        jobs: Vec<JobInfo>,
        /// Job records the daemon found unreadable at start, kept aside
        /// with their content (absent when there are none).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        corrupt: Vec<CorruptRecord>,
    },
    /// Daemon status.
    Status {
        /// Daemon version.
        version: String,
        /// Plotters.
        plotters: Vec<PlotterInfo>,
        /// Jobs not yet finished.
        active: Vec<JobInfo>,
    },
    /// The command was done.
    Ok {
        /// What was done.
        message: String,
    },
    /// The command failed; the connection stays usable.
    Error {
        /// What is wrong.
        message: String,
    },
    /// A progress event (replies to `watch`).
    Event(Event),
}

/// Progress of a job, sent to watchers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// The job.
    pub job: JobId,
    /// Its state now (`plotting`, `paused`, ...).
    pub state: String,
    /// Why it is paused or failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Strokes (chunks) the device has confirmed.
    pub strokes_done: usize,
    /// Strokes in the job, once known.
    pub strokes_total: Option<usize>,
    /// Bytes of the job the device has acknowledged.
    pub bytes_acked: u64,
    /// Estimated seconds left, from the plot-time model.
    pub eta_s: Option<f64>,
}

/// What [`decode_line`] found.
#[derive(Debug, PartialEq)]
pub enum Frame {
    /// A whole line was there: the request, or why it is not one.
    Line(Result<Request, String>),
    /// A line longer than the limit was dropped; the bytes up to its end are consumed.
    TooLong,
    /// No whole line yet.
    Incomplete,
}

/// Takes the first line off `buf` and decodes it. Lines longer than `limit`
/// are discarded from `buf`: `TooLong` is returned once their end is seen,
/// `Incomplete` while it is not (the caller keeps `*skipping` between calls).
pub fn decode_line(buf: &mut Vec<u8>, limit: usize, skipping: &mut bool) -> Frame {
    match buf.iter().position(|&b| b == b'\n') {
        Some(nl) => {
            let line: Vec<u8> = buf.drain(..=nl).collect();
            if std::mem::take(skipping) || nl > limit {
                return Frame::TooLong;
            }
            let line = &line[..nl];
            let line = line.strip_suffix(b"\r").unwrap_or(line);
            // serde quotes unknown names whole: cut the message (issue #20).
            Frame::Line(serde_json::from_slice(line).map_err(|e| format!("malformed request: {}", excerpt(&e.to_string()))))
        }
        None => {
            if buf.len() > limit {
                buf.clear();
                *skipping = true;
            }
            Frame::Incomplete
        }
    }
}

/// `text` cut to 200 characters and `...` when longer.
fn excerpt(text: &str) -> String {
    match text.char_indices().nth(200) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.to_owned(),
    }
}

/// A message as one protocol line.
#[must_use]
pub fn encode<T: Serialize>(msg: &T) -> Vec<u8> {
    let mut v = serde_json::to_vec(msg).expect("protocol messages serialise");
    v.push(b'\n');
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_round_trip() {
        let reqs = [
            Request::Submit { kind: JobKind::Hpgl, plotter: Some("hp".into()), name: None, content: "IN;".into(), files: BTreeMap::new() },
            Request::Submit {
                kind: JobKind::Scene,
                plotter: None,
                name: Some("map.toml".into()),
                content: "[camera]".into(),
                files: BTreeMap::from([("map/places.csv".into(), "bmFtZQ==".into())]),
            },
            Request::Jobs {},
            Request::Status {},
            Request::Cancel { id: 3, now: false },
            Request::Pause { id: None, now: true },
            Request::Resume { id: Some(2) },
            Request::PenChanged { plotter: None },
            Request::Watch { id: Some(1) },
        ];
        for r in reqs {
            let mut buf = encode(&r);
            let mut skip = false;
            assert_eq!(decode_line(&mut buf, 1 << 20, &mut skip), Frame::Line(Ok(r)));
            assert!(buf.is_empty());
        }
    }

    #[test]
    fn wire_names() {
        let line = br#"{"cmd":"pen-changed"}"#;
        assert_eq!(serde_json::from_slice::<Request>(line).unwrap(), Request::PenChanged { plotter: None });
        // Attachments are optional on the wire.
        let line = br#"{"cmd":"submit","kind":"scene","content":"x","files":{"a.csv":"eA=="}}"#;
        let Request::Submit { files, .. } = serde_json::from_slice::<Request>(line).unwrap() else { panic!() };
        assert_eq!(files["a.csv"], "eA==");
        // `now` is optional, and written only when set.
        let line = br#"{"cmd":"cancel","id":3}"#;
        assert_eq!(serde_json::from_slice::<Request>(line).unwrap(), Request::Cancel { id: 3, now: false });
        assert_eq!(
            serde_json::to_value(Request::Pause { id: None, now: true }).unwrap(),
            serde_json::json!({"cmd": "pause", "id": null, "now": true})
        );
        assert!(serde_json::from_slice::<Request>(br#"{"cmd":"pause","now":1}"#).is_err());
        let v = serde_json::to_value(Reply::Submitted { id: 4 }).unwrap();
        assert_eq!(v, serde_json::json!({"reply": "submitted", "id": 4}));
    }

    #[test]
    fn unknown_fields_are_refused_in_every_request() {
        for line in [
            r#"{"cmd":"jobs","x":1}"#,
            r#"{"cmd":"status","verbose":true}"#,
            r#"{"cmd":"cancel","id":1,"force":true}"#,
            r#"{"cmd":"pause","id":1,"soon":true}"#,
            r#"{"cmd":"watch","job":1}"#,
            r#"{"cmd":"submit","kind":"hpgl","content":"IN;","priority":9}"#,
        ] {
            let mut buf = format!("{line}\n").into_bytes();
            let Frame::Line(Err(e)) = decode_line(&mut buf, 1 << 10, &mut false) else { panic!("{line} was accepted") };
            assert!(e.contains("unknown field"), "{line}: {e}");
        }
    }

    #[test]
    fn malformed_and_incomplete() {
        let mut skip = false;
        let mut buf = b"{\"cmd\":\"jobs\"".to_vec();
        assert_eq!(decode_line(&mut buf, 100, &mut skip), Frame::Incomplete);
        buf.extend_from_slice(b"}\r\nnot json\n{\"cmd\":\"fly\"}\n");
        assert_eq!(decode_line(&mut buf, 100, &mut skip), Frame::Line(Ok(Request::Jobs {})));
        assert!(matches!(decode_line(&mut buf, 100, &mut skip), Frame::Line(Err(_))));
        let Frame::Line(Err(e)) = decode_line(&mut buf, 100, &mut skip) else { panic!() };
        assert!(e.contains("fly"), "{e}");
        assert_eq!(decode_line(&mut buf, 100, &mut skip), Frame::Incomplete);
    }

    #[test]
    fn oversized_line_is_skipped_then_reported() {
        let mut skip = false;
        let mut buf = vec![b'x'; 50];
        assert_eq!(decode_line(&mut buf, 10, &mut skip), Frame::Incomplete);
        assert!(buf.is_empty() && skip);
        buf.extend_from_slice(b"yyy\n{\"cmd\":\"status\"}\n");
        assert_eq!(decode_line(&mut buf, 10, &mut skip), Frame::TooLong);
        assert_eq!(decode_line(&mut buf, 100, &mut skip), Frame::Line(Ok(Request::Status {})));
        // Exactly at the limit with its newline in the same read.
        let mut buf = b"{\"cmd\":\"jobs\"}\n".to_vec();
        assert_eq!(decode_line(&mut buf, 5, &mut skip), Frame::TooLong);
        // Issue #20: serde quoted an unknown command whole; the reply is short.
        let mut buf = format!("{{\"cmd\":\"{}\"}}\n", "x".repeat(10_000)).into_bytes();
        let Frame::Line(Err(e)) = decode_line(&mut buf, 1 << 20, &mut skip) else { panic!() };
        assert!(e.len() < 300 && e.starts_with("malformed request: unknown variant `xxx"), "{e}");
    }
}
