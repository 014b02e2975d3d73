//! The worker's defences at the connection level, in front of the gRPC server: a
//! client that opens sockets and sends nothing (or too little) must not exhaust the
//! worker's file handles or lock a coordinator out.
//!
//! - Handshake timeout: a connection is handed to the gRPC server only once its first
//!   bytes arrive (an HTTP/2 client sends its preface at once, a TLS client its hello);
//!   one silent for `handshake_timeout` is closed.
//! - Pending cap: at most `max_pending` connections wait for their first bytes; when
//!   the list is full the oldest waiting one is closed to make room, so a flood of
//!   silent sockets cannot keep a real client (which speaks within milliseconds) out.
//! - Connection caps: at most `max_connections` established connections, and
//!   `max_per_caller` from one IP address; a connection over a cap is closed at once.
//! - Established connections that go silent are found by HTTP/2 keepalive pings (set
//!   on the server in `grpc_service::serve`), so half-open sockets do not live forever.
//!
//! Every refusal is logged with the caller's address and the reason. Written here: no
//! crate offers an accept loop with these rules for tonic's `serve_with_incoming`.

use std::collections::{HashMap, VecDeque};
use std::net::{IpAddr, SocketAddr};
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tonic::transport::server::{Connected, TcpConnectInfo};

/// Connection limits of a worker.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    pub handshake_timeout: Duration,
    pub max_pending: usize,
    pub max_connections: usize,
    pub max_per_caller: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits { handshake_timeout: Duration::from_secs(10), max_pending: 256, max_connections: 256, max_per_caller: 64 }
    }
}

#[derive(Default)]
struct State {
    established: usize,
    per_caller: HashMap<IpAddr, usize>,
    /// Connections waiting for their first bytes, oldest first: (id, how to close it).
    pending: VecDeque<(u64, tokio::sync::oneshot::Sender<()>)>,
    next_id: u64,
}

type Shared = Arc<Mutex<State>>;

fn lock(s: &Shared) -> std::sync::MutexGuard<'_, State> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// An established connection; its slot is given back when the server drops it.
pub struct Guarded {
    stream: TcpStream,
    state: Shared,
    ip: IpAddr,
}

impl Drop for Guarded {
    fn drop(&mut self) {
        let mut s = lock(&self.state);
        s.established = s.established.saturating_sub(1);
        if let Some(n) = s.per_caller.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                s.per_caller.remove(&self.ip);
            }
        }
    }
}

impl AsyncRead for Guarded {
    fn poll_read(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_read(cx, buf)
    }
}

impl AsyncWrite for Guarded {
    fn poll_write(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &[u8]) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write(cx, buf)
    }
    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_flush(cx)
    }
    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.stream).poll_shutdown(cx)
    }
    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        Pin::new(&mut self.stream).poll_write_vectored(cx, bufs)
    }
    fn is_write_vectored(&self) -> bool {
        self.stream.is_write_vectored()
    }
}

impl Connected for Guarded {
    type ConnectInfo = TcpConnectInfo;
    fn connect_info(&self) -> TcpConnectInfo {
        self.stream.connect_info()
    }
}

fn refused(caller: SocketAddr, reason: &'static str) {
    tracing::warn!(%caller, reason, "connection refused");
    ridgeline_ops::metrics::metrics().refused("connection", reason);
}

