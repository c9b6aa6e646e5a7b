//! The job's life as a state machine that does no I/O.
//!
//! [`JobLife`] holds every job's record and what each plotter is doing with
//! them. Everything that happens to a job comes in as a call: a job
//! submitted, a person's `cancel`, `pause`, `resume` or `pen-changed`, a
//! plotter that answered or not, the program rendered, the pen located, a
//! chunk confirmed, the device holding the job or going on, a span of chunks
//! streamed or failed (the link lost, the device reset), a record that could
//! not be saved, the time. What the daemon must do goes out as [`Action`]s,
//! in order: save a record and announce it, render, locate the pen, stream
//! chunks `from..until` (with the resume prefix, lifting the pen after),
//! stop a run, wake a plotter, reply to the person, end the run. The
//! results of the actions that do I/O come back as calls. So every rule of
//! a job's life is tested with scripted results and a clock moved by hand
//! (`tests.rs`), as the device exchanges are (`stream/machine.rs`).
//!
//! Its modules, each importing only those above it in this list:
//! - `error.rs`: the typed refusals ([`ControlError`], [`SubmitError`]);
//! - `action.rs`: the vocabulary: [`Action`], [`Step`], [`Save`],
//!   [`StopReason`];
//! - `position.rs`: a job whose device's position cannot be trusted:
//!   its pause, and what lets it go on;
//! - `ending.rs`: how a run ends: pause causes with their reasons, and the
//!   one mapping from a stream error;
//! - `recover.rs`: what a restart does to a job found in the spool;
//! - `run.rs`: one run's own state (the program and how far the device
//!   confirmed);
//! - `station.rs`: a plotter as the job's life sees it: its link, when to
//!   ask it again, the run it has;
//! - `life.rs`: [`JobLife`]: the records, saving before showing, and what
//!   each plotter does next ([`JobLife::poll`]);
//! - `control.rs`: [`JobLife`]'s submits and a person's requests;
//! - `claim.rs`: [`JobLife`] placing jobs for a class of plotters (`any`,
//!   or a device): which plotters a submit may go to ([`JobLife::admit`]),
//!   and the idle plotter that takes one;
//! - `sheet.rs`: [`JobLife`] keeping each plotter's sheet: a job waits for
//!   a fresh one, `sheet-loaded`; a job's copies, a sheet each;
//! - `park.rs`: where a one-pen plotter's head waits for a person's pen
//!   change;
//! - `plotting.rs`: [`JobLife`] running a job, from rendering to its end;
//! - `manual.rs`: [`JobLife`] taking a person's manual requests (pen,
//!   move, jog, frame): refused while a job plots, carried out between jobs.
//!
//! The drivers: `daemon/registry.rs` keeps the machine behind a lock and
//! carries out saves, removals, stops and wakes; `daemon/plotter.rs` is one
//! task per plotter, owning its port, that carries out probes, renders,
//! locates and spans.
//!
//! **A record change is saved before it is shown or announced** (a change
//! that cannot be saved is kept and shown all the same: the daemon acts on
//! it). **A checkpoint advances only when the device confirmed it.** **A
//! job whose checkpoint cannot be saved stops at the next stroke boundary**,
//! and goes on from the checkpoint in memory: nothing is streamed twice.
//! **A job the device holds is still its run's: `resume` refuses it.** **A
//! restart never moves the pen by itself.** **A device reset mid-job goes
//! on only once a person confirms the pen's position.** **A plotter takes a job only
//! just after it answered.**

mod action;
mod claim;
mod control;
mod ending;
mod error;
mod life;
mod manual;
mod park;
mod plotting;
mod position;
mod recover;
mod run;
mod sheet;
mod station;
#[cfg(test)]
mod tests;

pub use action::{Action, Manual, ManualWork, Progress, Removal, Save, Step, StopReason};
pub use claim::{class, Target, ANY};
pub use control::{NewJob, MAX_COPIES};
pub use error::{ControlError, SubmitError};
pub use life::JobLife;
pub use plotting::Rendered;
pub use recover::after_restart;
pub use run::PEN_CHANGE_S;
pub use station::{BACKOFF_MAX, BACKOFF_MIN, IDLE_CHECK};
