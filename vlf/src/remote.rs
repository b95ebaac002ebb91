//! Bake workers in other processes: a bake listening on a port (`holocave vlf bake
//! --listen ADDR`) hands subfields out as work to `holocave worker --vlf` processes on
//! any host, beside its own threads. Every connection makes the cluster's mutual
//! handshake (`holocave_protocol::handshake`, role `Worker`) and every message after it
//! is sealed with the link's keys. A worker casts a subfield with the same [`Caster`] as
//! the bake's own threads and the bake puts each result in its place by index, so the
//! light field is bit-identical whoever cast what; a worker that fails or leaves gives
//! its subfield back to the queue.

use std::collections::VecDeque;
use std::io::ErrorKind;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use glam::Vec3;
use holocave_protocol::handshake::{self, Role, Welcome};
use holocave_protocol::session::{Opener, Sealer};
use holocave_scene::Scene;
use serde::{Deserialize, Serialize};

use crate::bake::{Caster, Casting, Settings};
use crate::subfield::{Crossing, Link, Subfield};

/// The largest message: one subfield's lines (a 4096² subfield of a deep scene fits).
const MAX_MESSAGE: u32 = 1 << 30;
/// How long a peer has for the handshake.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(5);
/// How often the acceptor looks for new workers while the bake runs.
const ACCEPT_POLL: Duration = Duration::from_millis(20);

