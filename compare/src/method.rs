//! The ways of drawing a wall that are compared, each given the same ray budget per eye
//! and frame, and what each keeps between frames.

use std::sync::Arc;
use std::time::{Duration, Instant};

use holocave_cave::WallView;
use holocave_holodeck::run::{RayAllowance, Running};
use holocave_render_node::{EyeView, RenderCache, SampleFeed, VlfBase, WallDisplay};
use holocave_tracer::Tracer;
use holocave_tracer::film::Image;
use holocave_tracer::render::render;

/// A display method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Path tracing from scratch every frame at the budget: a renderer with no cache.
    Trace,
    /// The same, averaged over frames while the view stays put, reset when it moves.
    Accumulate,
    /// The render cache fed by the tracer (the budget is its samples per eye and frame;
    /// beyond one per pixel, paths averaged per sample).
    Cache,
    /// The render cache fed by a holodeck in this process, its tracer threads on the same
    /// cores and held to the budget: each frame they trace exactly the budget's rays
    /// (fewer only when the holodeck has nothing left to trace), and the frame waits for
    /// them (cold: a new file; warm: a file from an earlier run).
    Holodeck,
    /// The Virtual Light Field alone, drawn as a render node draws it (one lookup per
    /// pixel, shaded on the GPU): no paths traced at all.
    Vlf,
    /// The whole system: the holodeck's samples in the render cache over the light field.
    VlfHolodeck,
    /// The render cache over the light field, fed by gathers: samples with the direct
    /// light exact at the point seen and after one bounce, the field beyond
    /// (`holocave_vlf::gather`), at the budget's samples per eye and frame.
    VlfGather,
}

impl Method {
    pub const ALL: [Method; 7] = [
        Method::Trace,
        Method::Accumulate,
        Method::Cache,
        Method::Holodeck,
        Method::Vlf,
        Method::VlfHolodeck,
        Method::VlfGather,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::Trace => "trace",
            Method::Accumulate => "accumulate",
            Method::Cache => "cache",
            Method::Holodeck => "holodeck",
            Method::Vlf => "vlf",
            Method::VlfHolodeck => "vlf+holodeck",
            Method::VlfGather => "vlf+gather",
        }
    }

    /// Whether the method draws a baked light field.
    pub fn needs_vlf(self) -> bool {
        matches!(self, Method::Vlf | Method::VlfHolodeck | Method::VlfGather)
    }
}

/// A method by its name; the error lists the names.
impl std::str::FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Method, String> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
                format!("{s:?} is not a method (methods: {})", names.join(", "))
            })
    }
}

/// A frame as a method drew it: one image per eye and the rays it traced for it.
pub struct Drawn {
    pub images: Vec<Image>,
    pub rays: u64,
    /// Rays of the frame's budget not traced because the method had nothing to trace
    /// them for (the holodeck methods only; the others spend theirs or have none).
    pub unspent: u64,
}

/// Paths per pixel that spend `budget` rays on a `width`×`height` eye (at least one: a
/// path tracer cannot trace part of a path per pixel).
pub fn spp_for(budget: u32, width: u32, height: u32) -> u32 {
    (budget / (width * height).max(1)).max(1)
}

/// A method's state over a replay.
pub enum Drawer {
    Trace {
        tracer: Arc<Tracer>,
        spp: u32,
    },
    Accumulate {
        tracer: Arc<Tracer>,
        spp: u32,
        /// Per eye: the view accumulated, the sum of its frames and how many.
        sums: Vec<Option<(WallView, Image, u32)>>,
    },
    /// The cache fed `paths` paths per sample.
    Cache {
        display: WallDisplay,
        paths: u32,
    },
    /// The light field alone: a render cache used only for its light-field pass.
    Vlf {
        cache: RenderCache,
        base: Arc<VlfBase>,
    },
    /// The render cache fed by a holodeck whose threads are held to `allowance`.
    Holodeck {
        display: WallDisplay,
        server: Running,
        allowance: Arc<RayAllowance>,
        /// Rays granted per frame: the budget of every eye.
        grant: u64,
        /// Eye requests the server has served for the display so far.
        requests: u64,
    },
}

impl Drawer {
    /// Draws frame `frame` of `views` (one per eye).
    pub fn draw(&mut self, views: &[EyeView], frame: u64) -> Drawn {
        match self {
            Drawer::Trace { tracer, spp } => {
                let images: Vec<Image> = views
                    .iter()
                    .enumerate()
                    .map(|(e, v)| render(tracer, &v.wall, *spp, seed(frame, e), &|| {}))
                    .collect();
                let rays = traced(&images, *spp);
                Drawn {
                    images,
                    rays,
                    unspent: 0,
                }
            }
            Drawer::Accumulate { tracer, spp, sums } => {
                accumulate(tracer, *spp, sums, views, frame)
            }
            Drawer::Vlf { cache, base } => {
                let images = views
                    .iter()
                    .enumerate()
                    .map(|(e, v)| {
                        base.draw_lookups(e, v, cache);
                        cache.vlf_image(e).unwrap_or_else(|| Image::new(1, 1))
                    })
                    .collect();
                Drawn {
                    images,
                    rays: 0,
                    unspent: 0,
                }
            }
            Drawer::Cache { display, paths } => {
                let report = display.frame(views, false);
                let images = (0..views.len()).map(|e| display.cache.image(e)).collect();
                Drawn {
                    images,
                    rays: report.inserted as u64 * u64::from(*paths),
                    unspent: 0,
                }
            }
            Drawer::Holodeck {
                display,
                server,
                allowance,
                grant,
                requests,
            } => draw_from_holodeck(display, (server, allowance, *grant), requests, views, frame),
        }
    }
}

