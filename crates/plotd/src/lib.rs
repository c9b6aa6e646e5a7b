//! The plotd driver: dry-run renderer, spooling daemon and its client.
//!
//! One binary, `plotd`, with subcommands; this library holds everything so that
//! `main` stays a thin shell and tests can drive each piece directly.
//!
//! The daemon's pieces, in the order a job meets them:
//! - [`protocol`]: newline-delimited JSON over a Unix socket;
//! - [`spool`]: the crash-safe job store and job states;
//! - `plotcode::Program`: a job's device commands cut into per-stroke chunks
//!   (a checkpoint is an index into them), made by `plotcode`;
//! - [`job`]: the job's life, as a state machine that does no I/O;
//! - [`stream`]: the serial port and the flow-control handshakes;
//! - [`daemon`]: `serve(config, shutdown)`, one task per plotter, carrying
//!   out what the job's life decides;
//! - [`worker`]: checks and renders of jobs, in a child process under a
//!   budget ([`job_check`]: the limits they are held to; [`convert`]: a
//!   job's content to device commands);
//! - [`client`]: the `submit`/`jobs`/`status`/... commands.
//!
//! The command line is [`cli`] (clap); [`render`] is the dry run `plotd render
//! SCENE -o OUT`. [`pipeline`] is the one path from a scene to ordered
//! strokes, shared by the dry run and the daemon.
#![deny(missing_docs)]

pub mod cli;
pub mod client;
pub mod commands;
pub mod config;
pub mod console;
pub mod convert;
pub mod daemon;
#[cfg(feature = "demo")]
pub mod demo;
pub mod dryrun;
pub mod frames;
pub mod ink;
pub mod job;
pub mod job_check;
pub mod logging;
pub mod pen_map;
pub mod pen_table;
pub mod pipeline;
pub mod protocol;
pub mod render;
pub mod shell_docs;
pub mod spool;
pub mod stream;
pub mod text;
pub mod trusted_path;
pub mod worker;
pub mod written;
