//! Where a path's light and noise come from: renders a wall view with the tracer's
//! defaults (paths per second on all cores), then splits each path's radiance by the
//! vertex where it was gathered (emission met there plus the light sampled there) and
//! reports each vertex's share of the mean and of the variance per path.
//!
//! A path traced with `max_depth = k` draws exactly the random numbers of the same path
//! traced longer, up to its end, so `L(k) − L(k − 1)` is what the `k`-th vertex adds.
//!
//! ```text
//! cargo run --release -p holocave-tracer --example path_profile -- \
//!     SCENE.gltf EYE "PA;PB;PC" WxH SPP [OUT.exr]
//! ```
//!
//! With `OUT.exr`, the timed render is written there (to score it against a reference).

use std::sync::Arc;
use std::time::Instant;

use glam::{Vec2, Vec3};
use holocave_cave::{Size, WallView};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::render::render;
use holocave_tracer::{TraceSettings, Tracer};

/// Vertices reported one by one; the rest are summed into the last line.
const DEPTHS: usize = 8;

fn vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>().map_err(|e| format!("{s:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("{s:?}: expected X,Y,Z")),
    }
}

fn luminance(c: [f32; 3]) -> f64 {
    f64::from(holocave_scene::luminance(Vec3::from(c)))
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (scene_path, eye, wall, size, spp, out) = match &args[..] {
        [a, b, c, d, e] => (a, b, c, d, e, None),
        [a, b, c, d, e, f] => (a, b, c, d, e, Some(f)),
        _ => {
            return Err("usage: path_profile SCENE.gltf EYE \"PA;PB;PC\" WxH SPP [OUT.exr]".into());
        }
    };
    let corners: Vec<Vec3> = wall.split(';').map(vec3).collect::<Result<_, _>>()?;
    let [pa, pb, pc] = corners[..] else {
        return Err(format!("{wall:?}: expected three corners PA;PB;PC"));
    };
    let size: Size = size.parse()?;
    let (w, h) = (size.width, size.height);
    let spp: u32 = spp.parse().map_err(|e| format!("{spp:?}: {e}"))?;
    let scene = Scene::load(scene_path.as_ref(), &LoadOptions::default())
        .map_err(|e| format!("{scene_path}: {e}"))?;
    let scene = Arc::new(scene);
    let view = WallView {
        eye: vec3(eye)?,
        pa,
        pb,
        pc,
        size,
    };

    let defaults = TraceSettings::default();
    let tracer = Tracer::new(scene.clone(), defaults);
    let start = Instant::now();
    let image = render(&tracer, &view, spp, 1, &|| {});
    let secs = start.elapsed().as_secs_f64();
    if let Some(out) = out {
        image
            .write_exr(out.as_ref())
            .map_err(|e| format!("{out}: {e}"))?;
    }
    let paths = f64::from(w * h * spp);
    println!(
        "{w}x{h} at {spp} spp: {secs:.2} s, {:.3} M paths/s on {} threads",
        paths / secs / 1e6,
        rayon::current_num_threads()
    );

    // The same paths cut after 1, 2, … vertices: one tracer per length.
    let cut: Vec<Tracer> = (1..=DEPTHS as u32)
        .map(|k| {
            let settings = TraceSettings {
                max_depth: k,
                ..defaults
            };
            Tracer::new(scene.clone(), settings)
        })
        .collect();
    // Per vertex: the mean contribution, and the variance among one pixel's paths (the
    // noise), averaged over pixels.
    let mut mean = [0.0f64; DEPTHS + 1];
    let mut var = [0.0f64; DEPTHS + 1];
    let pixels = f64::from(w * h);
    for y in 0..h {
        for x in 0..w {
            let ray = view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (mut sum, mut sum2) = ([0.0f64; DEPTHS + 1], [0.0f64; DEPTHS + 1]);
            for s in 0..u64::from(spp) {
                let index = (u64::from(y * w + x) << 20) | s;
                let mut before = 0.0;
                for k in 0..=DEPTHS {
                    let t = cut.get(k).unwrap_or(&tracer);
                    let l = luminance(t.trace_one(&ray, 7, index).radiance);
                    sum[k] += l - before;
                    sum2[k] += (l - before).powi(2);
                    before = l;
                }
            }
            let n = f64::from(spp);
            for k in 0..=DEPTHS {
                let m = sum[k] / n;
                mean[k] += m / pixels;
                var[k] += (sum2[k] / n - m * m).max(0.0) / pixels;
            }
        }
    }
    print_shares(&mean, &var);
    Ok(())
}

/// Each vertex's share of the path's mean and variance, and the totals.
fn print_shares(mean: &[f64; DEPTHS + 1], var: &[f64; DEPTHS + 1]) {
    let (total_mean, total_var) = (mean.iter().sum::<f64>(), var.iter().sum::<f64>());
    println!("vertex  share of mean  share of variance (per-vertex, without covariances)");
    for k in 0..=DEPTHS {
        let label = if k < DEPTHS {
            format!("{}", k + 1)
        } else {
            format!(">{DEPTHS}")
        };
        println!(
            "{label:>6}  {:>12.1}%  {:>17.1}%",
            100.0 * mean[k] / total_mean,
            100.0 * var[k] / total_var
        );
    }
    println!(
        "per path: mean luminance {total_mean:.5}, variance {total_var:.5} (the vertices' sum), \
         relative {:.3}",
        total_var / (total_mean * total_mean)
    );
}
