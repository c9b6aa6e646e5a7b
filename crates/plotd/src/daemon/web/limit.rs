//! How many connections the page's server keeps, and for how long: at
//! most [`MAX_CONNECTIONS`] at once (one more is answered 503 and closed,
//! so a process that opens thousands can neither exhaust the daemon's
//! descriptors nor queue unanswered), each closed after [`IDLE`] without a
//! byte either way (a kept-alive connection nobody uses, or one that sends
//! half a request and stops). An event stream is never idle: it carries a
//! keep-alive comment well within [`IDLE`].

use axum::serve::Listener;
use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::time::{Instant, Sleep};

/// Connections served at once: many browsers' pages (each holds an event
/// stream and a request or two) in a plotter room, far below the
/// descriptors the daemon keeps for its spool and ports.
pub const MAX_CONNECTIONS: usize = 64;

/// A connection with no byte read or written for this long is closed.
pub const IDLE: Duration = Duration::from_secs(60);

/// The answer to a connection over [`MAX_CONNECTIONS`].
const BUSY: &[u8] = b"HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain\r\nConnection: close\r\nContent-Length: 59\r\n\r\ntoo many connections to the plotd page; try again shortly\r\n";

/// A TCP listener that keeps to the limits above.
pub struct Limited {
    listener: TcpListener,
    slots: Arc<Semaphore>,
}

impl Limited {
    /// Serves `listener` under [`MAX_CONNECTIONS`] and [`IDLE`].
    #[must_use]
    pub fn new(listener: TcpListener) -> Limited {
        Limited { listener, slots: Arc::new(Semaphore::new(MAX_CONNECTIONS)) }
    }
}

impl Listener for Limited {
    type Io = Connection;
    type Addr = SocketAddr;

    async fn accept(&mut self) -> (Connection, SocketAddr) {
        loop {
            let (mut stream, addr) = match self.listener.accept().await {
                Ok(accepted) => accepted,
                Err(e) => {
                    // Out of descriptors, most often: wait, then try again.
                    tracing::warn!(error = %e, "web page: accept failed; backing off");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            };
            match Arc::clone(&self.slots).try_acquire_owned() {
                Ok(slot) => {
                    let idle = Box::pin(tokio::time::sleep(IDLE));
                    return (Connection { stream, _slot: slot, idle }, addr);
                }
                Err(_) => {
                    tracing::debug!(%addr, "web page: {MAX_CONNECTIONS} connections open; refusing one");
                    // Answered, then the request read off (a second at
                    // most) before closing: closing on unread bytes would
                    // reset the connection, and the client lose the answer.
                    tokio::spawn(async move {
                        let _ = tokio::time::timeout(Duration::from_secs(1), async {
                            stream.write_all(BUSY).await?;
                            stream.shutdown().await?;
                            let mut sink = [0u8; 4096];
                            while stream.read(&mut sink).await? > 0 {}
                            Ok::<(), io::Error>(())
                        })
                        .await;
                    });
                }
            }
        }
    }

    fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }
}

/// One accepted connection, holding its place until dropped.
pub struct Connection {
    stream: TcpStream,
    _slot: OwnedSemaphorePermit,
    idle: Pin<Box<Sleep>>,
}

impl Connection {
    /// A byte went either way: idle from now.
    fn active(&mut self) {
        self.idle.as_mut().reset(Instant::now() + IDLE);
    }

    /// Whether the connection has been idle for [`IDLE`] (and so is ended).
    fn expired(&mut self, cx: &mut Context<'_>) -> bool {
        self.idle.as_mut().poll(cx).is_ready()
    }
}

impl AsyncRead for Connection {
    fn poll_read(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<io::Result<()>> {
        let before = buf.filled().len();
        match Pin::new(&mut self.stream).poll_read(cx, buf) {
            Poll::Ready(r) => {
                if buf.filled().len() > before {
                    self.active();
                }
                Poll::Ready(r)
            }
            Poll::Pending if self.expired(cx) => Poll::Ready(Err(io::Error::new(io::ErrorKind::TimedOut, "idle web connection"))),
            Poll::Pending => Poll::Pending,
        }
    }
}

impl AsyncWrite for Connection {
    fn poll_write(mut self: Pin<&mut Self>, cx: &mut Context<'_>, data: &[u8]) -> Poll<io::Result<usize>> {
        let written = Pin::new(&mut self.stream).poll_write(cx, data);
        if matches!(written, Poll::Ready(Ok(n)) if n > 0) {
            self.active();
        }
        written
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
}
