//! A TCP worker's session: the welcome (worker id, scene, distance kind), then ray packets
//! out as its queue has room and results back as they come; its packets go back to the
//! server for reassignment when it leaves.

use std::sync::Arc;
use std::time::Duration;

use holocave_protocol::frame::{FrameError, MAX_FRAME_BYTES};
use holocave_protocol::holodeck::{
    PROTOCOL_VERSION, ServerMsg, WorkerHello, WorkerMsg, WorkerWelcome,
};
use tokio::io::AsyncWriteExt;

use super::listener::{ConnError, Link, reader};
use super::state::State;
use crate::scene_id::same_scene;
use crate::server::WorkerId;

pub(crate) async fn serve(
    st: &Arc<State>,
    hello: WorkerHello,
    link: Link,
) -> Result<(), ConnError> {
    let scene = st.scene.as_str();
    if hello.protocol != PROTOCOL_VERSION {
        return Err(ConnError::Protocol(format!(
            "worker protocol {} (this server speaks {PROTOCOL_VERSION})",
            hello.protocol
        )));
    }
    // Samples of another scene (or the same file under another daylight) would spoil
    // every view that reads them: such a worker is sent away.
    if !scene.is_empty() && !same_scene(scene, &hello.scene) {
        return Err(ConnError::Protocol(format!(
            "worker {} traces scene {:?}; the holodeck holds scene {scene:?}",
            hello.name, hello.scene
        )));
    }
    let id: WorkerId = st.lock().add_worker();
    tracing::info!("worker {id} ({}) joined", hello.name);
    let res = session(st, id, link).await;
    st.lock().remove_worker(id);
    tracing::info!("worker {id} left");
    res
}

async fn session(st: &Arc<State>, id: WorkerId, link: Link) -> Result<(), ConnError> {
    let Link {
        rd,
        mut wr,
        mut sealer,
        opener,
    } = link;
    let wr = &mut wr;
    let welcome = WorkerWelcome {
        worker_id: id,
        scene: st.scene.clone(),
        distance: st.distance.into(),
    };
    sealer
        .write_async(wr, &ServerMsg::Welcome(welcome), MAX_FRAME_BYTES)
        .await?;
    wr.flush().await.map_err(FrameError::from)?;
    let (reader, mut rx) = reader(rd, opener);
    let mut tick = tokio::time::interval(Duration::from_millis(200));
    let result = loop {
        if st.stopping() {
            let _ = sealer
                .write_async(wr, &ServerMsg::Bye, MAX_FRAME_BYTES)
                .await;
            let _ = wr.flush().await;
            break Ok(());
        }
        let packets = st.lock().next_packets(id, st.now());
        for p in packets {
            sealer
                .write_async(wr, &ServerMsg::Rays(p), MAX_FRAME_BYTES)
                .await?;
        }
        wr.flush().await.map_err(FrameError::from)?;
        tokio::select! {
            m = rx.recv() => match m {
                Some(Ok(WorkerMsg::Samples(s))) => {
                    if let Err(e) = st.complete(id, &s) {
                        tracing::warn!("worker {id}: {e}");
                    }
                }
                Some(Ok(_)) => break Err(ConnError::Protocol("a worker sent a hello or a display message".into())),
                Some(Err(FrameError::Closed)) | None => break Ok(()),
                Some(Err(e)) => break Err(e.into()),
            },
            _ = tick.tick() => {}
        }
    };
    reader.abort();
    result
}
