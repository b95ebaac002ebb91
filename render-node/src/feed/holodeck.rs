//! Samples from a holodeck server (the holodeck paper's display process, §2.4.2): the chosen
//! pixels of each eye become jittered eye rays, the rays become beam requests (how many
//! samples each beam should have, per eye, with the eye for proximity sampling), and the
//! samples the server sends — stored ones at once, new ones as workers trace them, for this
//! wall's eyes or any other display's — become [`NewSample`]s of the eye they suit best.
//!
//! A sample is a ray with a radiance and the distance to what it hit; its world point is
//! where it lands ([`WorldSample`], as `holocave holodeck view` decodes it) and its pixel is
//! that point's projection into the eye. A ray that passed within the proximity radius of
//! the eye counts as traced from the eye (its origin is the eye, so a still view averages
//! such samples and converges); any other keeps the point of its line nearest the eye as
//! origin, so the render cache's key (the distance by which a point's ray missed the eye)
//! is the true miss and the ray passing nearest the eye wins a pixel (§2.4.2).
//!
//! The holodeck stores no surface ids: every hit gets [`HOLODECK_SURFACE`] and escaped rays
//! [`BACKGROUND`]. The render cache uses the id only to let a sample from a slightly moved
//! eye (within 2 cm) join a point's running mean; with one id for all hits that test rests
//! on the other half of the rule, the hit lying within 5% of its distance of the point, and
//! the depth cull still separates a surface from what lies behind it. Looking up the
//! surface in the scene instead would need the scene on every display and would name the
//! mirror, not the object seen in it, for the holodeck's virtual distances.
//!
//! All of this runs on a thread of its own: a frame only hands over its chosen pixels and
//! takes the samples that have been converted, and never waits for the server.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use glam::{DVec3, Vec2};
use holocave_holodeck::auth::Credentials;
use holocave_holodeck::beam_index::BeamKey;
use holocave_holodeck::cache::BeamMap;
use holocave_holodeck::display::{DisplayClient, DisplayError, EyeRequest};
use holocave_holodeck::distance_code::DistanceCode;
use holocave_holodeck::proximity::EyeSphere;
use holocave_holodeck::serving::serving_section;
use holocave_holodeck::view::WorldSample;
use holocave_holodeck::{PackedSample, Section};
use rand::{Rng, SeedableRng, rngs::SmallRng};

use crate::EyeView;
use crate::cache::{BACKGROUND, NewSample};
use crate::feed::tracer::BACKGROUND_DISTANCE;

/// The surface id of every holodeck sample that hit something (see the module notes).
pub const HOLODECK_SURFACE: u32 = u32::MAX - 2;

/// Tunables of a [`HolodeckSource`].
#[derive(Clone, Copy, Debug)]
pub struct HolodeckOptions {
    /// New rays should pass within this distance (m) of the eye (Appendix A); samples
    /// whose ray passed this near count as traced from the eye.
    pub eye_radius: f64,
    /// Largest angle between a sample's ray and the eye's line of sight to its point for
    /// the sample to be used at all (as `holocave holodeck view`).
    pub max_angle: f64,
    /// How often the wanted beams are sent.
    pub request_every: Duration,
    /// Each request, a beam's recent demand is multiplied by this (old views fade out).
    pub decay: f64,
}

impl Default for HolodeckOptions {
    fn default() -> Self {
        HolodeckOptions {
            eye_radius: 0.02,
            max_angle: 10f64.to_radians(),
            request_every: Duration::from_millis(100),
            decay: 0.7,
        }
    }
}

/// Counters, for reports and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HolodeckCounts {
    /// Samples received from the server.
    pub received: u64,
    /// Samples that fitted an eye (seen within the angle bound, inside its image).
    pub used: u64,
    /// Of those, samples whose ray passed within the proximity radius of the eye.
    pub near: u64,
}

type Job = (Vec<EyeView>, Vec<Vec<u32>>);

/// A display's sample source fed by a holodeck server (see the module notes).
pub struct HolodeckSource {
    jobs: Option<Sender<Job>>,
    done: Receiver<(usize, Vec<NewSample>)>,
    handle: Option<JoinHandle<()>>,
    connected: Arc<AtomicBool>,
    received: Arc<AtomicU64>,
    used: Arc<AtomicU64>,
    near: Arc<AtomicU64>,
}

