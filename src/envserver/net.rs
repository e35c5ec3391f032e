//! env-server's connections: what one client may hold, and for how long.
//!
//! axum's own `serve` accepts every connection, never times out a client
//! that sends its headers a line a second, never closes one that stops
//! reading, and waits for every connection at shutdown. This loop owns the
//! sockets instead (hyper's HTTP/1 connection, with upgrades for `/ws`):
//! - every accepted socket gets `TCP_NODELAY` (a client that pipelines two
//!   messages in one segment must not wait for its own delayed ACK);
//! - at most `max_connections` connections are served at once; past it the
//!   listener stops accepting until one closes (the kernel's backlog holds
//!   the rest);
//! - headers must arrive within `read_timeout` (hyper's header timer);
//!   bodies are read under the same deadline by the handlers;
//! - a connection whose client reads nothing of what is written to it for
//!   `stall_timeout` is closed ([`StallGuard`]), so a client that sends and
//!   never reads pins at most one reply, WebSocket or HTTP alike;
//! - on shutdown the listener closes, HTTP connections finish the request in
//!   hand, WebSocket sessions are told to close, and whatever is left after
//!   `shutdown_grace` is dropped.

use axum::Router;
use hyper_util::rt::{TokioExecutor, TokioIo, TokioTimer};
use hyper_util::server::conn::auto;
use hyper_util::service::TowerToHyperService;
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{Semaphore, watch};

/// What one server allows its connections.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NetLimits {
    pub max_connections: usize,
    pub read_timeout: Duration,
    pub stall_timeout: Duration,
    pub shutdown_grace: Duration,
}

/// hyper's read buffer per connection: a request line, headers and the
/// start of a body (the body itself is bounded by `--max-message-bytes`).
const READ_BUFFER_BYTES: usize = 64 * 1024;

/// A socket that fails a write which has made no progress for `limit`: the
/// client is not reading. Each write that moves bytes re-arms it.
pub(crate) struct StallGuard<T> {
    io: T,
    limit: Duration,
    stalled: Option<Pin<Box<tokio::time::Sleep>>>,
}

impl<T> StallGuard<T> {
    pub(crate) fn new(io: T, limit: Duration) -> StallGuard<T> {
        StallGuard { io, limit, stalled: None }
    }

