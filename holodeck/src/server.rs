//! The holodeck server's logic (paper §2.2), independent of threads and sockets: the beam
//! cache, the request list, packet assignment to workers and the return of their results.
//! Time is passed in (seconds since start) so the scheduling is deterministic under test.
//!
//! - **Batch** mode: every beam is requested in proportion to its world volume
//!   ([`Section::beam_volume`]) and served lowest computed/wanted first, so stopping at any
//!   time leaves an even fill.
//! - **Display-only** mode: no workers; requests are answered from the cache and the file.
//! - **Interactive** mode: displays send (beam, wanted) lists with their eye positions; the
//!   lists of all displays are merged (the larger wanted count wins) and new rays pass near
//!   the requesting eye (Appendix A).
//!
//! Each worker's queue is kept about `queue_seconds` deep at its measured ray rate, in
//! packets of half that, so one is traced while the next waits. A worker that leaves loses
//! only its in-flight packets, which go to the next worker asking for work.

use std::collections::{BTreeMap, VecDeque};

use holocave_protocol::holodeck::{RayPacket, RecordError, SamplePacket};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

use crate::beam_index::BeamKey;
use crate::cache::{BeamCache, BeamMap};
use crate::distance_code::DistanceCode;
use crate::file::{FileError, HoloFile};
use crate::proximity::{self, EyeSphere, RayCode};
use crate::rgbe;
use crate::sample::PackedSample;

/// A worker's number.
pub type WorkerId = u64;
/// A display's number (e.g. wall × 2 + eye).
pub type DisplayId = u32;

/// Server operation modes (paper §2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Batch,
    Interactive,
}

/// Tunables.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    /// Byte budget of the beam cache.
    pub cache_bytes: usize,
    /// How long each worker's queue should take to drain.
    pub queue_seconds: f64,
    /// Assumed rays per second of a worker before it has returned anything.
    pub initial_rate: f64,
    /// Most rays given to one beam per assignment (the paper's 21).
    pub max_bundle: u32,
}

impl ServerConfig {
    /// For displays following a tracked head (interactive mode): worker queues half a
    /// second deep, so rays are chosen near where an eye is now, not where it was 3 s ago.
    pub fn interactive() -> Self {
        Self {
            queue_seconds: 0.5,
            ..Self::default()
        }
    }
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            cache_bytes: 256 << 20,
            queue_seconds: 3.0,
            initial_rate: 200.0,
            max_bundle: 21,
        }
    }
}

/// Fewest and most rays per packet.
const MIN_PACKET_RAYS: usize = 16;
const MAX_PACKET_RAYS: usize = 1 << 16;
/// Rays per assignment to a beam of average volume in batch mode.
const BATCH_BUNDLE: f64 = 8.0;

#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("worker {worker} returned packet {packet}, which it does not hold")]
    UnknownPacket { worker: WorkerId, packet: u64 },
    #[error("packet {packet} had {rays} rays but {results} results came back")]
    WrongCount {
        packet: u64,
        rays: usize,
        results: usize,
    },
    #[error(transparent)]
    Records(#[from] RecordError),
    #[error("section {section} beam {beam} is not in the holodeck")]
    NoBeam { section: u16, beam: u32 },
}

/// Samples of one beam, sent to displays.
#[derive(Clone, Debug, PartialEq)]
pub struct BeamSamples {
    pub key: BeamKey,
    pub samples: Vec<PackedSample>,
}

/// Running totals.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    /// Samples in the holodeck (file and cache).
    pub samples: u64,
    /// Samples added by this server.
    pub added: u64,
    pub rays_assigned: u64,
    pub packets_reassigned: u64,
    pub workers: usize,
}

struct Bundle {
    key: BeamKey,
    codes: Vec<RayCode>,
    offsets: Vec<f64>,
}

struct Packet {
    rays: RayPacket,
    bundles: Vec<Bundle>,
    worker: Option<WorkerId>,
    sent_at: f64,
}

struct WorkerState {
    in_flight: Vec<u64>,
    rays_in_flight: usize,
    rate: Option<f64>,
    last_done: f64,
}

struct DisplayRequest {
    wanted: Vec<(BeamKey, f64)>,
    eye: Option<EyeSphere>,
}

