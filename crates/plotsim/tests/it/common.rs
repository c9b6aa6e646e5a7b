//! A host's end of the simulated serial port, for the link tests.
#![allow(dead_code)]

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::AsFd;
use std::path::Path;
use std::time::{Duration, Instant};

/// Generous limit for every wait: tests wait on device state, and this only
/// bounds a broken run.
pub const WAIT: Duration = Duration::from_secs(20);

pub struct Port {
    pub file: File,
    pub inbox: Vec<u8>,
}

impl Port {
    pub fn open(path: &Path) -> Port {
        let file = std::fs::OpenOptions::new().read(true).write(true).open(path).expect("open pty slave");
        Port { file, inbox: Vec::new() }
    }

    pub fn send(&mut self, bytes: &[u8]) {
        self.file.write_all(bytes).expect("write to pty");
    }

    /// Reads whatever is there within `wait` (returns early once something came).
    pub fn poll_in(&mut self, wait: Duration) -> Result<usize, std::io::Error> {
        let mut fds = [PollFd::new(self.file.as_fd(), PollFlags::POLLIN)];
        let t = PollTimeout::try_from(wait).unwrap_or(PollTimeout::MAX);
        let n = poll(&mut fds, t).map_err(std::io::Error::from)?;
        if n == 0 {
            return Ok(0);
        }
        let mut buf = [0u8; 4096];
        let got = self.file.read(&mut buf)?;
        if got == 0 {
            return Err(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "hung up"));
        }
        self.inbox.extend_from_slice(&buf[..got]);
        Ok(got)
    }

    /// The next reply up to and including `end`, without the terminator.
    pub fn read_until(&mut self, end: &[u8]) -> String {
        let t0 = Instant::now();
        loop {
            if let Some(i) = self.inbox.windows(end.len()).position(|w| w == end) {
                let line: Vec<u8> = self.inbox.drain(..i + end.len()).collect();
                return String::from_utf8_lossy(&line[..i]).into_owned();
            }
            assert!(t0.elapsed() < WAIT, "no reply ending {end:?}; have {:?}", String::from_utf8_lossy(&self.inbox));
            self.poll_in(Duration::from_millis(50)).expect("port alive");
        }
    }

    /// The next line, split on any CR or LF (an EBB ends lines `\r\n`, some
    /// `\n\r`, 3.0.2's future syntax `\n`), empty ones skipped.
    pub fn line(&mut self) -> String {
        let t0 = Instant::now();
        loop {
            if let Some(i) = self.inbox.iter().position(|&b| b == b'\r' || b == b'\n') {
                let l: Vec<u8> = self.inbox.drain(..=i).collect();
                if l.len() > 1 {
                    return String::from_utf8_lossy(&l[..l.len() - 1]).into_owned();
                }
                continue;
            }
            assert!(t0.elapsed() < WAIT, "no line; have {:?}", String::from_utf8_lossy(&self.inbox));
            self.poll_in(Duration::from_millis(50)).expect("port alive");
        }
    }

    /// Asks an HP plotter something with a device-control instruction or an
    /// output instruction and returns the answer.
    pub fn ask(&mut self, q: &[u8]) -> String {
        self.send(q);
        self.read_until(b"\r")
    }
}

/// A pen-down zigzag of `n` moves, each about `step` plotter units long,
/// 20 units apart along x (keep `n` under 500 to stay on A4).
pub fn hpgl_zigzag(n: usize, step: i32) -> Vec<u8> {
    let mut s = String::from("IN;SP1;PU0,0;PD");
    for i in 0..n {
        let x = (i as i32 + 1) * 20;
        let y = if i % 2 == 0 { step } else { 0 };
        s.push_str(&format!("{}{x},{y}", if i == 0 { "" } else { "," }));
    }
    s.push_str(";PU;");
    s.into_bytes()
}