/// Frame `frame` of `views` accumulated: each eye's fresh `spp`-sample render added to its
/// sum while its view stays the same (`sums`, per eye), the mean drawn.
fn accumulate(
    tracer: &Tracer,
    spp: u32,
    sums: &mut Vec<Option<(WallView, Image, u32)>>,
    views: &[EyeView],
    frame: u64,
) -> Drawn {
    sums.resize_with(views.len(), || None);
    let mut images = Vec::with_capacity(views.len());
    for (e, (v, slot)) in views.iter().zip(sums.iter_mut()).enumerate() {
        let fresh = render(tracer, &v.wall, spp, seed(frame, e), &|| {});
        let (sum, n) = match slot.take() {
            Some((w, mut sum, n)) if w == v.wall => {
                sum.pixels
                    .iter_mut()
                    .zip(&fresh.pixels)
                    .for_each(|(s, f)| *s += *f);
                (sum, n + 1)
            }
            _ => (fresh, 1),
        };
        let mut mean = sum.clone();
        mean.pixels.iter_mut().for_each(|p| *p /= n as f32);
        images.push(mean);
        *slot = Some((v.wall, sum, n));
    }
    let rays = traced(&images, spp);
    Drawn {
        images,
        rays,
        unspent: 0,
    }
}

/// Frame `frame` of `views` drawn by a display fed by the holodeck `server`, whose
/// threads trace `grant` rays a frame under `allowance`; `requests` counts the display's
/// requests the server has served.
fn draw_from_holodeck(
    display: &mut WallDisplay,
    (server, allowance, grant): (&Running, &RayAllowance, u64),
    requests: &mut u64,
    views: &[EyeView],
    frame: u64,
) -> Drawn {
    // Draws from the samples that have arrived and hands this frame's pixels to the
    // display's holodeck thread, which asks the server for their beams.
    let report = display.frame(views, false);
    // That request reaches the server before the rays are granted, so they are traced
    // for it, and a holodeck with nothing to trace is told apart from one whose request
    // is on its way (one request per eye, unless no pixel was chosen).
    if report.chosen.iter().any(|&n| n > 0) {
        let want = *requests + views.len() as u64;
        let t = Instant::now();
        while server.display_tally(0).requests < want {
            if t.elapsed() > REQUEST_WAIT {
                tracing::warn!(
                    "frame {frame}: the display's request has not reached the holodeck \
                     after {REQUEST_WAIT:?}; granting its rays anyway"
                );
                break;
            }
            std::thread::sleep(Duration::from_micros(100));
        }
    }
    *requests = server.display_tally(0).requests;
    allowance.grant(grant);
    let settled = allowance.settle();
    // And the display has taken in every sample the server handed it (so the next
    // frame's request counts them as there), however fast its thread.
    if let SampleFeed::Holodeck(h) = &display.feed {
        let handed = server.display_tally(0).samples;
        let t = Instant::now();
        while h.counts().received < handed && t.elapsed() < REQUEST_WAIT {
            std::thread::sleep(Duration::from_micros(100));
        }
    }
    let images = (0..views.len()).map(|e| display.cache.image(e)).collect();
    Drawn {
        images,
        rays: settled.traced,
        unspent: settled.withdrawn,
    }
}

/// How long a frame waits for its display's request to reach the holodeck, or for the
/// display to take in its samples (milliseconds on any machine; only a request or sample
/// that never comes waits this long).
const REQUEST_WAIT: Duration = Duration::from_secs(10);

/// The rays of `spp` paths per pixel of `images` (first segments: a path's bounces are
/// the tracer's business, as for every method).
fn traced(images: &[Image], spp: u32) -> u64 {
    images
        .iter()
        .map(|i| u64::from(i.width * i.height) * u64::from(spp))
        .sum()
}

/// The seed of an eye's frame: every frame and eye draws fresh paths.
fn seed(frame: u64, eye: usize) -> u64 {
    frame.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (eye as u64 + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn methods_parse_by_name_and_a_wrong_one_lists_them() {
        for m in Method::ALL {
            assert_eq!(m.name().parse(), Ok(m));
        }
        let e = "vlf-alone".parse::<Method>().unwrap_err();
        assert!(
            e.contains("trace, accumulate, cache, holodeck, vlf, vlf+holodeck, vlf+gather"),
            "{e}"
        );
    }

    #[test]
    fn the_budget_buys_whole_paths_per_pixel() {
        assert_eq!(spp_for(64 * 48, 64, 48), 1);
        assert_eq!(spp_for(4 * 64 * 48, 64, 48), 4);
        assert_eq!(spp_for(100, 64, 48), 1);
    }
}
