//! Running a [`Server`] with its workers and displays: in-process worker threads, TCP
//! worker processes and TCP displays accepted on one listener (tokio; told apart by their
//! hello), in-process displays ([`Running::display`]), periodic commits, progress reports
//! and a stop condition. Workers and displays may join and leave at any time; the server
//! re-assigns a lost worker's packets.
//!
//! [`start`] runs it in the background and returns a [`Running`] handle (what a render
//! node embeds); [`run`] runs it until a stop condition (what `holocave fill` does).

use std::net::{SocketAddr, TcpListener};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use holocave_protocol::frame::{self, FrameError, MAX_FRAME_BYTES};
use holocave_protocol::holodeck::{
    DisplayHello, DistanceKind, PROTOCOL_VERSION, SamplePacket, ServerMsg, Welcome, WorkerHello,
    WorkerMsg,
};
use tokio::io::{AsyncWriteExt, BufWriter};

use crate::display::{self, DisplayClient, EyeRequest, Hub};
use crate::server::{Server, ServerError, Stats, WorkerId};
use crate::worker::{SampleSource, trace_packet};

/// Largest sample batch sent to a TCP display in one message.
const DISPLAY_BATCH_BYTES: usize = 1 << 20;
/// Most samples queued for a TCP display (320 MB) before it counts as gone.
const MAX_QUEUED_SAMPLES: usize = 32 << 20;

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
    /// Subscribed displays; locked only while holding `server`.
    hub: Mutex<Hub>,
    wake: Condvar,
    stop: AtomicBool,
    connections: AtomicUsize,
    start: Instant,
    /// The distance the holodeck stores, asked of every worker.
    distance: DistanceKind,
    commits: AtomicU64,
    /// The first commit error (the run stops on it).
    error: Mutex<Option<ServerError>>,
    scene: String,
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

    /// Stores a worker's results and hands the new samples to the displays.
    fn complete(&self, id: WorkerId, result: &SamplePacket) -> Result<(), ServerError> {
        let mut s = self.lock();
        let new = s.complete(id, result, self.now())?;
        if !new.is_empty() {
            let mut hub = self.hub.lock().unwrap_or_else(|p| p.into_inner());
            hub.distribute(&mut s, &new);
        }
        Ok(())
    }

    /// Serves one eye request of the display subscribed as `token`.
    fn request(&self, token: u64, req: EyeRequest) {
        let mut s = self.lock();
        let mut hub = self.hub.lock().unwrap_or_else(|p| p.into_inner());
        if let Err(e) = hub.request(&mut s, token, req) {
            tracing::warn!("display request: {e}");
        }
        drop(hub);
        drop(s);
        // New requests may mean new work for idle worker threads.
        self.wake.notify_all();
    }

    fn unsubscribe(&self, token: u64) {
        let mut s = self.lock();
        let mut hub = self.hub.lock().unwrap_or_else(|p| p.into_inner());
        hub.unsubscribe(&mut s, token);
    }

    fn commit(&self) -> Result<(), ServerError> {
        let mut s = self.lock();
        let t = Instant::now();
        let seq = s.flush()?;
        tracing::info!(
            "commit {seq}: {} samples durable ({} added by this run; {:.2} s)",
            s.stats().samples,
            s.stats().added,
            t.elapsed().as_secs_f64()
        );
        self.commits.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }
}

/// Reads a running server's totals (see [`Running::monitor`]).
#[derive(Clone)]
pub struct Monitor(std::sync::Weak<Shared>);

impl Monitor {
    /// The running totals; `None` once the server has stopped.
    pub fn stats(&self) -> Option<Stats> {
        self.0.upgrade().map(|sh| sh.lock().stats())
    }
}

/// A server running in the background (see [`start`]).
pub struct Running {
    /// `None` only once stopped.
    shared: Option<Arc<Shared>>,
    threads: Vec<std::thread::JoinHandle<()>>,
    committer: Option<std::thread::JoinHandle<()>>,
    rt: Option<tokio::runtime::Runtime>,
    addr: Option<SocketAddr>,
}

impl Running {
    fn sh(&self) -> &Arc<Shared> {
        self.shared.as_ref().expect("not stopped yet")
    }

    /// A display in this process: its requests and samples go through a thread of its
    /// own, so neither call of the client ever waits for the server's lock.
    pub fn display(&self, id: u32) -> DisplayClient {
        let (tx, rx) = std::sync::mpsc::channel();
        let token = {
            let _s = self.sh().lock();
            self.sh()
                .hub
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .subscribe(id, Box::new(move |a| tx.send(a).is_ok()))
        };
        let sections = self.sh().lock().cache().file().sections().to_vec();
        // Weak: a display left alive does not keep the server from stopping.
        let (a, b) = (Arc::downgrade(self.sh()), Arc::downgrade(self.sh()));
        DisplayClient::local(
            sections,
            rx,
            move |req| {
                if let Some(sh) = a.upgrade() {
                    sh.request(token, req);
                }
            },
            move || {
                if let Some(sh) = b.upgrade() {
                    sh.unsubscribe(token);
                }
            },
        )
    }

