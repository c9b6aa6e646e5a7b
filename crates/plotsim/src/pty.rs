//! The pseudo-terminal the simulated plotter sits on, and its `--link` symlink.
//!
//! What a pty can and cannot model: it carries bytes both ways and honours the
//! slave's termios (so a host that sets IXON on the slave gets kernel XON/XOFF
//! on its output), but it has no baud rate (a host's `write` returns as soon
//! as the kernel queues the bytes; plotsim paces its reading instead), no
//! modem-control lines (TIOCMGET/TIOCMSET fail: DTR/CTS are reported through
//! `ESC.O`/`ESC.B` and [`crate::Status::cts`]), and no framing or parity
//! errors. Closing the master hangs up the slave (reads return EOF/EIO), which
//! is how an unplugged USB adapter looks to the host.

use crate::SimError;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
use std::fs::File;
use std::os::fd::{AsFd, AsRawFd, OwnedFd, RawFd};
use std::path::{Path, PathBuf};

/// One pty pair. The slave end is held open so the master never sees EIO
/// while no host has the port open.
pub(crate) struct Pty {
    pub master: File,
    slave: OwnedFd,
    pub slave_path: PathBuf,
}

nix::ioctl_read_bad!(fionread, nix::libc::FIONREAD, nix::libc::c_int);

impl Pty {
    /// Opens a pair, raw mode on the slave, non-blocking master.
    pub fn open() -> Result<Pty, SimError> {
        let pty = nix::pty::openpty(None, None).map_err(|source| SimError::Pty { what: "openpty", source })?;
        let mut t = tcgetattr(pty.slave.as_fd()).map_err(|source| SimError::Pty { what: "tcgetattr", source })?;
        cfmakeraw(&mut t);
        tcsetattr(pty.slave.as_fd(), SetArg::TCSANOW, &t).map_err(|source| SimError::Pty { what: "tcsetattr", source })?;
        let flags = fcntl(pty.master.as_raw_fd(), FcntlArg::F_GETFL).map_err(|source| SimError::Pty { what: "fcntl", source })?;
        fcntl(pty.master.as_raw_fd(), FcntlArg::F_SETFL(OFlag::from_bits_truncate(flags) | OFlag::O_NONBLOCK))
            .map_err(|source| SimError::Pty { what: "fcntl", source })?;
        let slave_path = nix::unistd::ttyname(pty.slave.as_fd()).map_err(|source| SimError::Pty { what: "ttyname", source })?;
        Ok(Pty { master: File::from(pty.master), slave: pty.slave, slave_path })
    }

    /// Drops what plotsim sent that no host has read: on a real port, what
    /// a device says while the port is closed is lost.
    pub fn discard_unread(&self) {
        let _ = nix::sys::termios::tcflush(self.slave.as_fd(), nix::sys::termios::FlushArg::TCIFLUSH);
    }

    /// Bytes the host has written that plotsim has not read yet.
    pub fn pending(&self) -> usize {
        pending_on(self.master.as_raw_fd())
    }
}

/// Bytes waiting to be read on `fd`, a live pty master (0 if it cannot say).
pub(crate) fn pending_on(fd: RawFd) -> usize {
    let mut n: nix::libc::c_int = 0;
    // SAFETY: FIONREAD writes one c_int through the pointer we pass; the
    // caller keeps `fd` open for the call.
    match unsafe { fionread(fd, &mut n) } {
        Ok(_) => usize::try_from(n).unwrap_or(0),
        Err(_) => 0,
    }
}

/// Points `link` at `target`, replacing whatever link is there atomically
/// (a temporary link renamed over it), so a host never sees it missing
/// while it is being replaced.
pub(crate) fn make_link(link: &Path, target: &Path) -> Result<(), SimError> {
    let err = |source| SimError::Link { path: link.to_path_buf(), source };
    if let Ok(meta) = std::fs::symlink_metadata(link) {
        if !meta.file_type().is_symlink() {
            return Err(err(std::io::Error::new(std::io::ErrorKind::AlreadyExists, "exists and is not a symlink; refusing to replace it")));
        }
    }
    let mut tmp = link.as_os_str().to_owned();
    tmp.push(format!(".plotsim-{}", std::process::id()));
    let tmp = PathBuf::from(tmp);
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp).map_err(err)?;
    std::fs::rename(&tmp, link).map_err(err)
}

/// Removes `link` if it is a symlink (an unplugged adapter's device node goes away).
pub(crate) fn remove_link(link: &Path) {
    if std::fs::symlink_metadata(link).is_ok_and(|m| m.file_type().is_symlink()) {
        let _ = std::fs::remove_file(link);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    #[test]
    fn bytes_cross_the_pair_and_are_counted() {
        let mut pty = Pty::open().unwrap();
        let mut host = std::fs::OpenOptions::new().read(true).write(true).open(&pty.slave_path).unwrap();
        host.write_all(b"IN;").unwrap();
        // The kernel moves bytes to the master asynchronously; wait for them.
        let t0 = std::time::Instant::now();
        while pty.pending() < 3 && t0.elapsed() < std::time::Duration::from_secs(5) {
            std::thread::yield_now();
        }
        assert_eq!(pty.pending(), 3);
        let mut buf = [0u8; 8];
        assert_eq!(pty.master.read(&mut buf).unwrap(), 3);
        assert_eq!(&buf[..3], b"IN;");
        // Raw mode: CR is not translated on the way to the host.
        pty.master.write_all(b"1\r").unwrap();
        let mut got = [0u8; 2];
        host.read_exact(&mut got).unwrap();
        assert_eq!(&got, b"1\r");
    }

    #[test]
    fn link_is_replaced_not_duplicated_and_regular_files_are_kept() {
        let dir = std::env::temp_dir().join(format!("plotsim-link-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("ttyPLOT");
        make_link(&link, Path::new("/dev/null")).unwrap();
        make_link(&link, Path::new("/dev/zero")).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), Path::new("/dev/zero"));
        remove_link(&link);
        assert!(std::fs::symlink_metadata(&link).is_err());
        std::fs::write(&link, "x").unwrap();
        assert!(make_link(&link, Path::new("/dev/null")).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
