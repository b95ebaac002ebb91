//! The path tracer as the holodeck's sample generator ([`HolodeckTracer`]), used by
//! `holocave worker`, the hosted holodeck's tracer threads and the fill bench.

use holocave_holodeck::file::DistanceKind;
use holocave_holodeck::worker::{SampleSource, SourceRay, SourceResult};
use holocave_scene::Ray;

use crate::Tracer;

/// The tracer answering holodeck ray packets, one packet per calling thread (the server
/// runs as many workers as it wants cores used). It answers the distance the holodeck file
/// records: the tracer's `virtual_distance` (the paper's `VDISTANCE=True`, the default for
/// new files) or its first-hit `distance`.
pub struct HolodeckTracer(pub Tracer);

impl SampleSource for HolodeckTracer {
    fn trace(&self, rays: &[SourceRay], seed: u64, distance: DistanceKind) -> Vec<SourceResult> {
        let rays: Vec<Ray> = rays.iter().map(|r| Ray::new(r.origin, r.dir)).collect();
        self.0
            .trace_serial(&rays, seed)
            .into_iter()
            .map(|s| SourceResult {
                radiance: s.radiance,
                distance: match distance {
                    DistanceKind::FirstHit => s.distance,
                    DistanceKind::Virtual => s.virtual_distance,
                },
            })
            .collect()
    }
}
