//! The path tracer as the holodeck's sample generator ([`HolodeckTracer`]), used by
//! `holocave worker`, the hosted holodeck's tracer threads and the fill bench.

use std::collections::BTreeMap;

use holocave_holodeck::file::{DISTANCE_SETTING, DistanceKind};
use holocave_holodeck::worker::{SampleSource, SourceRay, SourceResult};
use std::sync::Arc;

use holocave_scene::{Ray, Scene};

use crate::{TraceSettings, Tracer};

/// The tracer answering holodeck ray packets, one packet per calling thread (the server
/// runs as many workers as it wants cores used). It answers the distance the holodeck file
/// records: the tracer's `virtual_distance` (the paper's `VDISTANCE=True`, the default for
/// new files) or its first-hit `distance`.
pub struct HolodeckTracer(pub Tracer);

impl HolodeckTracer {
    /// The path tracer of `scene` at its default settings, as every holodeck's tracer
    /// threads and workers run it.
    pub fn of_scene(scene: Arc<Scene>) -> HolodeckTracer {
        HolodeckTracer(Tracer::new(scene, TraceSettings::default()))
    }
}

/// [`HolodeckTracer::of_scene`] as a holodeck server's sample source.
pub fn sample_source(scene: Arc<Scene>) -> Arc<dyn SampleSource> {
    Arc::new(HolodeckTracer::of_scene(scene))
}

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

/// A scene's identity as holodeck files record it and servers check their workers
/// against: the scene file's name and the scene's fingerprint (daylight included).
pub fn scene_identity(path: &std::path::Path, scene: &holocave_scene::Scene) -> String {
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    holocave_holodeck::scene_id::scene_id(&name, scene.fingerprint())
}

/// The settings a new holodeck file filled by [`HolodeckTracer`] records: the scene's
/// identity ([`scene_identity`], checked against every worker's), the generator, the distance it stores, and the
/// command that made it (`made_by`, e.g. `fill` or `sim`).
pub fn file_settings(
    scene: &str,
    distance: DistanceKind,
    made_by: &str,
) -> BTreeMap<String, String> {
    BTreeMap::from([
        ("scene".to_string(), scene.to_string()),
        (
            "generator".to_string(),
            "holocave-tracer, default TraceSettings".to_string(),
        ),
        (DISTANCE_SETTING.to_string(), distance.name().to_string()),
        (
            "created-by".to_string(),
            format!("holocave {made_by} {}", env!("CARGO_PKG_VERSION")),
        ),
    ])
}