    /// Running totals.
    pub fn stats(&self) -> Stats {
        self.sh().lock().stats()
    }

    /// A handle that reads the running totals from another thread (an operator's status
    /// line) without keeping the server alive.
    pub fn monitor(&self) -> Monitor {
        Monitor(Arc::downgrade(self.sh()))
    }

    /// Commits so far.
    pub fn commits(&self) -> u64 {
        self.sh().commits.load(Ordering::SeqCst)
    }

    /// Where TCP workers and displays connect, if listening.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.addr
    }

    /// Whether the run is stopping (Ctrl-C, or a commit failed).
    pub fn stopping(&self) -> bool {
        self.sh().stop.load(Ordering::SeqCst)
    }

    /// Stops the workers and displays, commits and returns the server.
    pub fn stop(mut self) -> Result<Server, ServerError> {
        let shared = self.sh().clone();
        shared.stop.store(true, Ordering::SeqCst);
        shared.wake.notify_all();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        if let Some(c) = self.committer.take() {
            let _ = c.join();
        }
        // Give connected workers and displays a moment to be told goodbye.
        let deadline = Instant::now() + Duration::from_secs(2);
        while shared.connections.load(Ordering::SeqCst) > 0 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        if let Some(rt) = self.rt.take() {
            rt.shutdown_timeout(Duration::from_millis(100));
        }
        let error = shared
            .error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take();
        drop(shared);
        // An in-process display may hold the state for the length of one request.
        let mut shared = self.shared.take().expect("not stopped yet");
        let mut server = loop {
            match Arc::try_unwrap(shared) {
                Ok(sh) => break sh.server.into_inner().unwrap_or_else(|p| p.into_inner()),
                Err(sh) => {
                    shared = sh;
                    std::thread::sleep(Duration::from_millis(5));
                }
            }
        };
        if let Some(e) = error {
            return Err(e);
        }
        let seq = server.flush()?;
        tracing::info!(
            "commit {seq}: {} samples durable ({} added by this run)",
            server.stats().samples,
            server.stats().added
        );
        Ok(server)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        if let Some(sh) = &self.shared {
            sh.stop.store(true, Ordering::SeqCst);
            sh.wake.notify_all();
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        if let Some(c) = self.committer.take() {
            let _ = c.join();
        }
        if let Some(rt) = self.rt.take() {
            rt.shutdown_timeout(Duration::from_millis(100));
        }
    }
}

