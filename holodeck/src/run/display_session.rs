//! A display over TCP, on the server's side: the welcome (scene and sections), then its
//! requests served as they come and its samples (the stored ones answering a request, the
//! new ones workers return; which ones is the [`Hub`](crate::display::Hub)'s rule) written as they
//! are produced. A display that stops reading is dropped with its requests.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use holocave_protocol::frame::{FrameError, MAX_FRAME_BYTES};
use holocave_protocol::holodeck::{DisplayHello, PROTOCOL_VERSION, ServerMsg, WorkerMsg};
use tokio::io::AsyncWriteExt;

use super::listener::{ConnError, Link, reader};
use super::state::State;
use crate::display::{Arrival, wire};

/// Largest sample batch sent to a TCP display in one message.
const DISPLAY_BATCH_BYTES: usize = 1 << 20;
/// Most samples queued for a TCP display (320 MB) before it counts as gone.
const MAX_QUEUED_SAMPLES: usize = 32 << 20;

pub(crate) async fn serve(
    st: &Arc<State>,
    hello: DisplayHello,
    link: Link,
) -> Result<(), ConnError> {
    let Link {
        rd,
        mut wr,
        mut sealer,
        opener,
    } = link;
    if hello.protocol != PROTOCOL_VERSION {
        return Err(ConnError::Protocol(format!(
            "display protocol {} (this server speaks {PROTOCOL_VERSION})",
            hello.protocol
        )));
    }
    let (tx, mut samples) = tokio::sync::mpsc::unbounded_channel::<Arrival>();
    // Samples queued for this display and not yet written: a display that stops reading
    // is dropped (its channel closes, ending the session) rather than filling memory.
    let queued = Arc::new(AtomicUsize::new(0));
    let q = queued.clone();
    let deliver = move |a: Arrival| {
        let n: usize = a.iter().map(|b| b.samples.len()).sum();
        if q.fetch_add(n, Ordering::SeqCst) + n > MAX_QUEUED_SAMPLES {
            tracing::warn!("a display is not reading its samples: dropping it");
            return false;
        }
        tx.send(a).is_ok()
    };
    let (welcome, token) = {
        let (s, mut hub) = st.lock_both();
        let token = hub.subscribe(hello.display, Box::new(deliver));
        (wire::welcome(&s, &st.scene), token)
    };
    tracing::info!("display {} ({}) joined", hello.display, hello.name);
    let (reader, mut requests) = reader(rd, opener);
    let session = async {
        sealer
            .write_async(
                &mut wr,
                &ServerMsg::DisplayWelcome(welcome),
                MAX_FRAME_BYTES,
            )
            .await?;
        wr.flush().await.map_err(FrameError::from)?;
        let mut tick = tokio::time::interval(Duration::from_millis(200));
        loop {
            if st.stopping() {
                let _ = sealer
                    .write_async(&mut wr, &ServerMsg::Bye, MAX_FRAME_BYTES)
                    .await;
                let _ = wr.flush().await;
                break Ok(());
            }
            tokio::select! {
                m = requests.recv() => match m {
                    Some(Ok(WorkerMsg::Request(r))) => match wire::eye_request(&r) {
                        Ok(req) => st.request(token, req),
                        Err(e) => break Err(ConnError::Protocol(e.to_string())),
                    },
                    Some(Ok(_)) => break Err(ConnError::Protocol("a display sent a worker message".into())),
                    Some(Err(FrameError::Closed)) | None => break Ok(()),
                    Some(Err(e)) => break Err(e.into()),
                },
                a = samples.recv() => {
                    let Some(a) = a else { break Ok(()) };
                    let mut all: Vec<_> = a.iter().cloned().collect();
                    while let Ok(more) = samples.try_recv() {
                        all.extend(more.iter().cloned());
                    }
                    let n: usize = all.iter().map(|b| b.samples.len()).sum();
                    for b in wire::pack(&all, DISPLAY_BATCH_BYTES) {
                        sealer.write_async(&mut wr, &ServerMsg::Beams(b), MAX_FRAME_BYTES).await?;
                    }
                    wr.flush().await.map_err(FrameError::from)?;
                    queued.fetch_sub(n, Ordering::SeqCst);
                }
                _ = tick.tick() => {}
            }
        }
    };
    let res = session.await;
    reader.abort();
    st.unsubscribe(token);
    tracing::info!("display {} left", hello.display);
    res
}