impl HolodeckSource {
    /// Connects to a holodeck server over TCP as display `display` (the wall's number; its
    /// eyes are slots of it), with default options.
    pub fn connect(
        addr: SocketAddr,
        display: u32,
        credentials: &Credentials,
    ) -> Result<HolodeckSource, DisplayError> {
        Ok(Self::new(
            DisplayClient::connect(addr, display, credentials)?,
            HolodeckOptions::default(),
            u64::from(display),
        ))
    }

    /// A source over an open display client (in-process:
    /// `holocave_holodeck::run::Running::display`).
    pub fn new(client: DisplayClient, options: HolodeckOptions, seed: u64) -> HolodeckSource {
        let (jobs, job_rx) = channel::<Job>();
        let (done_tx, done) = channel();
        let connected = Arc::new(AtomicBool::new(true));
        let received = Arc::new(AtomicU64::new(0));
        let used = Arc::new(AtomicU64::new(0));
        let near = Arc::new(AtomicU64::new(0));
        let mut worker = Worker {
            sections: client.sections().to_vec(),
            codes: client
                .sections()
                .iter()
                .map(|s| DistanceCode::new(s.size()))
                .collect(),
            client,
            options,
            rng: SmallRng::seed_from_u64(seed ^ 0x4844_4b20_6e6f_6465),
            views: Vec::new(),
            demand: Vec::new(),
            have: BeamMap::default(),
            fresh: false,
            best: Vec::new(),
            counts: [received.clone(), used.clone(), near.clone()],
        };
        let alive = connected.clone();
        let handle = std::thread::Builder::new()
            .name("render-node holodeck".into())
            .spawn(move || {
                let mut last_request: Option<Instant> = None;
                loop {
                    match job_rx.recv_timeout(Duration::from_millis(5)) {
                        Ok(job) => worker.add(job),
                        Err(RecvTimeoutError::Timeout) => {}
                        Err(RecvTimeoutError::Disconnected) => break,
                    }
                    for job in job_rx.try_iter() {
                        worker.add(job);
                    }
                    if worker.fresh
                        && last_request.is_none_or(|t| t.elapsed() >= worker.options.request_every)
                    {
                        worker.request();
                        last_request = Some(Instant::now());
                    }
                    for (eye, samples) in worker.receive() {
                        if done_tx.send((eye, samples)).is_err() {
                            return;
                        }
                    }
                    alive.store(worker.client.is_connected(), Ordering::SeqCst);
                }
            })
            .expect("spawn the holodeck source thread");
        HolodeckSource {
            jobs: Some(jobs),
            done,
            handle: Some(handle),
            connected,
            received,
            used,
            near,
        }
    }

    /// Hands over a frame's views and chosen pixels per eye (never blocks).
    pub fn submit(&mut self, views: &[EyeView], chosen: Vec<Vec<u32>>) {
        if let Some(j) = &self.jobs {
            let _ = j.send((views.to_vec(), chosen));
        }
    }

    /// The samples converted so far, per eye, without waiting.
    pub fn collect(&mut self) -> Vec<(usize, Vec<NewSample>)> {
        self.done.try_iter().collect()
    }

    /// Whether the link to the server is up.
    pub fn is_connected(&self) -> bool {
        self.connected.load(Ordering::SeqCst)
    }

    pub fn counts(&self) -> HolodeckCounts {
        HolodeckCounts {
            received: self.received.load(Ordering::SeqCst),
            used: self.used.load(Ordering::SeqCst),
            near: self.near.load(Ordering::SeqCst),
        }
    }
}