/// Runs until `stop` returns true (or Ctrl-C), then stops the workers, commits and returns
/// the server.
pub fn run(
    server: Server,
    opts: RunOptions,
    mut stop: impl FnMut(&Progress) -> bool,
) -> Result<Server, ServerError> {
    let running = start(server, opts)?;
    let t0 = Instant::now();
    loop {
        let progress = Progress {
            elapsed: t0.elapsed(),
            stats: running.stats(),
            commits: running.commits(),
        };
        if running.stopping() || stop(&progress) {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    running.stop()
}

/// Starts the server in the background: worker threads, the TCP listener (workers and
/// displays), Ctrl-C handling (it sets [`Running::stopping`]) and a commit every
/// `opts.commit_every`.
pub fn start(server: Server, opts: RunOptions) -> Result<Running, ServerError> {
    let distance = server.cache().file().distance_kind()?;
    let shared = Arc::new(Shared {
        server: Mutex::new(server),
        hub: Mutex::new(Hub::default()),
        wake: Condvar::new(),
        stop: AtomicBool::new(false),
        connections: AtomicUsize::new(0),
        start: Instant::now(),
        distance,
        commits: AtomicU64::new(0),
        error: Mutex::new(None),
        scene: opts.scene.clone(),
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
    let mut addr = None;
    if let Some(l) = opts.listener {
        let sh = shared.clone();
        l.set_nonblocking(true).ok();
        addr = l.local_addr().ok();
        let _guard = rt.enter();
        match tokio::net::TcpListener::from_std(l) {
            Ok(listener) => {
                rt.spawn(async move {
                    while let Ok((sock, peer)) = listener.accept().await {
                        let sh = sh.clone();
                        sh.connections.fetch_add(1, Ordering::SeqCst);
                        tokio::spawn(async move {
                            if let Err(e) = serve_connection(&sh, sock).await {
                                tracing::warn!("{peer}: {e}");
                            }
                            sh.connections.fetch_sub(1, Ordering::SeqCst);
                        });
                    }
                });
            }
            Err(e) => tracing::warn!("cannot listen for workers and displays: {e}"),
        }
    }
    let committer = {
        let sh = shared.clone();
        let every = opts.commit_every;
        std::thread::Builder::new()
            .name("holodeck commits".into())
            .spawn(move || {
                let mut last = Instant::now();
                while !sh.stop.load(Ordering::SeqCst) {
                    if last.elapsed() >= every {
                        if let Err(e) = sh.commit() {
                            tracing::error!("commit failed: {e}; stopping");
                            *sh.error.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                            sh.stop.store(true, Ordering::SeqCst);
                            sh.wake.notify_all();
                            break;
                        }
                        last = Instant::now();
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            })
            .expect("spawn the commit thread")
    };
    Ok(Running {
        shared: Some(shared),
        threads,
        committer: Some(committer),
        rt: Some(rt),
        addr,
    })
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
            if let Err(e) = sh.complete(id, &result) {
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

async fn serve_connection(sh: &Arc<Shared>, sock: tokio::net::TcpStream) -> Result<(), ConnError> {
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
        WorkerMsg::Hello(hello) => serve_worker(sh, hello, rd, wr).await,
        WorkerMsg::DisplayHello(hello) => serve_display(sh, hello, rd, wr).await,
        _ => Err(ConnError::Protocol("first message was not a hello".into())),
    }
}

async fn serve_worker(
    sh: &Arc<Shared>,
    hello: WorkerHello,
    rd: tokio::net::tcp::OwnedReadHalf,
    mut wr: BufWriter<tokio::net::tcp::OwnedWriteHalf>,
) -> Result<(), ConnError> {
    let scene = sh.scene.as_str();
    if hello.protocol != PROTOCOL_VERSION {
        return Err(ConnError::Protocol(format!(
            "worker protocol {} (this server speaks {PROTOCOL_VERSION})",
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

/// A display over TCP: its requests are served as they come; its samples (the stored ones
/// answering a request, the new ones workers return) are written as they are produced.
async fn serve_display(
    sh: &Arc<Shared>,
    hello: DisplayHello,
    mut rd: tokio::net::tcp::OwnedReadHalf,
    mut wr: BufWriter<tokio::net::tcp::OwnedWriteHalf>,
) -> Result<(), ConnError> {
    if hello.protocol != PROTOCOL_VERSION {
        return Err(ConnError::Protocol(format!(
            "display protocol {} (this server speaks {PROTOCOL_VERSION})",
            hello.protocol
        )));
    }
    let (tx, mut samples) = tokio::sync::mpsc::unbounded_channel::<display::Arrival>();
    // Samples queued for this display and not yet written: a display that stops reading
    // is dropped (its channel closes, ending the session) rather than filling memory.
    let queued = Arc::new(AtomicUsize::new(0));
    let q = queued.clone();
    let deliver = move |a: display::Arrival| {
        let n: usize = a.iter().map(|b| b.samples.len()).sum();
        if q.fetch_add(n, Ordering::SeqCst) + n > MAX_QUEUED_SAMPLES {
            tracing::warn!("a display is not reading its samples: dropping it");
            return false;
        }
        tx.send(a).is_ok()
    };
    let (welcome, token) = {
        let s = sh.lock();
        let token = sh
            .hub
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .subscribe(hello.display, Box::new(deliver));
        (display::welcome(&s, &sh.scene), token)
    };
    tracing::info!("display {} ({}) joined", hello.display, hello.name);
    let (rtx, mut requests) = tokio::sync::mpsc::unbounded_channel();
    let reader = tokio::spawn(async move {
        loop {
            let m = frame::read_frame_async::<_, WorkerMsg>(&mut rd, MAX_FRAME_BYTES).await;
            let end = m.is_err();
            if rtx.send(m).is_err() || end {
                break;
            }
        }
    });
    let session = async {
        frame::write_frame_async(
            &mut wr,
            &ServerMsg::DisplayWelcome(welcome),
            MAX_FRAME_BYTES,
        )
        .await?;
        wr.flush().await.map_err(FrameError::from)?;
        let mut tick = tokio::time::interval(Duration::from_millis(200));
        loop {
            if sh.stop.load(Ordering::SeqCst) {
                let _ = frame::write_frame_async(&mut wr, &ServerMsg::Bye, MAX_FRAME_BYTES).await;
                let _ = wr.flush().await;
                break Ok(());
            }
            tokio::select! {
                m = requests.recv() => match m {
                    Some(Ok(WorkerMsg::Request(r))) => match display::eye_request(&r) {
                        Ok(req) => sh.request(token, req),
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
                    for b in display::pack(&all, DISPLAY_BATCH_BYTES) {
                        frame::write_frame_async(&mut wr, &ServerMsg::Beams(b), MAX_FRAME_BYTES).await?;
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
    sh.unsubscribe(token);
    tracing::info!("display {} left", hello.display);
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
                    if let Err(e) = sh.complete(id, &s) {
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
