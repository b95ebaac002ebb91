//! Eye rays on through mirrors and glass traced in batches (`surface::follow_all`), as a
//! render node traces them on the GPU: the same lookups and points as the rays followed
//! one by one, every further ray sent to the batch walk and none of a pixel that ends at
//! its first hit.

use std::path::Path;
use std::sync::{Arc, Mutex};

use glam::Vec2;
use holocave_cave::{Size, WallView};
use holocave_scene::{Hit, LoadOptions, Ray, Scene};
use holocave_vlf::surface::seen_at;
use holocave_vlf::view::Visibility;
use holocave_vlf::{CpuRays, Settings, ShadowQuery, StaticRays};

/// The CPU's walk, counting the batches it is given.
struct Counting<'a> {
    cpu: CpuRays<'a>,
    batches: Mutex<Vec<usize>>,
}

impl StaticRays for Counting<'_> {
    fn closest_hits(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        self.batches.lock().unwrap().push(rays.len());
        self.cpu.closest_hits(rays)
    }

    fn blocked(&self, groups: &[Vec<ShadowQuery>]) -> Vec<bool> {
        self.cpu.blocked(groups)
    }
}

#[test]
fn rays_through_mirrors_and_glass_traced_in_batches_are_the_rays_followed_one_by_one() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    let scene = Arc::new(Scene::load(&path, &LoadOptions::default()).unwrap());
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let cam = scene.cameras.iter().find(|c| c.name == "front").unwrap();
    let view = WallView::through_camera(cam, Size::new(96, 72));
    let (one_by_one, points) = vis.pixels_and_points(&view);

    let w = view.size.width as usize;
    let rays: Vec<Ray> = (0..w * view.size.height as usize)
        .map(|i| view.ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)))
        .collect();
    let firsts = CpuRays(&scene).closest_hits(&rays);
    let counting = Counting {
        cpu: CpuRays(&scene),
        batches: Mutex::new(Vec::new()),
    };
    let mut batched_points = Vec::new();
    let first_frame = holocave_vlf::view::ReflectionFrames::still(0);
    let batched = vis.pixels_into(
        &view,
        Some((&firsts, &counting)),
        &mut batched_points,
        &first_frame,
    );

    let differ = (batched.iter().zip(&one_by_one))
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "{differ} lookups differ");
    for (i, (a, b)) in points.iter().zip(&batched_points).enumerate() {
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "pixel {i}'s point");
    }
    // The pixels whose first hit is the mirror or the glass: each sends at least one ray
    // on, in the first batch, and no other pixel sends any; no pixel more than a walk of
    // the greatest depth can ask for (`most`), so no more rounds than that.
    let on = (firsts.iter())
        .filter(|h| h.is_some_and(|h| seen_at(&scene, h.triangle, h.u, h.v).delta))
        .count();
    let batches = counting.batches.into_inner().unwrap();
    let traced: usize = batches.iter().sum();
    eprintln!("{on} pixels see a mirror or glass first; {traced} rays in batches {batches:?}");
    assert!(on > 500, "{on}: too few to tell");
    assert_eq!(
        batches.first(),
        Some(&on),
        "one ray on from each, in the first batch"
    );
    assert!(batches.iter().all(|&b| b > 0), "no empty batch");
    let most = most_rays(holocave_vlf::surface::MAX_DELTA_DEPTH, true);
    assert!(
        batches.len() <= most,
        "{} rounds, at most {most}",
        batches.len()
    );
    assert!(traced <= on * most);
}

/// The most rays a walk of `depth` delta surfaces asks for past its first hit (`given`)
/// or from its start: a ray a level, and at each level but the last a glass surface's
/// weaker branch, a walk of half the depth left.
fn most_rays(depth: u32, given: bool) -> usize {
    let own = depth as usize + usize::from(!given);
    own + (0..depth)
        .map(|level| most_rays((depth - level - 1) / 2, false))
        .sum::<usize>()
}
