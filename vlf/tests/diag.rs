mod common;
use glam::Vec3;
use holocave_scene::Hit;
use holocave_vlf::{Settings, layout};

#[test]
fn diag() {
    let scene = common::closed_box("furnace", 1.0, common::lambert("g", 0.5, Vec3::ONE));
    for (mb, ds) in [(0u32, 256u32), (0, 4096), (200, 256)] {
        let settings = Settings {
            directions: 162,
            resolution: 64,
            element_size: Some(0.1),
            direct_samples: ds,
            tolerance: 1e-3,
            max_bounces: mb,
        };
        let (state, _) = common::bake_quiet(&scene, &settings);
        let el = layout(&scene, &settings);
        let (_, centre) = el.areas_and_centres(&scene);
        let mut bins = vec![(0f64, 0f64, 0usize, 0f64); 8];
        for (e, &(t, u, v)) in centre.iter().enumerate() {
            let c = el.triangles[t as usize];
            if (e as u32) >= c.base(1) {
                continue;
            }
            let p = scene
                .surface(&Hit {
                    triangle: t,
                    t: 0.0,
                    u,
                    v,
                })
                .position;
            let d = p.to_array().map(|c| c.min(1.0 - c));
            let mut s = d;
            s.sort_by(f32::total_cmp);
            let dist = s[1];
            let b = ((dist / 0.0667) as usize).min(7);
            let expect = if mb == 0 {
                std::f32::consts::PI
            } else {
                std::f32::consts::PI * 2.0
            };
            let err = (state.irradiance[e][0] / expect - 1.0) as f64;
            bins[b].0 += err;
            bins[b].1 += err * err;
            bins[b].2 += 1;
            bins[b].3 = bins[b].3.max(err.abs());
        }
        for (i, (s, s2, n, m)) in bins.iter().enumerate() {
            if *n > 0 {
                eprintln!(
                    "mb {mb} ds {ds} bin {i}: n {n} mean {:.4} rms {:.4} max {:.4}",
                    s / *n as f64,
                    (s2 / *n as f64).sqrt(),
                    m
                );
            }
        }
    }
}
