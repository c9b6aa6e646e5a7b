//! The serial port as an async byte stream: a tty opened non-blocking, put in
//! raw mode at the configured rate, driven by tokio's `AsyncFd`.
//!
//! Works the same on a USB serial adapter and on a pseudo-terminal (the
//! simulator). XON/XOFF is handled in user space by the streamer (the kernel's
//! own IXON is switched off), RTS/CTS by the driver when asked for.

use nix::fcntl::{open, OFlag};
use nix::sys::stat::Mode;
use nix::sys::termios::{self, BaudRate, ControlFlags, SetArg};
use std::io;
use std::os::fd::{AsRawFd, OwnedFd};
use std::path::Path;
use std::pin::Pin;
use std::task::{ready, Context, Poll};
use tokio::io::unix::AsyncFd;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};

/// The termios constant for a standard line rate.
#[must_use]
pub fn baud_rate(baud: u32) -> Option<BaudRate> {
    Some(match baud {
        300 => BaudRate::B300,
        600 => BaudRate::B600,
        1200 => BaudRate::B1200,
        2400 => BaudRate::B2400,
        4800 => BaudRate::B4800,
        9600 => BaudRate::B9600,
        19200 => BaudRate::B19200,
        38400 => BaudRate::B38400,
        57600 => BaudRate::B57600,
        115200 => BaudRate::B115200,
        230400 => BaudRate::B230400,
        _ => return None,
    })
}

/// An open serial port.
#[derive(Debug)]
pub struct SerialPort {
    fd: AsyncFd<OwnedFd>,
}

impl SerialPort {
    /// Opens `path` raw at `baud`; `rtscts` turns on hardware flow control.
    ///
    /// # Errors
    /// The OS error from opening or configuring the tty (ENOENT when the
    /// adapter is unplugged, ENOTTY when the path is not a tty).
    pub fn open(path: &Path, baud: u32, rtscts: bool) -> io::Result<SerialPort> {
        let rate = baud_rate(baud).ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "bad baud rate"))?;
        let fd: OwnedFd = open(path, OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_NONBLOCK | OFlag::O_CLOEXEC, Mode::empty())
            .map_err(io::Error::from)
            .map(|raw| {
                // SAFETY: `open` just returned this descriptor and nothing else owns it.
                unsafe { <OwnedFd as std::os::fd::FromRawFd>::from_raw_fd(raw) }
            })?;
        let mut t = termios::tcgetattr(&fd).map_err(io::Error::from)?;
        termios::cfmakeraw(&mut t);
        termios::cfsetspeed(&mut t, rate).map_err(io::Error::from)?;
        t.control_flags |= ControlFlags::CLOCAL | ControlFlags::CREAD;
        t.control_flags.set(ControlFlags::CRTSCTS, rtscts);
        t.input_flags.remove(termios::InputFlags::IXON | termios::InputFlags::IXOFF | termios::InputFlags::IXANY);
        termios::tcsetattr(&fd, SetArg::TCSANOW, &t).map_err(io::Error::from)?;
        // Stale bytes from before we opened are not answers to our queries.
        let _ = termios::tcflush(&fd, termios::FlushArg::TCIOFLUSH);
        // SAFETY: `fd` is an OwnedFd moved into the AsyncFd: it stays open and
        // the same descriptor for the AsyncFd's whole life.
        let fd = unsafe { AsyncFd::register(fd) }.map_err(io::Error::from)?;
        Ok(SerialPort { fd })
    }
}

impl AsyncRead for SerialPort {
    fn poll_read(self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<io::Result<()>> {
        loop {
            let mut guard = ready!(self.fd.poll_read_ready(cx))?;
            let unfilled = buf.initialize_unfilled();
            match guard.try_io(|fd| nix::unistd::read(fd.get_ref().as_raw_fd(), unfilled).map_err(io::Error::from)) {
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
            let mut guard = ready!(self.fd.poll_write_ready(cx))?;
            match guard.try_io(|fd| nix::unistd::write(fd.get_ref(), data).map_err(io::Error::from)) {
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
