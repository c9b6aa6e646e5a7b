//! Noticing a host opening the port, for boards that reset when it opens
//! ([`crate::Quirk::ResetOnOpen`]).
//!
//! On a real port, opening it raises DTR, and an Arduino's DTR line is wired
//! to its reset. A pty has no DTR, and plotsim holds the slave open itself,
//! so the master never sees a host come or go; inotify reports each open of
//! the slave's device node instead (a failed open, such as one refused by a
//! host's exclusive lock, reports nothing). Every open counts, even one made
//! while another host holds the port, which raises no DTR edge on real
//! hardware; hosts open plotters' ports exclusively, so that does not arise.

use crate::SimError;
use nix::sys::inotify::{AddWatchFlags, InitFlags, Inotify, WatchDescriptor};
use std::os::fd::{AsFd, BorrowedFd};
use std::path::Path;

/// Open events of the current pty slave.
pub(crate) struct OpenWatch {
    inotify: Inotify,
    /// The watch on the current slave; the one on a slave closed by an
    /// unplug went away with its device node.
    watch: Option<WatchDescriptor>,
}

fn failed(source: nix::Error) -> SimError {
    SimError::Pty { what: "inotify", source }
}

impl OpenWatch {
    /// Watches `slave` for opens.
    pub fn new(slave: &Path) -> Result<OpenWatch, SimError> {
        let inotify = Inotify::init(InitFlags::IN_NONBLOCK | InitFlags::IN_CLOEXEC).map_err(failed)?;
        let mut w = OpenWatch { inotify, watch: None };
        w.watch(slave)?;
        Ok(w)
    }

    /// Watches a new slave (after a replug) instead of the old one.
    pub fn watch(&mut self, slave: &Path) -> Result<(), SimError> {
        if let Some(old) = self.watch.take() {
            // Already gone with its device node, usually.
            let _ = self.inotify.rm_watch(old);
        }
        self.watch = Some(self.inotify.add_watch(slave, AddWatchFlags::IN_OPEN).map_err(failed)?);
        Ok(())
    }

    /// Whether the slave was opened since the last call (reads the events).
    pub fn opened(&mut self) -> bool {
        let mut opened = false;
        while let Ok(events) = self.inotify.read_events() {
            opened |= events.iter().any(|e| Some(e.wd) == self.watch && e.mask.contains(AddWatchFlags::IN_OPEN));
            if events.is_empty() {
                break;
            }
        }
        opened
    }

    /// For the simulator thread's poll.
    pub fn fd(&self) -> BorrowedFd<'_> {
        self.inotify.as_fd()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pty::Pty;

    #[test]
    fn each_open_of_the_slave_is_seen_once() {
        let pty = Pty::open().unwrap();
        let mut w = OpenWatch::new(&pty.slave_path).unwrap();
        assert!(!w.opened(), "plotsim's own hold on the slave is not a host");
        let host = std::fs::File::options().read(true).write(true).open(&pty.slave_path).unwrap();
        assert!(w.opened());
        assert!(!w.opened());
        drop(host);
        assert!(!w.opened(), "closing is not opening");
        let again = Pty::open().unwrap();
        w.watch(&again.slave_path).unwrap();
        let _host = std::fs::File::options().read(true).write(true).open(&again.slave_path).unwrap();
        assert!(w.opened(), "the new slave after a replug");
    }
}
