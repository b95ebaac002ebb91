//! Rendering a wall view into an image: each pixel the mean of `spp` stratified path
//! samples through its patch of the screen, rows traced in parallel.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::Tracer;
use crate::film::Image;
use holocave_cave::WallView;

/// Renders `view` with `spp` samples per pixel. `on_row` is called once per finished row
/// (from any thread), for progress reporting. Deterministic for a given `seed`.
pub fn render(
    tracer: &Tracer,
    view: &WallView,
    spp: u32,
    seed: u64,
    on_row: &(dyn Fn() + Sync),
) -> Image {
    let mut image = Image::new(view.size.width, view.size.height);
    let w = view.size.width as usize;
    image
        .pixels
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| {
            let row_seed = seed ^ (y as u64 + 1).wrapping_mul(0xA076_1D64_78BD_642F);
            let mut jitter = Pcg32::seed_from_u64(row_seed);
            for (x, px) in row.iter_mut().enumerate() {
                let rays = view.pixel_rays(x as u32, y as u32, spp, || jitter.random());
                let samples =
                    tracer.trace_serial(&rays, row_seed.wrapping_add(x as u64 * u64::from(spp)));
                let sum: Vec3 = samples.iter().map(|s| Vec3::from(s.radiance)).sum();
                *px = sum / spp.max(1) as f32;
            }
            on_row();
        });
    image
}
