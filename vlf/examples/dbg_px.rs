use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_scene::{LoadOptions, Scene};
use holocave_vlf::view::shade_one;
use std::sync::Arc;
fn main() {
    let scene = Arc::new(
        Scene::load(
            std::path::Path::new("scenes/room.gltf"),
            &LoadOptions::default(),
        )
        .unwrap(),
    );
    let o = holocave_vlf::baked::open(std::path::Path::new("out/sim/room.vlf"), &scene).unwrap();
    let values = Arc::new(o.file.state.indirect_values());
    let ne = o.elements.count as u32;
    let vis = holocave_vlf::Visibility::new(scene.clone(), o.elements, o.tiles);
    vis.draw_with(values.clone(), true);
    let view = WallView {
        eye: Vec3::new(0.031412333, 1.4453603, -0.07714769),
        pa: Vec3::new(-1.5, 0., 1.5),
        pb: Vec3::new(1.5, 0., 1.5),
        pc: Vec3::new(-1.5, 0., -1.5),
        width: 128,
        height: 128,
    };
    for (x, y) in [(100, 6), (102, 6), (103, 6), (104, 6)] {
        let r = view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let (l, p) = vis.lookup_and_point(r);
        let s = shade_one(&l, &values);
        println!(
            "({x},{y}) tile {} bins {} x {:.2} y {:.2} weight {:?} emitted {:?} base {} shade {:?} refl {:?}",
            l.tile,
            l.bins,
            l.x,
            l.y,
            l.weight,
            l.emitted,
            l.base,
            s,
            p.and_then(|p| p.reflected)
        );
        if l.tile != u32::MAX {
            let g = l.tile - ne;
            let k = l.bins;
            let row: Vec<String> = (0..k * k)
                .map(|b| {
                    format!(
                        "{:.2}",
                        Vec3::from(values[(l.tile + b) as usize]).element_sum() / 3.0
                    )
                })
                .collect();
            println!("   tile {g} bins {}", row.join(" "));
        }
    }
}
