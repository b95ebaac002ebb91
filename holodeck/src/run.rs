//! Running a [`Server`] with its workers: in-process worker threads, TCP worker processes
//! accepted on a listener (tokio), periodic commits, progress reports and a stop condition.
//! Workers may join and leave at any time; the server re-assigns a lost worker's packets.

use std::net::TcpListener;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use holocave_protocol::frame::{self, FrameError, MAX_FRAME_BYTES};
use holocave_protocol::holodeck::{DistanceKind, PROTOCOL_VERSION, ServerMsg, Welcome, WorkerMsg};
use tokio::io::{AsyncWriteExt, BufWriter};

use crate::server::{Server, ServerError, Stats, WorkerId};
use crate::worker::{SampleSource, trace_packet};

/// How to run.
pub struct RunOptions {
    /// In-process worker threads (need `source`).
    pub threads: usize,
    pub source: Option<Arc<dyn SampleSource>>,
    /// Accept TCP workers here.
    pub listener: Option<TcpListener>,
    /// The scene name sent to TCP workers in the welcome.
    pub scene: String,
    /// Commit this often.
    pub commit_every: Duration,
}

/// Progress, passed to the stop callback about ten times a second.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub elapsed: Duration,
    pub stats: Stats,
    pub commits: u64,
}

struct Shared {
    server: Mutex<Server>,
    wake: Condvar,
    stop: AtomicBool,
    connections: AtomicUsize,
    start: Instant,
    /// The distance the holodeck stores, asked of every worker.
    distance: DistanceKind,
}

