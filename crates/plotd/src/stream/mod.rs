//! Streaming a job's chunks to a device with flow control, and confirming
//! which chunks the device has executed.
//!
//! - `port.rs`: the serial port (transport);
//! - `error.rs`: why streaming stopped short; `run.rs`: what a run is
//!   asked and how it ends;
//! - `link.rs`: bytes out, answer lines in, with deadlines;
//! - `plan.rs`: what a run streams ([`Span`]) and its bytes;
//! - `machine.rs`: what every exchange with the device is, as a state
//!   machine that does no I/O; the handshakes `hpgl.rs` and `grbl.rs`,
//!   with the checkpoint rule: a chunk is confirmed only when the device
//!   says it has got past it; the exchanges around runs: `ping.rs`,
//!   `grbl_setup.rs` (sync; an alarm
//!   unlocked or homed only as a person said), `hpgl_locate.rs`,
//!   `grbl_locate.rs` and `ebb_locate.rs` (where the pen rests after an
//!   interruption), and
//!   `locate.rs` (which chunk that place says to resume from);
//! - `streamer.rs`: the one loop that feeds a machine from the link;
//!   `settings.rs`: its tuning and measurements;
//! - `usb_ports.rs`: the USB serial ports sysfs lists, and the one
//!   EiBotBoard among them for `port = "auto"` or `nickname = "..."`
//!   (asked its name by `ebb_nickname.rs`).
//!
//! Every byte sent to the device or read from it is plotcode's: the job's
//! chunks, the operations and markers of [`plotcode::control`], the answers
//! of [`plotcode::answer`]. The machines say when to send what, and what an
//! answer means.

mod ebb;
mod ebb_locate;
mod ebb_nickname;
mod error;
mod grbl;
mod grbl_locate;
mod grbl_setup;
mod hpgl;
mod hpgl_locate;
pub mod link;
mod locate;
mod machine;
mod ping;
mod plan;
pub mod port;
mod run;
mod settings;
pub mod streamer;
pub mod usb_ports;

pub use crate::written::Written;
pub use error::{Alarm, DeviceError, ErrorAt, Excerpt, Garbled, Reset, StreamError, Unanswered};
pub use hpgl::HpglCapabilities;
pub use link::Link;
pub use plan::Span;
pub use port::{OpenError, SerialPort};
pub use run::{Hold, Outcome, Restore, Stop};
pub use settings::{StreamSettings, StreamStats};
pub use streamer::{RunObserver, Streamer};
