//! The plotd driver: dry-run renderer, spooling daemon and its client.
//!
//! One binary, `plotd`, with subcommands; this library holds everything so that
//! `main` stays a thin shell and tests can drive each piece directly.
#![deny(missing_docs)]