impl Shared {
    fn now(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, Server> {
        // A worker thread that panicked mid-update leaves the server as it was between
        // calls; carrying on is safer than losing the unflushed cache.
        self.server.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Runs until `stop` returns true (or Ctrl-C), then stops the workers, commits and returns
/// the server.
pub fn run(
    server: Server,
    opts: RunOptions,
    mut stop: impl FnMut(&Progress) -> bool,
) -> Result<Server, ServerError> {
    let distance = server.cache().file().distance_kind()?;
    let shared = Arc::new(Shared {
        server: Mutex::new(server),
        wake: Condvar::new(),
        stop: AtomicBool::new(false),
        connections: AtomicUsize::new(0),
        start: Instant::now(),
        distance,
    });
    let mut threads = Vec::new();
    if let Some(source) = &opts.source {
        for i in 0..opts.threads {
            let (sh, src) = (shared.clone(), source.clone());
            threads.push(
                std::thread::Builder::new()
                    .name(format!("holodeck-worker-{i}"))
                    .spawn(move || thread_worker(&sh, &*src))
                    .expect("spawn worker thread"),
            );
        }
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(|e| {
            ServerError::File(crate::FileError::Io {
                path: "tokio runtime".into(),
                source: e,
            })
        })?;
    {
        let sh = shared.clone();
        rt.spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                tracing::info!("interrupted: stopping and committing");
                sh.stop.store(true, Ordering::SeqCst);
            }
        });
    }
    if let Some(l) = opts.listener {
        let sh = shared.clone();
        let scene = opts.scene.clone();
        l.set_nonblocking(true).ok();
        let _guard = rt.enter();
        match tokio::net::TcpListener::from_std(l) {
            Ok(listener) => {
                rt.spawn(async move {
                    while let Ok((sock, peer)) = listener.accept().await {
                        let (sh, scene) = (sh.clone(), scene.clone());
                        sh.connections.fetch_add(1, Ordering::SeqCst);
                        tokio::spawn(async move {
                            if let Err(e) = serve_connection(&sh, sock, &scene).await {
                                tracing::warn!("worker {peer}: {e}");
                            }
                            sh.connections.fetch_sub(1, Ordering::SeqCst);
                        });
                    }
                });
            }
            Err(e) => tracing::warn!("cannot listen for workers: {e}"),
        }
    }
    let mut last_commit = Instant::now();
    let mut commits = 0;
    let mut result = Ok(());
    loop {
        let progress = Progress {
            elapsed: shared.start.elapsed(),
            stats: shared.lock().stats(),
            commits,
        };
        if shared.stop.load(Ordering::SeqCst) || stop(&progress) {
            break;
        }
        if last_commit.elapsed() >= opts.commit_every {
            let mut s = shared.lock();
            let t = Instant::now();
            match s.flush() {
                Ok(seq) => tracing::info!(
                    "commit {seq}: {} samples durable ({} added by this run; {:.2} s)",
                    s.stats().samples,
                    s.stats().added,
                    t.elapsed().as_secs_f64()
                ),
                Err(e) => {
                    result = Err(e);
                    break;
                }
            }
            drop(s);
            commits += 1;
            last_commit = Instant::now();
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    shared.stop.store(true, Ordering::SeqCst);
    shared.wake.notify_all();
    for t in threads {
        let _ = t.join();
    }
    // Give connected workers a moment to be told goodbye.
    let deadline = Instant::now() + Duration::from_secs(2);
    while shared.connections.load(Ordering::SeqCst) > 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    rt.shutdown_timeout(Duration::from_millis(100));
    let mut server = Arc::try_unwrap(shared)
        .map_err(|_| ())
        .expect("all worker threads and tasks have ended")
        .server
        .into_inner()
        .unwrap_or_else(|p| p.into_inner());
    result?;
    let seq = server.flush()?;
    tracing::info!(
        "commit {seq}: {} samples durable ({} added by this run)",
        server.stats().samples,
        server.stats().added
    );
    Ok(server)
}

fn thread_worker(sh: &Shared, source: &dyn SampleSource) {
    let id = sh.lock().add_worker();
    while !sh.stop.load(Ordering::SeqCst) {
        let packets = {
            let mut s = sh.lock();
            let p = s.next_packets(id, sh.now());
            if p.is_empty() {
                // Nothing to do now: wait for a change (or the stop).
                let _ = sh.wake.wait_timeout(s, Duration::from_millis(200));
                continue;
            }
            p
        };
        for p in packets {
            if sh.stop.load(Ordering::SeqCst) {
                break;
            }
            let result = trace_packet(source, &p, sh.distance)
                .expect("packets built by the server are whole records");
            if let Err(e) = sh.lock().complete(id, &result, sh.now()) {
                tracing::warn!("worker thread: {e}");
            }
        }
    }
    sh.lock().remove_worker(id);
}

#[derive(Debug, thiserror::Error)]
enum ConnError {
    #[error(transparent)]
    Frame(#[from] FrameError),
    #[error("{0}")]
    Protocol(String),
}

async fn serve_connection(
    sh: &Arc<Shared>,
    sock: tokio::net::TcpStream,
    scene: &str,
) -> Result<(), ConnError> {
    sock.set_nodelay(true).ok();
    let (mut rd, wr) = sock.into_split();
    let mut wr = BufWriter::new(wr);
    let hello = tokio::time::timeout(
        Duration::from_secs(30),
        frame::read_frame_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES),
    )
    .await
    .map_err(|_| ConnError::Protocol("no hello within 30 s".into()))??;
    let WorkerMsg::Hello(hello) = hello else {
        return Err(ConnError::Protocol("first message was not a hello".into()));
    };
    if hello.protocol != PROTOCOL_VERSION {
        return Err(ConnError::Protocol(format!(
            "protocol {} (this server speaks {PROTOCOL_VERSION})",
            hello.protocol
        )));
    }
    if !scene.is_empty() && hello.scene != scene {
        tracing::warn!(
            "worker {} traces scene {:?}; the holodeck was made with {scene:?}",
            hello.name,
            hello.scene
        );
    }
    let id: WorkerId = sh.lock().add_worker();
    tracing::info!("worker {id} ({}) joined", hello.name);
    let res = worker_session(sh, id, rd, &mut wr, scene).await;
    sh.lock().remove_worker(id);
    tracing::info!("worker {id} left");
    res
}

async fn worker_session(
    sh: &Arc<Shared>,
    id: WorkerId,
    mut rd: tokio::net::tcp::OwnedReadHalf,
    wr: &mut BufWriter<tokio::net::tcp::OwnedWriteHalf>,
    scene: &str,
) -> Result<(), ConnError> {
    frame::write_frame_async(
        wr,
        &ServerMsg::Welcome(Welcome {
            worker_id: id,
            scene: scene.into(),
            distance: sh.distance,
        }),
        MAX_FRAME_BYTES,
    )
    .await?;
    wr.flush().await.map_err(FrameError::from)?;
    // Reading runs apart from writing, so a worker blocked sending results never waits on us.
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
    let reader = tokio::spawn(async move {
        loop {
            let m = frame::read_frame_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES).await;
            let end = m.is_err();
            if tx.send(m).is_err() || end {
                break;
            }
        }
    });
    let mut tick = tokio::time::interval(Duration::from_millis(200));
    let result = loop {
        if sh.stop.load(Ordering::SeqCst) {
            let _ = frame::write_frame_async(wr, &ServerMsg::Bye, MAX_FRAME_BYTES).await;
            let _ = wr.flush().await;
            break Ok(());
        }
        let packets = sh.lock().next_packets(id, sh.now());
        for p in packets {
            frame::write_frame_async(wr, &ServerMsg::Rays(p), MAX_FRAME_BYTES).await?;
        }
        wr.flush().await.map_err(FrameError::from)?;
        tokio::select! {
            m = rx.recv() => match m {
                Some(Ok(WorkerMsg::Samples(s))) => {
                    if let Err(e) = sh.lock().complete(id, &s, sh.now()) {
                        tracing::warn!("worker {id}: {e}");
                    }
                }
                Some(Ok(WorkerMsg::Hello(_))) => break Err(ConnError::Protocol("a second hello".into())),
                Some(Err(FrameError::Closed)) | None => break Ok(()),
                Some(Err(e)) => break Err(e.into()),
            },
            _ = tick.tick() => {}
        }
    };
    reader.abort();
    result
}