impl Drop for HolodeckSource {
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The source's thread.
struct Worker {
    client: DisplayClient,
    sections: Vec<Section>,
    codes: Vec<DistanceCode>,
    options: HolodeckOptions,
    rng: SmallRng,
    /// The latest views.
    views: Vec<EyeView>,
    /// Per eye: recent chosen pixels per beam (decaying).
    demand: Vec<BeamMap<BeamKey, f64>>,
    /// Samples received per beam.
    have: BeamMap<BeamKey, u32>,
    /// Pixels arrived since the last request.
    fresh: bool,
    /// Per eye: the eye position and image size these are for, and per pixel the
    /// smallest miss of the samples sent to the cache for it (0 once one passed near).
    best: Vec<(DVec3, u32, u32, Vec<f32>)>,
    counts: [Arc<AtomicU64>; 3],
}

/// A sample on its way to an eye's pixel.
struct Landed {
    eye: usize,
    pixel: u32,
    miss: f64,
    /// The point of the ray's line nearest the eye.
    nearest: DVec3,
    point: DVec3,
    radiance: [f32; 3],
    escaped: bool,
}

/// Samples of one batch passing near the eye, summed per pixel.
struct Sum {
    radiance: [f64; 3],
    n: u32,
    point: DVec3,
    escaped: bool,
}

impl Worker {
    /// The beam a jittered eye ray through `pixel` belongs to, in the section serving it
    /// ([`serving_section`]: the one holding the eye, else the first the ray enters).
    fn beam_of(&mut self, view: &EyeView, pixel: u32) -> Option<BeamKey> {
        let w = view.wall.size.width;
        let j = Vec2::new(self.rng.random(), self.rng.random());
        let ray = view
            .wall
            .ray(Vec2::new((pixel % w) as f32, (pixel / w) as f32) + j);
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        serving_section(&self.sections, o, d).map(|(i, c)| BeamKey::new(i as u16, c.beam))
    }

    fn add(&mut self, (views, chosen): Job) {
        self.demand.resize_with(views.len(), BeamMap::default);
        for (eye, (view, pixels)) in views.iter().zip(&chosen).enumerate() {
            for &p in pixels {
                if let Some(k) = self.beam_of(view, p) {
                    *self.demand[eye].entry(k).or_default() += 1.0;
                    self.fresh = true;
                }
            }
        }
        self.views = views;
    }

    /// Sends every eye's wanted beams: what it has of each plus its recent demand, so the
    /// server traces beams in proportion to the pixels that need them.
    fn request(&mut self) {
        for (eye, (view, demand)) in self.views.iter().zip(&mut self.demand).enumerate() {
            let wanted = demand
                .iter()
                .map(|(k, d)| {
                    (
                        *k,
                        f64::from(self.have.get(k).copied().unwrap_or(0)) + d.ceil(),
                    )
                })
                .collect();
            self.client.request(EyeRequest {
                slot: eye as u8,
                eye: Some(EyeSphere {
                    pos: view.eye().as_dvec3(),
                    radius: self.options.eye_radius,
                }),
                wanted,
            });
            for d in demand.values_mut() {
                *d *= self.options.decay;
            }
            demand.retain(|_, d| *d >= 0.5);
        }
        self.fresh = false;
    }

    /// Converts what arrived. Per eye and pixel, the samples whose rays passed near the
    /// eye are averaged into one that counts as many (the render cache's insertion
    /// handles one sample per pixel and batch),
    /// and a sample that did not is sent only if its ray passed nearer the eye than every
    /// sample sent for that pixel before (§2.4.2: the nearest ray wins, so the others would
    /// only take the place of better points in the cache).
    fn receive(&mut self) -> Vec<(usize, Vec<NewSample>)> {
        let arrivals = self.client.collect();
        if arrivals.is_empty() {
            return Vec::new();
        }
        self.reset_best();
        let radius = self.options.eye_radius * 1.25;
        let mut near: Vec<HashMap<u32, Sum>> =
            (0..self.views.len()).map(|_| HashMap::new()).collect();
        let mut far: Vec<HashMap<u32, Landed>> =
            (0..self.views.len()).map(|_| HashMap::new()).collect();
        let (mut received, mut used, mut near_count) = (0u64, 0u64, 0u64);
        for a in arrivals {
            for b in a.iter() {
                *self.have.entry(b.key).or_default() += b.samples.len() as u32;
                received += b.samples.len() as u64;
                let Some(section) = self.sections.get(usize::from(b.key.section)) else {
                    continue;
                };
                let code = &self.codes[usize::from(b.key.section)];
                for s in &b.samples {
                    let Some(l) = self.land(section, code, b.key.beam, s) else {
                        continue;
                    };
                    used += 1;
                    if l.miss <= radius {
                        near_count += 1;
                        let sum = near[l.eye].entry(l.pixel).or_insert(Sum {
                            radiance: [0.0; 3],
                            n: 0,
                            point: l.point,
                            escaped: l.escaped,
                        });
                        for (a, v) in sum.radiance.iter_mut().zip(l.radiance) {
                            *a += f64::from(v);
                        }
                        sum.n += 1;
                    } else {
                        let slot = far[l.eye].entry(l.pixel);
                        match slot {
                            Entry::Occupied(mut o) => {
                                if l.miss < o.get().miss {
                                    o.insert(l);
                                }
                            }
                            Entry::Vacant(v) => {
                                v.insert(l);
                            }
                        }
                    }
                }
            }
        }
        let c = &self.counts;
        c[0].fetch_add(received, Ordering::SeqCst);
        c[1].fetch_add(used, Ordering::SeqCst);
        c[2].fetch_add(near_count, Ordering::SeqCst);
        let mut out = Vec::new();
        for (eye, (near, far)) in near.into_iter().zip(far).enumerate() {
            let eye_pos = self.views[eye].eye().as_dvec3();
            let best = &mut self.best[eye].3;
            let mut v = Vec::with_capacity(near.len() + far.len());
            for (pixel, s) in near {
                best[pixel as usize] = 0.0;
                let radiance = s.radiance.map(|x| (x / f64::from(s.n)) as f32);
                v.push(
                    sample(pixel, eye_pos, s.point, radiance, s.escaped).with_weight(s.n as f32),
                );
            }
            for (pixel, l) in far {
                let b = &mut best[pixel as usize];
                if (l.miss as f32) < *b {
                    *b = l.miss as f32;
                    // The origin on the ray, so the cache measures the ray's true miss.
                    v.push(sample(pixel, l.nearest, l.point, l.radiance, l.escaped));
                }
            }
            if !v.is_empty() {
                out.push((eye, v));
            }
        }
        out
    }