/// The server.
pub struct Server {
    cache: BeamCache,
    mode: Mode,
    config: ServerConfig,
    requests: crate::requests::RequestList,
    /// Rays assigned to workers and not yet returned, per beam.
    pending: BeamMap<BeamKey, u32>,
    /// Per-beam weight in batch mode (mean 1).
    weights: BeamMap<BeamKey, f64>,
    workers: BTreeMap<WorkerId, WorkerState>,
    next_worker: WorkerId,
    packets: BeamMap<u64, Packet>,
    orphans: VecDeque<u64>,
    next_packet: u64,
    displays: BTreeMap<DisplayId, DisplayRequest>,
    /// Per beam, the eyes of the displays that want it and how many samples each wants.
    eyes: BeamMap<BeamKey, Vec<(EyeSphere, f64)>>,
    codes: Vec<DistanceCode>,
    rng: SmallRng,
    stats: Stats,
}

impl Server {
    /// A server over a holodeck file open for writing.
    pub fn new(file: HoloFile, mode: Mode, config: ServerConfig) -> Self {
        let codes = file
            .sections()
            .iter()
            .map(|s| DistanceCode::new(s.size()))
            .collect();
        let samples: u64 = (0..file.sections().len())
            .map(|s| {
                file.directory(s)
                    .iter()
                    .map(|e| u64::from(e.count))
                    .sum::<u64>()
            })
            .sum();
        // Distinct per run (the file changes), so a resumed fill draws new rays.
        let rng = SmallRng::seed_from_u64(file.seq().wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ samples);
        let mut server = Server {
            cache: BeamCache::new(file, config.cache_bytes),
            mode,
            config,
            requests: Default::default(),
            pending: BeamMap::default(),
            weights: BeamMap::default(),
            workers: BTreeMap::new(),
            next_worker: 1,
            packets: BeamMap::default(),
            orphans: VecDeque::new(),
            next_packet: 1,
            displays: BTreeMap::new(),
            eyes: BeamMap::default(),
            codes,
            rng,
            stats: Stats {
                samples,
                ..Default::default()
            },
        };
        if mode == Mode::Batch {
            server.request_by_volume();
        }
        server
    }

