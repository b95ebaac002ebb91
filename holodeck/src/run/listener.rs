//! The TCP listener (tokio): accepts workers and displays on one port and tells them apart
//! by their hello; each connection runs as a task until it ends or the run stops.

use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use holocave_protocol::frame::{self, FrameError, MAX_FRAME_BYTES};
use holocave_protocol::holodeck::WorkerMsg;
use tokio::io::BufWriter;

use super::state::State;
use crate::display;

/// Why a connection ended badly.
#[derive(Debug, thiserror::Error)]
pub(crate) enum ConnError {
    #[error(transparent)]
    Frame(#[from] FrameError),
    #[error("{0}")]
    Protocol(String),
}

/// The runtime the connections run on (one thread).
pub(crate) fn runtime() -> std::io::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
}

/// Accepts connections on `listener` in `rt`; returns its address.
pub(crate) fn listen(
    rt: &tokio::runtime::Runtime,
    state: &Arc<State>,
    listener: TcpListener,
) -> Option<SocketAddr> {
    listener.set_nonblocking(true).ok();
    let addr = listener.local_addr().ok();
    let _guard = rt.enter();
    let listener = match tokio::net::TcpListener::from_std(listener) {
        Ok(l) => l,
        Err(e) => {
            tracing::warn!("cannot listen for workers and displays: {e}");
            return addr;
        }
    };
    let st = state.clone();
    rt.spawn(async move {
        while let Ok((sock, peer)) = listener.accept().await {
            let st = st.clone();
            st.connections.fetch_add(1, Ordering::SeqCst);
            tokio::spawn(async move {
                if let Err(e) = serve_connection(&st, sock).await {
                    tracing::warn!("{peer}: {e}");
                }
                st.connections.fetch_sub(1, Ordering::SeqCst);
            });
        }
    });
    addr
}

async fn serve_connection(st: &Arc<State>, sock: tokio::net::TcpStream) -> Result<(), ConnError> {
    sock.set_nodelay(true).ok();
    let (mut rd, wr) = sock.into_split();
    let wr = BufWriter::new(wr);
    let hello = tokio::time::timeout(
        Duration::from_secs(30),
        frame::read_frame_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES),
    )
    .await
    .map_err(|_| ConnError::Protocol("no hello within 30 s".into()))??;
    match hello {
        WorkerMsg::Hello(hello) => super::worker_session::serve(st, hello, rd, wr).await,
        WorkerMsg::DisplayHello(hello) => display::session::serve(st, hello, rd, wr).await,
        _ => Err(ConnError::Protocol("first message was not a hello".into())),
    }
}

/// Reads frames on a task of its own, so a peer blocked writing never waits on us; the
/// receiver ends after the first error.
pub(crate) fn reader(
    mut rd: tokio::net::tcp::OwnedReadHalf,
) -> (
    tokio::task::JoinHandle<()>,
    tokio::sync::mpsc::UnboundedReceiver<Result<WorkerMsg, FrameError>>,
) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let task = tokio::spawn(async move {
        loop {
            let m = frame::read_frame_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES).await;
            let end = m.is_err();
            if tx.send(m).is_err() || end {
                break;
            }
        }
    });
    (task, rx)
}
