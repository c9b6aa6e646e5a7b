//! Helpers for the end-to-end tests in `tests/tests/`: a daemon and a virtual
//! plotter wired together over a real pseudo-terminal.