#[derive(Debug, thiserror::Error)]
pub enum RemoteError {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("handshake: {0}")]
    Handshake(#[from] handshake::HandshakeError),
    #[error("message: {0}")]
    Frame(#[from] holocave_protocol::frame::FrameError),
    #[error("the bake refused this worker: {0}")]
    Refused(String),
    #[error("the bake sent an unexpected message")]
    Unexpected,
}

#[derive(Serialize, Deserialize, Clone, Copy)]
struct WireSettings {
    directions: u32,
    resolution: u32,
    element_size: Option<f32>,
    direct_samples: u32,
    tolerance: f64,
    max_bounces: u32,
    glossy_alpha: f32,
    tile_bins: u32,
}

impl From<&Settings> for WireSettings {
    fn from(s: &Settings) -> Self {
        WireSettings {
            directions: s.directions as u32,
            resolution: s.resolution,
            element_size: s.element_size,
            direct_samples: s.direct_samples,
            tolerance: s.tolerance,
            max_bounces: s.max_bounces,
            glossy_alpha: s.glossy_alpha,
            tile_bins: s.tile_bins,
        }
    }
}

impl From<WireSettings> for Settings {
    fn from(s: WireSettings) -> Self {
        Settings {
            directions: s.directions as usize,
            resolution: s.resolution,
            element_size: s.element_size,
            direct_samples: s.direct_samples,
            tolerance: s.tolerance,
            max_bounces: s.max_bounces,
            glossy_alpha: s.glossy_alpha,
            tile_bins: s.tile_bins,
        }
    }
}

/// A link on the wire: element, weight, emitted, the direction it leaves the element.
type WireLink = (u32, [f32; 3], [f32; 3], [f32; 3]);

#[derive(Serialize, Deserialize)]
enum ToWorker {
    /// What is baked: the scene's fingerprint (a worker with another scene refuses) and
    /// the settings.
    Bake {
        fingerprint: u64,
        settings: WireSettings,
    },
    Cast {
        index: u32,
    },
    Done,
}

#[derive(Serialize, Deserialize)]
enum FromWorker {
    Ready,
    Refused {
        why: String,
    },
    Cast {
        index: u32,
        lines_cast: u32,
        line_start: Vec<u32>,
        crossings: Vec<[u32; 2]>,
        links: Vec<WireLink>,
    },
}

fn to_wire(index: usize, s: Subfield) -> FromWorker {
    FromWorker::Cast {
        index: index as u32,
        lines_cast: s.lines_cast,
        line_start: s.line_start,
        crossings: s.crossings.iter().map(|c| [c.minus, c.plus]).collect(),
        links: s
            .links
            .iter()
            .map(|l| {
                (
                    l.element,
                    l.weight.to_array(),
                    l.emitted.to_array(),
                    l.toward.to_array(),
                )
            })
            .collect(),
    }
}

/// A subfield from the wire, checked against the bake's layout (a worker's answer is
/// input like any other: indices out of range are refused, not used).
fn from_wire(
    lines_cast: u32,
    line_start: Vec<u32>,
    crossings: Vec<[u32; 2]>,
    links: Vec<WireLink>,
    elements: usize,
) -> Result<Subfield, String> {
    let links: Vec<Link> = links
        .into_iter()
        .map(|(element, w, e, toward)| Link {
            element,
            weight: Vec3::from(w),
            emitted: Vec3::from(e),
            toward: Vec3::from(toward),
        })
        .collect();
    let ok_side = |side: u32| {
        if side & crate::subfield::DELTA != 0 {
            ((side & !crate::subfield::DELTA) as usize) < links.len()
        } else {
            (side as usize) < elements
        }
    };
    if crossings.iter().flatten().any(|&s| !ok_side(s))
        || links
            .iter()
            .any(|l| l.element != u32::MAX && l.element as usize >= elements)
        || line_start.first() != Some(&0)
        || line_start.windows(2).any(|w| w[0] >= w[1])
        || line_start.last().map(|&l| l as usize) != Some(crossings.len())
    {
        return Err("a subfield whose lines or elements do not fit the bake".into());
    }
    Ok(Subfield {
        line_start,
        crossings: crossings
            .into_iter()
            .map(|[minus, plus]| Crossing { minus, plus })
            .collect(),
        links,
        lines_cast,
    })
}

/// The bake's side: a port for workers, and whether this process's threads cast too.
pub struct Workers {
    pub listener: TcpListener,
    pub cluster: String,
    pub secret: Vec<u8>,
    /// Cast on this process's threads as well (rayon's pool size), not only in workers.
    pub local: bool,
    pub fingerprint: u64,
    pub settings: Settings,
}

/// The subfields still to cast and those cast, shared by the bake's threads and the
/// workers' handlers.
struct Work {
    queue: Mutex<VecDeque<usize>>,
    changed: Condvar,
    results: Mutex<Vec<Option<Subfield>>>,
    remaining: AtomicUsize,
}

impl Work {
    /// The next subfield to cast; `None` when all are cast. Waits while every remaining
    /// subfield is out with someone (a failing worker may give one back).
    fn next(&self) -> Option<usize> {
        let mut q = self.queue.lock().unwrap_or_else(|p| p.into_inner());
        loop {
            if let Some(k) = q.pop_front() {
                return Some(k);
            }
            if self.remaining.load(Ordering::Acquire) == 0 {
                return None;
            }
            q = self
                .changed
                .wait_timeout(q, Duration::from_millis(100))
                .unwrap_or_else(|p| p.into_inner())
                .0;
        }
    }

    fn give_back(&self, k: usize) {
        self.queue
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push_back(k);
        self.changed.notify_all();
    }

    fn done(&self, k: usize, s: Subfield) {
        let mut r = self.results.lock().unwrap_or_else(|p| p.into_inner());
        if r[k].is_none() {
            r[k] = Some(s);
            self.remaining.fetch_sub(1, Ordering::AcqRel);
        }
        drop(r);
        self.changed.notify_all();
    }
}

impl Workers {
    /// One worker's connection: the handshake, then subfields until none are left.
    fn serve(&self, mut stream: TcpStream, work: &Work, elements: usize, done: &(dyn Fn() + Sync)) {
        let peer = stream
            .peer_addr()
            .map_or_else(|_| "a worker".into(), |a| a.to_string());
        let mut out = None;
        match self.link(&mut stream) {
            Ok((mut sealer, mut opener)) => loop {
                let Some(k) = work.next() else {
                    let _ = sealer.write(&mut stream, &ToWorker::Done, MAX_MESSAGE);
                    break;
                };
                out = Some(k);
                let answer = sealer
                    .write(
                        &mut stream,
                        &ToWorker::Cast { index: k as u32 },
                        MAX_MESSAGE,
                    )
                    .map_err(|e| e.to_string())
                    .and_then(|()| {
                        opener
                            .read::<_, FromWorker>(&mut stream, MAX_MESSAGE)
                            .map_err(|e| e.to_string())
                    });
                match answer {
                    Ok(FromWorker::Cast {
                        index,
                        lines_cast,
                        line_start,
                        crossings,
                        links,
                    }) if index as usize == k => {
                        match from_wire(lines_cast, line_start, crossings, links, elements) {
                            Ok(s) => {
                                work.done(k, s);
                                done();
                                out = None;
                            }
                            Err(e) => {
                                tracing::warn!("bake worker {peer}: {e}; dropped");
                                break;
                            }
                        }
                    }
                    Ok(_) => {
                        tracing::warn!("bake worker {peer}: answered another subfield; dropped");
                        break;
                    }
                    Err(e) => {
                        tracing::warn!(
                            "bake worker {peer}: {e}; its subfield goes back to the queue"
                        );
                        break;
                    }
                }
            },
            Err(e) => tracing::warn!("bake worker {peer} refused: {e}"),
        }
        if let Some(k) = out {
            work.give_back(k);
        }
    }

    /// The handshake and the bake's description; the link's sealer and opener.
    fn link(&self, stream: &mut TcpStream) -> Result<(Sealer, Opener), String> {
        stream.set_nonblocking(false).map_err(|e| e.to_string())?;
        stream
            .set_read_timeout(Some(HANDSHAKE_TIMEOUT))
            .map_err(|e| e.to_string())?;
        let accepted =
            handshake::accept(stream, &self.cluster, &self.secret).map_err(|e| e.to_string())?;
        if accepted.role != Role::Worker {
            let why = format!(
                "a {} connected to a light-field bake (workers only)",
                accepted.role
            );
            let _ = accepted.refuse(stream, &why);
            return Err(why);
        }
        let keys = accepted
            .welcome(stream, Welcome::default())
            .map_err(|e| e.to_string())?;
        stream.set_read_timeout(None).map_err(|e| e.to_string())?;
        let (mut sealer, mut opener) = keys.acceptor();
        let bake = ToWorker::Bake {
            fingerprint: self.fingerprint,
            settings: WireSettings::from(&self.settings),
        };
        sealer
            .write(stream, &bake, MAX_MESSAGE)
            .map_err(|e| e.to_string())?;
        match opener.read::<_, FromWorker>(stream, MAX_MESSAGE) {
            Ok(FromWorker::Ready) => Ok((sealer, opener)),
            Ok(FromWorker::Refused { why }) => Err(why),
            Ok(_) => Err("an unexpected message".into()),
            Err(e) => Err(e.to_string()),
        }
    }
}

impl Casting for Workers {
    fn cast_all(&self, caster: &Caster, done: &(dyn Fn() + Sync)) -> Vec<Subfield> {
        let n = caster.count();
        let work = Work {
            queue: Mutex::new((0..n).collect()),
            changed: Condvar::new(),
            results: Mutex::new((0..n).map(|_| None).collect()),
            remaining: AtomicUsize::new(n),
        };
        let elements = caster.elements.count;
        let _ = self.listener.set_nonblocking(true);
        std::thread::scope(|scope| {
            scope.spawn(|| {
                while work.remaining.load(Ordering::Acquire) > 0 {
                    match self.listener.accept() {
                        Ok((stream, _)) => {
                            let work = &work;
                            scope.spawn(move || self.serve(stream, work, elements, done));
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => {
                            std::thread::sleep(ACCEPT_POLL)
                        }
                        Err(e) => tracing::warn!("accepting bake workers: {e}"),
                    }
                }
            });
            if self.local {
                for _ in 0..rayon::current_num_threads() {
                    scope.spawn(|| {
                        while let Some(k) = work.next() {
                            work.done(k, caster.cast(k));
                            done();
                        }
                    });
                }
            }
        });
        work.results
            .into_inner()
            .unwrap_or_else(|p| p.into_inner())
            .into_iter()
            .map(|s| s.unwrap_or_default())
            .collect()
    }
}

/// A worker process's side: connects to the bake at `addr`, proves the cluster's secret,
/// and casts subfields of `scene` until the bake is done. Returns how many it cast.
pub fn work(addr: &str, cluster: &str, secret: &[u8], scene: &Scene) -> Result<usize, RemoteError> {
    let mut stream = TcpStream::connect(addr)?;
    stream.set_read_timeout(Some(HANDSHAKE_TIMEOUT))?;
    let linked = handshake::connect(&mut stream, cluster, Role::Worker, secret)?;
    stream.set_read_timeout(None)?;
    let (mut sealer, mut opener) = linked.keys.connector();
    let (wanted, settings) = match opener.read::<_, ToWorker>(&mut stream, MAX_MESSAGE)? {
        ToWorker::Bake {
            fingerprint,
            settings,
        } => (fingerprint, Settings::from(settings)),
        _ => return Err(RemoteError::Unexpected),
    };
    let mine = scene.fingerprint();
    if wanted != mine {
        let why = format!(
            "the worker's scene {} (fingerprint {mine:016x}) is not the bake's (fingerprint {wanted:016x})",
            scene.name
        );
        sealer.write(
            &mut stream,
            &FromWorker::Refused { why: why.clone() },
            MAX_MESSAGE,
        )?;
        return Err(RemoteError::Refused(why));
    }
    sealer.write(&mut stream, &FromWorker::Ready, MAX_MESSAGE)?;
    let caster = Caster::new(scene, &settings);
    let mut cast = 0;
    loop {
        match opener.read::<_, ToWorker>(&mut stream, MAX_MESSAGE)? {
            ToWorker::Cast { index } if (index as usize) < caster.count() => {
                let s = caster.cast(index as usize);
                sealer.write(&mut stream, &to_wire(index as usize, s), MAX_MESSAGE)?;
                cast += 1;
            }
            ToWorker::Done => return Ok(cast),
            _ => return Err(RemoteError::Unexpected),
        }
    }
}