/// Accepts connections on `listener` under `limits`; yields those that may reach the
/// gRPC server.
pub fn incoming(listener: TcpListener, limits: Limits) -> tokio_stream::wrappers::ReceiverStream<std::io::Result<Guarded>> {
    let (tx, rx) = tokio::sync::mpsc::channel(64);
    let state: Shared = Arc::default();
    tokio::spawn(async move {
        loop {
            let (stream, caller) = match listener.accept().await {
                Ok(c) => c,
                Err(e) => {
                    // out of file handles and the like: wait for some to close
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            };
            if tx.is_closed() {
                break;
            }
            let _ = stream.set_nodelay(true);
            let (id, cancelled) = {
                let mut s = lock(&state);
                if s.pending.len() >= limits.max_pending.max(1) {
                    if let Some((_, close)) = s.pending.pop_front() {
                        let _ = close.send(());
                    }
                }
                let (close, cancelled) = tokio::sync::oneshot::channel();
                s.next_id += 1;
                let id = s.next_id;
                s.pending.push_back((id, close));
                (id, cancelled)
            };
            let (state, tx) = (state.clone(), tx.clone());
            tokio::spawn(async move {
                let mut first = [0u8; 1];
                let spoke = tokio::select! {
                    r = tokio::time::timeout(limits.handshake_timeout, stream.peek(&mut first)) => match r {
                        Ok(Ok(n)) if n > 0 => Ok(()),
                        Ok(_) => Err(None), // closed by the caller, or a socket error
                        Err(_) => Err(Some("nothing received within the handshake timeout")),
                    },
                    _ = cancelled => Err(Some("evicted: too many connections waiting for their first bytes")),
                };
                let admitted = {
                    let mut s = lock(&state);
                    s.pending.retain(|(i, _)| *i != id);
                    match spoke {
                        Err(Some(reason)) => Err(reason),
                        Err(None) => return,
                        Ok(()) if s.established >= limits.max_connections => Err("too many connections"),
                        Ok(()) if s.per_caller.get(&caller.ip()).copied().unwrap_or(0) >= limits.max_per_caller => {
                            Err("too many connections from this caller")
                        }
                        Ok(()) => {
                            s.established += 1;
                            *s.per_caller.entry(caller.ip()).or_default() += 1;
                            Ok(())
                        }
                    }
                };
                match admitted {
                    Ok(()) => {
                        let _ = tx.send(Ok(Guarded { stream, state, ip: caller.ip() })).await;
                    }
                    Err(reason) => refused(caller, reason),
                }
            });
        }
    });
    tokio_stream::wrappers::ReceiverStream::new(rx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::AsyncReadExt;
    use tokio_stream::StreamExt;

    async fn closed_by_server(c: &mut TcpStream) -> bool {
        let mut b = [0u8; 8];
        matches!(tokio::time::timeout(Duration::from_secs(5), c.read(&mut b)).await, Ok(Ok(0)) | Ok(Err(_)))
    }

    #[tokio::test]
    async fn silent_sockets_are_closed_and_cannot_keep_a_speaking_client_out() {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let limits =
            Limits { handshake_timeout: Duration::from_millis(300), max_pending: 8, max_connections: 4, max_per_caller: 3 };
        let mut admitted = incoming(listener, limits);
        // a flood of silent sockets, more than may wait
        let mut silent = Vec::new();
        for _ in 0..20 {
            silent.push(TcpStream::connect(addr).await.unwrap());
        }
        // a client that speaks still gets in
        let mut speaker = TcpStream::connect(addr).await.unwrap();
        tokio::io::AsyncWriteExt::write_all(&mut speaker, b"PRI * HTTP/2.0").await.unwrap();
        let first = tokio::time::timeout(Duration::from_secs(2), admitted.next()).await.expect("admitted in time");
        assert!(first.unwrap().is_ok());
        // the oldest silent ones were evicted at once, the rest after the timeout
        assert!(closed_by_server(&mut silent[0]).await);
        tokio::time::sleep(Duration::from_millis(500)).await;
        assert!(closed_by_server(&mut silent[19]).await);
        // per-caller cap: 3 established from this address (the speaker's ended when
        // its server side was dropped above), the 4th is closed
        let (mut held, mut clients) = (Vec::new(), Vec::new());
        for _ in 0..3 {
            let mut c = TcpStream::connect(addr).await.unwrap();
            tokio::io::AsyncWriteExt::write_all(&mut c, b"x").await.unwrap();
            held.push(admitted.next().await.unwrap().unwrap());
            clients.push(c);
        }
        let mut over = TcpStream::connect(addr).await.unwrap();
        tokio::io::AsyncWriteExt::write_all(&mut over, b"x").await.unwrap();
        assert!(closed_by_server(&mut over).await, "a 4th connection from one caller is refused");
        // a slot comes back when a connection ends
        drop(held.remove(0));
        let mut again = TcpStream::connect(addr).await.unwrap();
        tokio::io::AsyncWriteExt::write_all(&mut again, b"x").await.unwrap();
        assert!(tokio::time::timeout(Duration::from_secs(2), admitted.next()).await.is_ok());
    }
}
