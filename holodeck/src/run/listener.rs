//! The TCP listener (tokio): accepts workers and displays on one port, each after the
//! cluster handshake ([`crate::auth`]; a peer without the secret is refused and logged),
//! tells them apart by their (sealed) hello, and runs each connection as a task until it
//! ends or the run stops.

use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use holocave_protocol::frame::{FrameError, MAX_FRAME_BYTES};
use holocave_protocol::handshake::Role;
use holocave_protocol::holodeck::WorkerMsg;
use holocave_protocol::session::Opener;
use tokio::io::BufWriter;

use super::state::State;
use crate::auth::{self, Credentials};

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

/// Accepts connections on `listener` in `rt` from peers that prove `credentials`; returns
/// its address.
pub(crate) fn listen(
    rt: &tokio::runtime::Runtime,
    state: &Arc<State>,
    listener: TcpListener,
    credentials: Credentials,
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
    let credentials = Arc::new(credentials);
    rt.spawn(async move {
        let mut next_id = 0u64;
        while let Ok((sock, peer)) = listener.accept().await {
            let (st, credentials) = (st.clone(), credentials.clone());
            next_id += 1;
            let id = next_id;
            st.connections.fetch_add(1, Ordering::SeqCst);
            tokio::spawn(async move {
                if let Err(e) = serve_connection(&st, sock, &credentials, id).await {
                    tracing::warn!("{peer}: {e}");
                }
                st.connections.fetch_sub(1, Ordering::SeqCst);
            });
        }
    });
    addr
}

async fn serve_connection(
    st: &Arc<State>,
    sock: tokio::net::TcpStream,
    credentials: &Arc<Credentials>,
    id: u64,
) -> Result<(), ConnError> {
    sock.set_nodelay(true).ok();
    // The handshake is blocking and short (bounded by its timeouts): on a blocking thread.
    let mut std = sock.into_std().map_err(FrameError::from)?;
    std.set_nonblocking(false).map_err(FrameError::from)?;
    let creds = credentials.clone();
    let shaken = tokio::task::spawn_blocking(move || {
        auth::accept(&mut std, &creds, id).map(|(role, sealer, opener)| (std, role, sealer, opener))
    })
    .await
    .map_err(|e| ConnError::Protocol(format!("handshake task: {e}")))?;
    let (std, role, sealer, mut opener) =
        shaken.map_err(|why| ConnError::Protocol(format!("refused: {why}")))?;
    std.set_nonblocking(true).map_err(FrameError::from)?;
    let sock = tokio::net::TcpStream::from_std(std).map_err(FrameError::from)?;
    let (mut rd, wr) = sock.into_split();
    let wr = BufWriter::new(wr);
    let hello = tokio::time::timeout(
        Duration::from_secs(30),
        opener.read_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES),
    )
    .await
    .map_err(|_| ConnError::Protocol("no hello within 30 s".into()))??;
    let link = Link {
        rd,
        wr,
        sealer,
        opener,
    };
    match (hello, role) {
        (WorkerMsg::Hello(hello), Role::Worker) => {
            super::worker_session::serve(st, hello, link).await
        }
        (WorkerMsg::DisplayHello(hello), Role::Display) => {
            super::display_session::serve(st, hello, link).await
        }
        (_, role) => Err(ConnError::Protocol(format!(
            "a {role}'s first message was not its hello"
        ))),
    }
}

/// An authenticated connection: its halves and the link's sealer and opener.
pub(crate) struct Link {
    pub(crate) rd: tokio::net::tcp::OwnedReadHalf,
    pub(crate) wr: BufWriter<tokio::net::tcp::OwnedWriteHalf>,
    pub(crate) sealer: holocave_protocol::session::Sealer,
    pub(crate) opener: Opener,
}

/// Reads sealed messages on a task of its own, so a peer blocked writing never waits on
/// us; the receiver ends after the first error (a forged message included).
pub(crate) fn reader(
    mut rd: tokio::net::tcp::OwnedReadHalf,
    mut opener: Opener,
) -> (
    tokio::task::JoinHandle<()>,
    tokio::sync::mpsc::UnboundedReceiver<Result<WorkerMsg, FrameError>>,
) {
    let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
    let task = tokio::spawn(async move {
        loop {
            let m = opener
                .read_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES)
                .await;
            let end = m.is_err();
            if tx.send(m).is_err() || end {
                break;
            }
        }
    });
    (task, rx)
}