    /// The write is pending: fail it once it has been pending for `limit`.
    fn pending<R>(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<R>> {
        let limit = self.limit;
        let timer = self.stalled.get_or_insert_with(|| Box::pin(tokio::time::sleep(limit)));
        match timer.as_mut().poll(cx) {
            Poll::Ready(()) => Poll::Ready(Err(io::Error::new(
                io::ErrorKind::TimedOut,
                format!("the client read nothing for {} s", limit.as_secs_f64()),
            ))),
            Poll::Pending => Poll::Pending,
        }
    }

    fn progressed<R>(&mut self, r: Poll<io::Result<R>>, cx: &mut Context<'_>) -> Poll<io::Result<R>> {
        match r {
            Poll::Ready(r) => {
                self.stalled = None;
                Poll::Ready(r)
            }
            Poll::Pending => self.pending(cx),
        }
    }
}

impl<T: AsyncRead + Unpin> AsyncRead for StallGuard<T> {
    fn poll_read(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.io).poll_read(cx, buf)
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for StallGuard<T> {
    fn poll_write(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &[u8]) -> Poll<io::Result<usize>> {
        let r = Pin::new(&mut self.io).poll_write(cx, buf);
        self.progressed(r, cx)
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = Pin::new(&mut self.io).poll_flush(cx);
        self.progressed(r, cx)
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let r = Pin::new(&mut self.io).poll_shutdown(cx);
        self.progressed(r, cx)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[io::IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        let r = Pin::new(&mut self.io).poll_write_vectored(cx, bufs);
        self.progressed(r, cx)
    }

    fn is_write_vectored(&self) -> bool {
        self.io.is_write_vectored()
    }
}

/// An accepted socket as every connection is served: `TCP_NODELAY` set.
pub(crate) fn configure(tcp: &TcpStream) -> io::Result<()> {
    tcp.set_nodelay(true)
}

/// Serve `router` on `listener` until `shutdown` resolves, then close as
/// described in the module doc. `stop` is told when shutdown begins (the
/// WebSocket sessions watch it); `sessions_open` says how many of them are
/// still running.
pub(crate) async fn serve(
    listener: TcpListener,
    router: Router,
    limits: NetLimits,
    shutdown: impl Future<Output = ()>,
    stop: watch::Sender<bool>,
    sessions_open: impl Fn() -> usize,
) -> io::Result<()> {
    let permits = Arc::new(Semaphore::new(limits.max_connections));
    let graceful = hyper_util::server::graceful::GracefulShutdown::new();
    let mut builder = auto::Builder::new(TokioExecutor::new()).http1_only();
    builder.http1().timer(TokioTimer::new()).header_read_timeout(limits.read_timeout).max_buf_size(READ_BUFFER_BYTES);
    let builder = Arc::new(builder);
    tokio::pin!(shutdown);
    loop {
        let permit = tokio::select! {
            permit = permits.clone().acquire_owned() => permit.expect("the semaphore is never closed"),
            () = &mut shutdown => break,
        };
        let tcp = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((tcp, _)) => tcp,
                // Out of file descriptors or a connection reset before it
                // was accepted: the listener itself is fine.
                Err(e) if is_transient(&e) => {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    continue;
                }
                Err(e) => return Err(e),
            },
            () = &mut shutdown => break,
        };
        if configure(&tcp).is_err() {
            continue;
        }
        let io = TokioIo::new(StallGuard::new(tcp, limits.stall_timeout));
        let service = TowerToHyperService::new(router.clone());
        let builder = builder.clone();
        let connection = graceful.watch(builder.serve_connection_with_upgrades(io, service).into_owned());
        tokio::spawn(async move {
            let _ = connection.await;
            drop(permit);
        });
    }
    drop(listener);
    let _ = stop.send(true);
    let deadline = tokio::time::Instant::now() + limits.shutdown_grace;
    let _ = tokio::time::timeout_at(deadline, graceful.shutdown()).await;
    while sessions_open() > 0 && tokio::time::Instant::now() < deadline {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    Ok(())
}

fn is_transient(e: &io::Error) -> bool {
    matches!(e.kind(), io::ErrorKind::ConnectionAborted | io::ErrorKind::ConnectionReset | io::ErrorKind::Interrupted)
        || e.raw_os_error().is_some_and(|code| code == 24 || code == 23) // EMFILE, ENFILE
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    #[tokio::test]
    async fn accepted_sockets_send_without_delay() {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let client = tokio::spawn(async move { TcpStream::connect(addr).await.unwrap() });
        let (tcp, _) = listener.accept().await.unwrap();
        assert!(!tcp.nodelay().unwrap(), "the default, which this must change");
        configure(&tcp).unwrap();
        assert!(tcp.nodelay().unwrap());
        drop(client.await.unwrap());
    }

    /// A peer that never reads fills the socket's buffers; the guard then
    /// fails the write instead of waiting for ever.
    #[tokio::test]
    async fn a_write_to_a_peer_that_never_reads_fails_after_the_stall_limit() {
        let (server, _client) = tokio::io::duplex(1024);
        let mut guarded = StallGuard::new(server, Duration::from_millis(50));
        let chunk = [7u8; 512];
        let mut written = 0usize;
        let error = loop {
            match guarded.write(&chunk).await {
                Ok(n) => written += n,
                Err(e) => break e,
            }
        };
        assert_eq!(error.kind(), io::ErrorKind::TimedOut);
        assert_eq!(written, 1024, "everything the buffer held was written first");
    }

    /// A peer that reads, however slowly, keeps the connection: each write
    /// that moves bytes re-arms the guard.
    #[tokio::test]
    async fn a_slow_reader_is_not_a_stalled_one() {
        let (server, mut client) = tokio::io::duplex(64);
        let mut guarded = StallGuard::new(server, Duration::from_millis(200));
        let reader = tokio::spawn(async move {
            let mut got = Vec::new();
            let mut buf = [0u8; 16];
            while got.len() < 1024 {
                tokio::time::sleep(Duration::from_millis(5)).await;
                let n = client.read(&mut buf).await.unwrap();
                got.extend_from_slice(&buf[..n]);
            }
            got.len()
        });
        guarded.write_all(&[1u8; 1024]).await.unwrap();
        assert_eq!(reader.await.unwrap(), 1024);
    }
}
