//! The serial port as an async byte stream: a tty opened and configured by
//! the `serialport` crate (rate, 8N1, hardware flow lines, exclusive access),
//! then switched to non-blocking and driven by tokio's `AsyncFd`.
//!
//! Works the same on a USB serial adapter and on a pseudo-terminal (the
//! simulator). XON/XOFF is handled in user space by the streamer (the kernel's
//! own IXON stays off), RTS/CTS by the driver when asked for.

use crate::config::is_standard_rate;
use crate::protocol::{LinkCause, LinkFault};
use serialport::{DataBits, FlowControl, Parity, StopBits, TTYPort};
use std::io;
use std::os::fd::{AsRawFd, BorrowedFd};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a port cannot be opened, as a person acts on it.
#[derive(Debug, Error)]
pub enum OpenError {
    /// Its path does not exist: the adapter is unplugged, or the path is wrong.
    #[error("{}: no such file", .0.display())]
    Missing(PathBuf),
    /// Another opener holds it (its exclusive mark or lock).
    #[error("{}: held by another opener", .0.display())]
    Held(PathBuf),
    /// `port = "auto"` found no one EiBotBoard to open.
    #[error(transparent)]
    NoBoard(#[from] super::usb_ports::AutoPortError),
    /// `nickname = "..."` found no one EiBotBoard that answers it.
    #[error(transparent)]
    NoNamedBoard(#[from] super::usb_ports::NicknameError),
    /// Any other failure to open or set up the tty.
    #[error("{}: {source}", path.display())]
    Refused {
        /// The port.
        path: PathBuf,
        /// What the OS said.
        source: io::Error,
    },
}

impl OpenError {
    /// Why the plotter is offline; `holder`: the plotter of this daemon
    /// whose port names the same device, when one does.
    #[must_use]
    pub fn link_cause(&self, holder: Option<&str>) -> LinkCause {
        match (self, holder) {
            (OpenError::Missing(_) | OpenError::NoBoard(_) | OpenError::NoNamedBoard(_), _) => {
                LinkCause::new(LinkFault::NoSuchPort, self.to_string())
            }
            (OpenError::Held(_), Some(holder)) => LinkCause::new(LinkFault::PortHeld, format!("port held by plotter {holder:?}")),
            (OpenError::Held(_), None) => LinkCause::new(LinkFault::PortHeld, "port held by another program"),
            (OpenError::Refused { .. }, _) => LinkCause::new(LinkFault::CannotOpen, self.to_string()),
        }
    }
}
use std::pin::Pin;
use std::task::{ready, Context, Poll};
use tokio::io::unix::AsyncFd;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// An open serial port, held exclusively: no other program can open the
/// device while plotd streams to it (TIOCEXCL plus an exclusive flock).
#[derive(Debug)]
pub struct SerialPort {
    tty: AsyncFd<TTYPort>,
}

impl SerialPort {
    /// Opens `path` raw (8N1) at `baud`; `rtscts` turns on hardware flow control.
    ///
    /// # Errors
    /// [`OpenError::Missing`] when the path does not exist,
    /// [`OpenError::Held`] when another opener holds the port, else
    /// [`OpenError::Refused`] with the OS error (InvalidInput for a rate
    /// that is not standard, Other when the path is not a tty).
    pub fn open(path: &Path, baud: u32, rtscts: bool) -> Result<SerialPort, OpenError> {
        let refused = |source| OpenError::Refused { path: path.to_owned(), source };
        if !is_standard_rate(baud) {
            return Err(refused(io::Error::new(io::ErrorKind::InvalidInput, format!("{baud} is not a standard line rate"))));
        }
        // serialport tells a missing path and a held port by one kind.
        match SerialPort::open_tty(path, baud, rtscts) {
            Err(_) if !path.exists() => Err(OpenError::Missing(path.to_owned())),
            Err(e) if e.kind() == io::ErrorKind::NotFound => Err(OpenError::Held(path.to_owned())),
            r => r.map_err(refused),
        }
    }

    fn open_tty(path: &Path, baud: u32, rtscts: bool) -> io::Result<SerialPort> {
        let flow = if rtscts { FlowControl::Hardware } else { FlowControl::None };
        let tty = serialport::new(path.to_string_lossy(), baud)
            .data_bits(DataBits::Eight)
            .parity(Parity::None)
            .stop_bits(StopBits::One)
            .flow_control(flow)
            .exclusive(true)
            .open_native()?;
        // serialport leaves the descriptor blocking, for its own timed reads;
        // the async loop needs it non-blocking.
        let fd = tty.as_raw_fd();
        // SAFETY: `tty` owns `fd` and outlives this borrow.
        let borrowed = unsafe { BorrowedFd::borrow_raw(fd) };
        let flags = nix::fcntl::fcntl(borrowed.as_raw_fd(), nix::fcntl::FcntlArg::F_GETFL).map_err(io::Error::from)?;
        let flags = nix::fcntl::OFlag::from_bits_truncate(flags) | nix::fcntl::OFlag::O_NONBLOCK;
        nix::fcntl::fcntl(borrowed.as_raw_fd(), nix::fcntl::FcntlArg::F_SETFL(flags)).map_err(io::Error::from)?;
        // Stale bytes from before we opened are not answers to our queries.
        serialport::SerialPort::clear(&tty, serialport::ClearBuffer::All)?;
        // SAFETY: the TTYPort owns its descriptor and keeps it open, unchanged,
        // for as long as the AsyncFd holds it.
        let tty = unsafe { AsyncFd::register(tty) }.map_err(io::Error::from)?;
        Ok(SerialPort { tty })
    }

    fn fd(&self) -> BorrowedFd<'_> {
        // SAFETY: the TTYPort inside the AsyncFd owns the descriptor for as
        // long as `self` lives.
        unsafe { BorrowedFd::borrow_raw(self.tty.get_ref().as_raw_fd()) }
    }
}

impl AsyncRead for SerialPort {
    fn poll_read(self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<io::Result<()>> {
        loop {
            let mut guard = ready!(self.tty.poll_read_ready(cx))?;
            let unfilled = buf.initialize_unfilled();
            match guard.try_io(|_| nix::unistd::read(self.fd().as_raw_fd(), unfilled).map_err(io::Error::from)) {
                Ok(Ok(n)) => {
                    buf.advance(n);
                    return Poll::Ready(Ok(()));
                }
                Ok(Err(e)) => return Poll::Ready(Err(e)),
                Err(_would_block) => continue,
            }
        }
    }
}

impl AsyncWrite for SerialPort {
    fn poll_write(self: Pin<&mut Self>, cx: &mut Context<'_>, data: &[u8]) -> Poll<io::Result<usize>> {
        loop {
            let mut guard = ready!(self.tty.poll_write_ready(cx))?;
            match guard.try_io(|_| nix::unistd::write(self.fd(), data).map_err(io::Error::from)) {
                Ok(r) => return Poll::Ready(r),
                Err(_would_block) => continue,
            }
        }
    }
    fn poll_flush(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(Ok(()))
    }
    fn poll_shutdown(self: Pin<&mut Self>, _cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Poll::Ready(Ok(()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// A pty whose other end the test keeps open, as the simulator does.
    fn pty() -> (std::fs::File, std::path::PathBuf) {
        let (master, _slave, path) = pty_held();
        (master, path)
    }

    /// A pty and a second descriptor on its device side, held open meanwhile.
    fn pty_held() -> (std::fs::File, std::os::fd::OwnedFd, std::path::PathBuf) {
        let pair = nix::pty::openpty(None, None).expect("openpty");
        let path = nix::unistd::ttyname(&pair.slave).expect("ttyname");
        (std::fs::File::from(pair.master), pair.slave, path)
    }

    nix::ioctl_read_bad!(tiocgexcl, nix::libc::TIOCGEXCL, nix::libc::c_int);

    fn marked_exclusive(fd: &std::os::fd::OwnedFd) -> bool {
        let mut v: nix::libc::c_int = 0;
        // SAFETY: TIOCGEXCL writes one int through the pointer.
        unsafe { tiocgexcl(fd.as_raw_fd(), &mut v) }.expect("TIOCGEXCL");
        v != 0
    }

    #[tokio::test]
    async fn the_port_is_ours_alone_until_we_drop_it() {
        let (_master, held, path) = pty_held();
        let first = SerialPort::open(&path, 9600, false).expect("first open");
        assert!(marked_exclusive(&held));
        drop(first);
        // Another descriptor still holds the tty: the mark must not outlive
        // our descriptor (the kernel clears it when we close), or our next
        // open would fail unless we run as root, which tests may: so the
        // mark is checked directly.
        assert!(!marked_exclusive(&held), "TIOCEXCL left on the tty after the port was dropped");
        let again = SerialPort::open(&path, 9600, false).expect("reopen after drop");
        let refused = SerialPort::open(&path, 9600, false).expect_err("a second opener is refused while we hold the port");
        assert!(matches!(refused, OpenError::Held(_)), "{refused}");
        assert_eq!(refused.link_cause(None).message, "port held by another program");
        assert_eq!(refused.link_cause(Some("b")).message, "port held by plotter \"b\"");
        drop(again);
    }

    #[tokio::test]
    async fn bytes_pass_both_ways_raw() {
        let (master, path) = pty();
        let mut port = SerialPort::open(&path, 9600, false).expect("open");
        let mut master = tokio::fs::File::from_std(master);
        // Raw: no CR/LF translation, no XON/XOFF swallowed, no echo.
        port.write_all(b"PU;\r\n\x11\x13").await.unwrap();
        let mut got = [0u8; 7];
        master.read_exact(&mut got).await.unwrap();
        assert_eq!(&got, b"PU;\r\n\x11\x13");
        master.write_all(b"ok\r\n\x13").await.unwrap();
        let mut back = [0u8; 5];
        port.read_exact(&mut back).await.unwrap();
        assert_eq!(&back, b"ok\r\n\x13");
    }

    /// Issue 36: a port path that does not exist said only "(offline)".
    #[test]
    fn a_missing_port_is_told_by_its_path() {
        let err = SerialPort::open(Path::new("/nonexistent/ttyUSB0"), 9600, false).unwrap_err();
        assert!(matches!(err, OpenError::Missing(_)), "{err}");
        let cause = err.link_cause(None);
        assert_eq!((cause.kind, cause.message.as_str()), (LinkFault::NoSuchPort, "/nonexistent/ttyUSB0: no such file"));
    }

    #[test]
    fn a_rate_that_is_not_standard_is_refused_before_opening() {
        let err = SerialPort::open(Path::new("/nonexistent/tty"), 9601, false).unwrap_err();
        assert!(matches!(&err, OpenError::Refused { source, .. } if source.kind() == io::ErrorKind::InvalidInput), "{err}");
        assert!(is_standard_rate(115_200) && !is_standard_rate(0));
    }
}