    /// Forgets an eye's best misses when it moved (or its image changed size).
    fn reset_best(&mut self) {
        self.best.resize_with(self.views.len(), || {
            (DVec3::splat(f64::NAN), 0, 0, Vec::new())
        });
        for (b, view) in self.best.iter_mut().zip(&self.views) {
            let (eye, w, h) = (
                view.eye().as_dvec3(),
                view.wall.size.width,
                view.wall.size.height,
            );
            let d = b.0.distance(eye);
            let moved = d.is_nan() || d > self.options.eye_radius * 0.25;
            if moved || b.1 != w || b.2 != h {
                *b = (eye, w, h, vec![f32::INFINITY; (w * h) as usize]);
            }
        }
    }

    /// Where a sample lands: the eye whose line of sight it suits best (its ray passed
    /// nearest, among the eyes that see its point within the image) and the pixel.
    fn land(
        &self,
        section: &Section,
        code: &DistanceCode,
        beam: u32,
        s: &PackedSample,
    ) -> Option<Landed> {
        let ws = WorldSample::decode(section, code, beam, s)?;
        let mut best: Option<Landed> = None;
        for (i, view) in self.views.iter().enumerate() {
            let eye = view.eye().as_dvec3();
            if ws
                .seen_from(eye, self.options.max_angle, section.size())
                .is_none()
            {
                continue;
            }
            let point = if ws.escaped() {
                eye + ws.dir * f64::from(BACKGROUND_DISTANCE)
            } else {
                ws.point(0.0)
            };
            let Some((x, y, _)) = view.project(point.as_vec3()) else {
                continue;
            };
            let (w, h) = (view.wall.size.width, view.wall.size.height);
            if !(x >= 0.0 && y >= 0.0 && x < w as f32 && y < h as f32) {
                continue;
            }
            let miss = ws.miss(eye);
            if best.as_ref().is_none_or(|b| miss < b.miss) {
                best = Some(Landed {
                    eye: i,
                    pixel: (y as u32).min(h - 1) * w + (x as u32).min(w - 1),
                    miss,
                    nearest: ws.nearest_to(eye),
                    point,
                    radiance: ws.radiance,
                    escaped: ws.escaped(),
                });
            }
        }
        best
    }
}

/// A render-cache sample for `pixel` from a ray through `origin` to `point`.
fn sample(pixel: u32, origin: DVec3, point: DVec3, radiance: [f32; 3], escaped: bool) -> NewSample {
    let surface = if escaped {
        BACKGROUND
    } else {
        HOLODECK_SURFACE
    };
    NewSample::new(
        pixel,
        origin.as_vec3(),
        point.as_vec3(),
        (point - origin).length() as f32,
        radiance,
        surface,
    )
}