    /// Batch mode: every beam wanted in proportion to its volume.
    fn request_by_volume(&mut self) {
        let mut w = BeamMap::default();
        for (si, s) in self.cache.file().sections().iter().enumerate() {
            for b in 0..s.beam_count() {
                w.insert(BeamKey::new(si as u16, b), s.beam_volume(b, 2));
            }
        }
        let mean = w.values().sum::<f64>() / w.len().max(1) as f64;
        w.retain(|_, v| *v > 0.0);
        for v in w.values_mut() {
            *v /= mean;
        }
        let (cache, pending) = (&self.cache, &self.pending);
        self.requests.set(w.clone(), |k| {
            cache.count(k) + pending.get(&k).copied().unwrap_or(0)
        });
        self.weights = w;
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    pub fn stats(&self) -> Stats {
        Stats {
            workers: self.workers.len(),
            ..self.stats
        }
    }

    pub fn cache(&self) -> &BeamCache {
        &self.cache
    }

    /// Registers a worker.
    pub fn add_worker(&mut self) -> WorkerId {
        let id = self.next_worker;
        self.next_worker += 1;
        self.workers.insert(
            id,
            WorkerState {
                in_flight: Vec::new(),
                rays_in_flight: 0,
                rate: None,
                last_done: 0.0,
            },
        );
        id
    }

    /// A worker left (or died): its in-flight packets go back for reassignment.
    pub fn remove_worker(&mut self, id: WorkerId) {
        if let Some(w) = self.workers.remove(&id) {
            for p in w.in_flight {
                if let Some(pk) = self.packets.get_mut(&p) {
                    pk.worker = None;
                    self.orphans.push_back(p);
                }
            }
        }
    }

    /// Ray packets for a worker, keeping its queue about `queue_seconds` deep. Empty when
    /// the worker's queue is full or there is nothing to compute.
    pub fn next_packets(&mut self, id: WorkerId, now: f64) -> Vec<RayPacket> {
        let mut out = Vec::new();
        let Some(w) = self.workers.get(&id) else {
            return out;
        };
        let rate = w.rate.unwrap_or(self.config.initial_rate);
        let target = ((rate * self.config.queue_seconds) as usize)
            .clamp(2 * MIN_PACKET_RAYS, 2 * MAX_PACKET_RAYS);
        let size = (target / 2).clamp(MIN_PACKET_RAYS, MAX_PACKET_RAYS);
        while self.workers[&id].rays_in_flight < target {
            let pid = match self.orphans.pop_front() {
                Some(p) => {
                    self.stats.packets_reassigned += 1;
                    p
                }
                None => match self.build_packet(size) {
                    Some(p) => p,
                    None => break,
                },
            };
            let p = self.packets.get_mut(&pid).expect("queued packets exist");
            p.worker = Some(id);
            p.sent_at = now;
            let w = self.workers.get_mut(&id).expect("checked above");
            w.in_flight.push(pid);
            w.rays_in_flight += p.rays.len();
            out.push(p.rays.clone());
        }
        out
    }

    fn have(&self, key: BeamKey) -> u32 {
        self.cache.count(key) + self.pending.get(&key).copied().unwrap_or(0)
    }

    fn build_packet(&mut self, size: usize) -> Option<u64> {
        let limit = if self.mode == Mode::Batch {
            f64::INFINITY
        } else {
            1.0
        };
        let mut rays = RayPacket {
            id: self.next_packet,
            seed: self.rng.random(),
            rays: Vec::new(),
        };
        let mut bundles = Vec::new();
        let mut n_rays = 0;
        while n_rays < size {
            let (cache, pending) = (&self.cache, &self.pending);
            let have = |k| cache.count(k) + pending.get(&k).copied().unwrap_or(0);
            let Some((key, _)) = self.requests.pop(have, limit) else {
                break;
            };
            let want = match self.mode {
                Mode::Batch => (self.weights[&key] * BATCH_BUNDLE).round(),
                _ => (self.requests.wanted(key) - f64::from(self.have(key))).ceil(),
            };
            let n = (want.max(1.0) as usize)
                .min(self.config.max_bundle as usize)
                .min(size - n_rays);
            let section = &self.cache.file().sections()[usize::from(key.section)];
            // Several displays (both eyes of a stereo wall) may want a beam: each bundle
            // passes near one of their eyes, drawn in proportion to what each wants.
            let eye = match self.eyes.get(&key) {
                Some(eyes) if self.mode == Mode::Interactive && !eyes.is_empty() => {
                    let total: f64 = eyes.iter().map(|e| e.1).sum();
                    let mut x = self.rng.random::<f64>() * total;
                    eyes.iter()
                        .find(|e| {
                            x -= e.1;
                            x < 0.0
                        })
                        .or(eyes.last())
                        .map(|e| e.0)
                }
                _ => None,
            };
            let codes = match eye {
                Some(eye) => proximity::near_eye(section, key.beam, eye, n, &mut self.rng).0,
                None => proximity::uniform(n, &mut self.rng),
            };
            let mut offsets = Vec::with_capacity(n);
            for &(e, x) in &codes {
                let r = section
                    .trace_ray(key.beam, e, x)
                    .expect("requested beams exist");
                rays.push(r.origin.as_vec3().to_array(), r.dir.as_vec3().to_array());
                offsets.push(r.offset);
            }
            *self.pending.entry(key).or_default() += n as u32;
            n_rays += n;
            self.requests.requeue(key, self.have(key));
            bundles.push(Bundle {
                key,
                codes,
                offsets,
            });
        }
        if bundles.is_empty() {
            return None;
        }
        let id = self.next_packet;
        self.next_packet += 1;
        self.stats.rays_assigned += n_rays as u64;
        self.packets.insert(
            id,
            Packet {
                rays,
                bundles,
                worker: None,
                sent_at: 0.0,
            },
        );
        Some(id)
    }

    /// Stores a worker's results. Returns the new samples per beam for displays (nothing
    /// while no display has asked for beams, as in batch mode).
    pub fn complete(
        &mut self,
        id: WorkerId,
        result: &SamplePacket,
        now: f64,
    ) -> Result<Vec<BeamSamples>, ServerError> {
        let pid = result.id;
        let holds = self.packets.get(&pid).is_some_and(|p| p.worker == Some(id));
        if !holds {
            return Err(ServerError::UnknownPacket {
                worker: id,
                packet: pid,
            });
        }
        let rays = self.packets[&pid].rays.len();
        let w = self
            .workers
            .get_mut(&id)
            .expect("a packet's worker is registered");
        w.in_flight.retain(|&p| p != pid);
        w.rays_in_flight -= rays;
        let results = match result.results() {
            Ok(r) if r.len() == rays => r,
            other => {
                // Bad answer: the packet goes to another worker.
                self.packets.get_mut(&pid).expect("held").worker = None;
                self.orphans.push_back(pid);
                return Err(match other {
                    Ok(r) => ServerError::WrongCount {
                        packet: pid,
                        rays,
                        results: r.len(),
                    },
                    Err(e) => e.into(),
                });
            }
        };
        let packet = self.packets.remove(&pid).expect("held");
        let busy = now - packet.sent_at.max(w.last_done);
        if busy > 0.0 {
            let inst = rays as f64 / busy;
            w.rate = Some(w.rate.map_or(inst, |r| 0.7 * r + 0.3 * inst));
        }
        w.last_done = now;
        let mut out = Vec::with_capacity(packet.bundles.len());
        let mut it = results.into_iter();
        for b in packet.bundles {
            let code = self.codes[usize::from(b.key.section)];
            let samples: Vec<PackedSample> = b
                .codes
                .iter()
                .zip(&b.offsets)
                .zip(it.by_ref())
                .map(|((&(entry, exit), &off), (rad, d))| PackedSample {
                    rgbe: rgbe::encode(rad),
                    entry,
                    exit,
                    dist: code.encode((f64::from(d) + off) as f32),
                })
                .collect();
            self.cache.add(b.key, &samples)?;
            let p = self
                .pending
                .get_mut(&b.key)
                .expect("assigned beams are pending");
            *p -= samples.len() as u32;
            if *p == 0 {
                self.pending.remove(&b.key);
            }
            self.stats.samples += samples.len() as u64;
            self.stats.added += samples.len() as u64;
            if !self.displays.is_empty() {
                out.push(BeamSamples {
                    key: b.key,
                    samples,
                });
            }
        }
        Ok(out)
    }

    /// A display's wanted beams and eye (replacing its previous list); the lists of all
    /// displays are merged. Fails, changing nothing, if a beam is not in the holodeck.
    pub fn set_requests(
        &mut self,
        display: DisplayId,
        wanted: Vec<(BeamKey, f64)>,
        eye: Option<EyeSphere>,
    ) -> Result<(), ServerError> {
        for &(key, _) in &wanted {
            let ok = self
                .cache
                .file()
                .sections()
                .get(usize::from(key.section))
                .is_some_and(|sec| key.beam < sec.beam_count());
            if !ok {
                return Err(ServerError::NoBeam {
                    section: key.section,
                    beam: key.beam,
                });
            }
        }
        self.displays
            .insert(display, DisplayRequest { wanted, eye });
        self.merge_displays();
        Ok(())
    }

    /// The stored samples of `beams` from index `from(beam)` on (from the cache, or the
    /// file, which loads them into the cache), in file order, beams with none left out.
    pub fn stored_samples(
        &mut self,
        beams: impl IntoIterator<Item = BeamKey>,
        from: impl Fn(BeamKey) -> u32,
    ) -> Result<Vec<BeamSamples>, ServerError> {
        let mut have: Vec<BeamKey> = beams
            .into_iter()
            .filter(|&k| self.cache.count(k) > from(k))
            .collect();
        have.sort_by_key(|&k| {
            (
                !self.cache.contains(k),
                self.cache
                    .file()
                    .count(usize::from(k.section), k.beam)
                    .min(1),
                self.file_offset(k),
            )
        });
        have.dedup();
        have.into_iter()
            .map(|key| {
                let skip = from(key) as usize;
                let all = self.cache.get(key)?;
                Ok(BeamSamples {
                    key,
                    samples: all[skip.min(all.len())..].to_vec(),
                })
            })
            .collect()
    }

    fn file_offset(&self, k: BeamKey) -> u64 {
        self.cache
            .file()
            .entry(usize::from(k.section), k.beam)
            .map_or(0, |e| e.offset)
    }

    /// A display went away.
    pub fn remove_display(&mut self, display: DisplayId) {
        self.displays.remove(&display);
        self.merge_displays();
    }

    fn merge_displays(&mut self) {
        let mut wanted: BeamMap<BeamKey, f64> = BeamMap::default();
        self.eyes.clear();
        for d in self.displays.values() {
            for &(k, w) in &d.wanted {
                let slot = wanted.entry(k).or_default();
                *slot = slot.max(w);
                if let Some(e) = d.eye {
                    self.eyes.entry(k).or_default().push((e, w));
                }
            }
        }
        let (cache, pending) = (&self.cache, &self.pending);
        self.requests.set(wanted, |k| {
            cache.count(k) + pending.get(&k).copied().unwrap_or(0)
        });
    }

    /// Writes changed beams and commits.
    pub fn flush(&mut self) -> Result<u64, ServerError> {
        Ok(self.cache.flush()?)
    }

    /// Flushes and closes.
    pub fn into_file(self) -> Result<HoloFile, ServerError> {
        Ok(self.cache.into_file()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::{Section, ViewClass};
    use glam::DVec3;

    fn server(mode: Mode) -> (tempfile::TempDir, Server) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.hdk");
        let s = Section::axis_aligned(
            DVec3::ZERO,
            DVec3::new(2.0, 1.0, 1.0),
            [3, 2, 2],
            ViewClass::Interior,
        )
        .unwrap();
        let h = HoloFile::create(&p, vec![s], Default::default()).unwrap();
        (dir, Server::new(h, mode, ServerConfig::default()))
    }

    /// A fake tracer: radiance from the direction, escaped rays.
    fn answer(p: &RayPacket) -> SamplePacket {
        let mut s = SamplePacket {
            id: p.id,
            results: Vec::new(),
        };
        for (_, d) in p.rays().unwrap() {
            s.push([d[0].abs(), d[1].abs(), d[2].abs()], 1.5);
        }
        s
    }

    /// Simulates one worker tracing `rate` rays/s for `packets` packets; returns the time.
    fn run_worker(srv: &mut Server, w: WorkerId, rate: f64, packets: usize, mut t: f64) -> f64 {
        let mut queue = VecDeque::new();
        for _ in 0..packets {
            queue.extend(srv.next_packets(w, t));
            let Some(p) = queue.pop_front() else { break };
            t += p.len() as f64 / rate;
            srv.complete(w, &answer(&p), t).unwrap();
        }
        t
    }

    #[test]
    fn batch_fills_in_proportion_to_volume() {
        let (_d, mut srv) = server(Mode::Batch);
        let w = srv.add_worker();
        run_worker(&mut srv, w, 2000.0, 100, 0.0);
        let weights = srv.weights.clone();
        let ratios: Vec<f64> = weights
            .iter()
            .map(|(k, w)| f64::from(srv.cache.count(*k)) / w)
            .collect();
        let (lo, hi) = ratios
            .iter()
            .fold((f64::MAX, 0f64), |(a, b), &x| (a.min(x), b.max(x)));
        let min_w = weights.values().cloned().fold(f64::MAX, f64::min);
        // Even to within one bundle of the least-weighted beam (plus what is in flight).
        assert!(
            lo > 0.0 && hi - lo <= (BATCH_BUNDLE * 2.0 + 1.0) / min_w,
            "{lo} {hi}"
        );
        assert_eq!(srv.stats().samples, srv.stats().added);
        let added = srv.stats().added;
        let h = srv.into_file().unwrap();
        let stored: u64 = h.directory(0).iter().map(|e| u64::from(e.count)).sum();
        assert_eq!(stored, added);
    }

    #[test]
    fn queue_depth_follows_worker_rate() {
        let (_d, mut srv) = server(Mode::Batch);
        let w = srv.add_worker();
        let first: usize = srv.next_packets(w, 0.0).iter().map(|p| p.len()).sum();
        assert!(first >= (200.0 * 3.0) as usize && first < 700, "{first}");
        assert!(srv.next_packets(w, 0.0).is_empty(), "queue full");
        srv.remove_worker(w);
        // A worker tracing 10,000 rays/s: its queue deepens to about 30,000 rays.
        let w = srv.add_worker();
        let t = run_worker(&mut srv, w, 10_000.0, 60, 0.0);
        let rate = srv.workers[&w].rate.unwrap();
        assert!((rate / 10_000.0 - 1.0).abs() < 0.2, "{rate}");
        let queued = srv.workers[&w].rays_in_flight
            + srv
                .next_packets(w, t)
                .iter()
                .map(|p| p.len())
                .sum::<usize>();
        let seconds = queued as f64 / rate;
        assert!(
            (2.0..=4.0).contains(&seconds),
            "queue drains in {seconds} s"
        );
    }

    #[test]
    fn a_dying_worker_loses_only_its_packets_which_are_reassigned() {
        let (_d, mut srv) = server(Mode::Batch);
        let a = srv.add_worker();
        let b = srv.add_worker();
        let lost = srv.next_packets(a, 0.0);
        let lost_rays: usize = lost.iter().map(|p| p.len()).sum();
        srv.remove_worker(a);
        let got = srv.next_packets(b, 0.0);
        assert_eq!(
            &got[..lost.len()],
            &lost[..],
            "same packets, same rays and seeds"
        );
        for p in &got {
            srv.complete(b, &answer(p), 1.0).unwrap();
        }
        assert!(srv.stats().added >= lost_rays as u64);
        assert_eq!(srv.stats().packets_reassigned, lost.len() as u64);
        assert!(srv.pending.is_empty());
        // A late answer from the dead worker is refused, not stored twice.
        assert!(matches!(
            srv.complete(a, &answer(&lost[0]), 2.0),
            Err(ServerError::UnknownPacket { .. })
        ));
        // A short answer sends the packet elsewhere.
        let p = srv.next_packets(b, 3.0).remove(0);
        let mut short = answer(&p);
        short.results.truncate(16);
        assert!(matches!(
            srv.complete(b, &short, 4.0),
            Err(ServerError::WrongCount { .. })
        ));
        assert_eq!(srv.orphans.front(), Some(&p.id));
    }

    #[test]
    fn interactive_requests_merge_and_replay_from_cache() {
        let (_d, mut srv) = server(Mode::Interactive);
        let w = srv.add_worker();
        let eye = EyeSphere {
            pos: DVec3::new(1.0, 0.5, 0.5),
            radius: 0.2,
        };
        srv.set_requests(
            0,
            vec![(BeamKey::new(0, 3), 10.0), (BeamKey::new(0, 4), 5.0)],
            Some(eye),
        )
        .unwrap();
        srv.set_requests(1, vec![(BeamKey::new(0, 3), 30.0)], None)
            .unwrap();
        assert_eq!(srv.requests.wanted(BeamKey::new(0, 3)), 30.0);
        let mut t = 0.0;
        loop {
            let pk = srv.next_packets(w, t);
            if pk.is_empty() {
                break;
            }
            for p in pk {
                t += 0.1;
                srv.complete(w, &answer(&p), t).unwrap();
            }
        }
        assert_eq!(srv.cache.count(BeamKey::new(0, 3)), 30);
        assert_eq!(srv.cache.count(BeamKey::new(0, 4)), 5);
        // What is stored is there at once, from any index on.
        srv.set_requests(
            2,
            vec![(BeamKey::new(0, 4), 5.0), (BeamKey::new(0, 3), 1.0)],
            None,
        )
        .unwrap();
        let got = srv
            .stored_samples([BeamKey::new(0, 4), BeamKey::new(0, 3)], |_| 0)
            .unwrap();
        assert_eq!(got.iter().map(|b| b.samples.len()).sum::<usize>(), 35);
        let rest = srv
            .stored_samples([BeamKey::new(0, 4), BeamKey::new(0, 3)], |k| {
                if k == BeamKey::new(0, 3) { 25 } else { 5 }
            })
            .unwrap();
        assert_eq!(rest.len(), 1);
        assert_eq!(
            rest[0].samples,
            got.iter()
                .find(|b| b.key == BeamKey::new(0, 3))
                .unwrap()
                .samples[25..]
        );
        assert!(
            srv.set_requests(2, vec![(BeamKey::new(0, 1 << 30), 1.0)], None)
                .is_err()
        );
        srv.remove_display(0);
        srv.remove_display(1);
        assert_eq!(srv.requests.wanted(BeamKey::new(0, 3)), 1.0);
    }
}
