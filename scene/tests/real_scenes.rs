//! The real scenes in `../shared/scenes/` load, with the warnings their imperfections call
//! for, and what was loaded agrees with the files (triangle counts from the README,
//! materials and cameras from the JSON).

use crate::common;

use common::{dropped_degenerate, json, load, shared_scene};
use glam::Vec3;
use holocave_scene::{LoadOptions, Scene, SceneError};

/// Checks that a scene's bounds are finite and its diagonal lies in `[min, max]` metres,
/// and that every triangle lies inside the bounds.
fn check_bounds(scene: &Scene, min_diag: f32, max_diag: f32) -> (Vec3, Vec3) {
    let (lo, hi) = scene.bounds();
    assert!(lo.is_finite() && hi.is_finite(), "bounds {lo} .. {hi}");
    assert!(lo.cmple(hi).all(), "bounds {lo} .. {hi}");
    let diag = (hi - lo).length();
    assert!(
        (min_diag..=max_diag).contains(&diag),
        "{}: bounds {lo} .. {hi} (diagonal {diag} m) outside [{min_diag}, {max_diag}]",
        scene.name
    );
    for i in 0..scene.triangle_count() as u32 {
        for p in scene.triangle(i) {
            assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{p} outside bounds");
        }
    }
    (lo, hi)
}

/// Loaded triangles plus the dropped degenerate ones equal the instanced count of the
/// file; the loaded ones are within 1 % of the README's approximate figure.
fn check_triangles(scene: &Scene, instanced: usize, readme: usize) {
    let dropped = dropped_degenerate(scene);
    assert_eq!(
        scene.triangle_count() + dropped,
        instanced,
        "{}: {} loaded + {dropped} dropped",
        scene.name,
        scene.triangle_count()
    );
    let rel = (scene.triangle_count() as f64 - readme as f64).abs() / readme as f64;
    assert!(
        rel < 0.01,
        "{}: {} triangles, README says about {readme}",
        scene.name,
        scene.triangle_count()
    );
}

/// Triangles of every mesh instance of the default scene, counted from the JSON
/// (indexed: indices / 3; non-indexed: positions / 3), walking the node hierarchy.
fn instanced_triangles(doc: &serde_json::Value) -> usize {
    let acc = |i: &serde_json::Value| {
        doc["accessors"][i.as_u64().unwrap() as usize]["count"]
            .as_u64()
            .unwrap() as usize
    };
    let mesh_tris = |m: usize| -> usize {
        doc["meshes"][m]["primitives"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| match p.get("indices") {
                Some(i) => acc(i) / 3,
                None => acc(&p["attributes"]["POSITION"]) / 3,
            })
            .sum()
    };
    fn walk(doc: &serde_json::Value, n: usize, mesh_tris: &dyn Fn(usize) -> usize) -> usize {
        let node = &doc["nodes"][n];
        let own = node["mesh"].as_u64().map_or(0, |m| mesh_tris(m as usize));
        let children: usize = node["children"]
            .as_array()
            .map(|c| {
                c.iter()
                    .map(|c| walk(doc, c.as_u64().unwrap() as usize, mesh_tris))
                    .sum()
            })
            .unwrap_or(0);
        own + children
    }
    let scene = doc["scene"].as_u64().unwrap_or(0) as usize;
    doc["scenes"][scene]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| walk(doc, n.as_u64().unwrap() as usize, &mesh_tris))
        .sum()
}

/// Triangles of each mesh counted once, however many nodes draw it.
fn unique_triangles(doc: &serde_json::Value) -> usize {
    let n = doc["meshes"].as_array().unwrap().len();
    (0..n)
        .map(|m| {
            doc["meshes"][m]["primitives"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| {
                    let a = p.get("indices").unwrap_or(&p["attributes"]["POSITION"]);
                    doc["accessors"][a.as_u64().unwrap() as usize]["count"]
                        .as_u64()
                        .unwrap() as usize
                        / 3
                })
                .sum::<usize>()
        })
        .sum()
}

fn material<'a>(scene: &'a Scene, name: &str) -> &'a holocave_scene::Material {
    scene
        .materials
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("{}: no material {name:?}", scene.name))
}

fn camera_names(scene: &Scene) -> Vec<&str> {
    scene.cameras.iter().map(|c| c.name.as_str()).collect()
}

#[test]
fn sponza_loads_leniently_with_warnings() {
    let Some(path) = shared_scene("sponza/Sponza.gltf") else {
        return;
    };
    let scene = load(&path);
    let doc = json(&path);

    assert_sponzas_warnings(&scene);

    // Textures are the core PNG/JPEG images, never the MSFT_texture_dds alternates.
    assert!(!scene.textures.is_empty());
    for t in &scene.textures {
        assert!(!t.name.ends_with(".dds"), "{} is a DDS alternate", t.name);
    }
    let bricks = material(&scene, "Bricks");
    let tex = bricks
        .base_color_texture
        .expect("Bricks has a colour texture");
    assert_eq!(
        scene.textures[tex.texture as usize].name,
        "spnza_bricks_a_diff"
    );
    assert_eq!(
        scene.textures[tex.texture as usize].encoding(),
        holocave_scene::Encoding::Srgb
    );

    // Instancing: every node's copy of a shared mesh is there (the file has far fewer
    // distinct mesh triangles than drawn ones).
    let instanced = instanced_triangles(&doc);
    assert!(unique_triangles(&doc) * 2 < instanced);
    check_triangles(&scene, instanced, 262_000);

    assert_sponzas_bounds_and_cameras(&scene);
    assert!(scene.lights.is_empty(), "Sponza carries no lights");
    // One material per glTF material, plus the default for primitives without one.
    assert_eq!(
        scene.materials.len(),
        doc["materials"].as_array().unwrap().len() + 1
    );
}

/// Sponza's warnings: its unsupported required extension, ignored, and its three missing
/// curtain textures, whose materials fall back to their factors; no other texture warning.
fn assert_sponzas_warnings(scene: &Scene) {
    // The unsupported required extension is named in a warning that says it is ignored.
    let ext: Vec<_> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("AMD_split_roughnessMetallic"))
        .collect();
    assert_eq!(ext.len(), 1, "warnings: {:#?}", scene.warnings);
    assert!(ext[0].contains("ignored"), "{}", ext[0]);

    // The three missing curtain textures: one warning each, naming the texture and the
    // fallback; their materials keep their factors and no texture.
    for (tex, mat) in [
        ("sponza_curtain_diff", "FabricC"),
        ("sponza_curtain_blue_diff", "FabricG"),
        ("sponza_curtain_green_diff", "FabricF"),
    ] {
        let w: Vec<_> = scene
            .warnings
            .iter()
            .filter(|w| w.contains(&format!("texture {tex}:")))
            .collect();
        assert_eq!(w.len(), 1, "{tex}: warnings {:#?}", scene.warnings);
        assert!(w[0].contains("fall back to their factors"), "{}", w[0]);
        let m = material(scene, mat);
        assert_eq!(m.base_color_texture, None, "{mat}");
        assert_eq!(
            m.base_color,
            glam::Vec4::ONE,
            "{mat}: glTF's default factor"
        );
    }
    // Nothing else failed to load: the two warnings above are the only texture ones.
    let texture_warnings = scene
        .warnings
        .iter()
        .filter(|w| w.starts_with("texture "))
        .count();
    assert_eq!(texture_warnings, 3, "warnings: {:#?}", scene.warnings);
}

/// Sponza's bounds and its four cameras inside them.
fn assert_sponzas_bounds_and_cameras(scene: &Scene) {
    // This rebuild of Sponza spans about 51 m × 21 m × 31 m with its roof (worked out
    // from the accessors' min/max and the node transforms); its cameras are inside.
    let (lo, hi) = check_bounds(scene, 55.0, 70.0);
    assert!(
        (lo - Vec3::new(-26.845, 2.282, -16.478))
            .abs()
            .max_element()
            < 0.01,
        "{lo}"
    );
    assert!(
        (hi - Vec3::new(24.177, 23.617, 14.900)).abs().max_element() < 0.01,
        "{hi}"
    );
    assert_eq!(
        camera_names(scene),
        [
            "CameraMain",
            "CameraAlternate",
            "CameraBalcony",
            "CameraAlcove"
        ]
    );
    for c in &scene.cameras {
        assert!(c.position.cmpge(lo).all() && c.position.cmple(hi).all());
        assert!((c.yfov - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
        assert!((c.rotation.length() - 1.0).abs() < 1e-5);
    }
    let main = &scene.cameras[0];
    assert!((main.position - Vec3::new(15.464552, 4.387878, 0.452397)).length() < 1e-4);
}

#[test]
fn sponza_strict_loading_names_the_extension() {
    let Some(path) = shared_scene("sponza/Sponza.gltf") else {
        return;
    };
    let opts = LoadOptions {
        strict: true,
        ..Default::default()
    };
    let err = Scene::load(&path, &opts)
        .err()
        .expect("strict loading must fail");
    assert!(
        matches!(&err, SceneError::UnsupportedExtension { extension, .. } if extension == "AMD_split_roughnessMetallic"),
        "{err:?}"
    );
    let msg = err.to_string();
    assert!(msg.contains("Sponza.gltf"), "{msg}");
    assert!(msg.contains("AMD_split_roughnessMetallic"), "{msg}");
    assert!(msg.contains("strict"), "{msg}");
}

#[test]
fn breakfast_room_reads_specular_and_cameras() {
    let Some(path) = shared_scene("breakfast_room/BreakfastRoom.gltf") else {
        return;
    };
    let scene = load(&path);
    let doc = json(&path);
    // It requires no extension, and all its core images exist.
    assert!(
        scene.warnings.iter().all(|w| w.contains("degenerate")),
        "unexpected warnings: {:#?}",
        scene.warnings
    );

    let gold = material(&scene, "GoldPaint");
    assert!((gold.specular - 0.8).abs() < 1e-6, "{}", gold.specular);
    assert_eq!(gold.specular_color, Vec3::ONE);
    assert!((gold.roughness - 0.1).abs() < 1e-6);
    assert_eq!(gold.metallic, 1.0, "glTF's default metallicFactor");
    assert!((gold.base_color - glam::Vec4::new(0.2, 0.1, 0.0, 1.0)).length() < 1e-6);
    // Materials without the extension keep the default specular layer.
    let white = material(&scene, "WhiteMatt");
    assert_eq!((white.specular, white.metallic), (1.0, 0.0));

    let instanced = instanced_triangles(&doc);
    assert!(
        unique_triangles(&doc) < instanced,
        "the room uses instancing"
    );
    check_triangles(&scene, instanced, 263_000);
    let (lo, hi) = check_bounds(&scene, 3.0, 30.0);

    assert_eq!(
        camera_names(&scene),
        ["CameraMain", "CameraTableTop", "CameraTopDown"]
    );
    // The camera nodes carry a scale of 0.5: position and rotation must come out
    // unscaled, and the camera inside the room.
    let expect = [
        (
            Vec3::new(1.1668346, 0.97024196, 0.677655),
            glam::Quat::from_xyzw(0.007681724, 0.20818973, -0.0016351358, 0.97805697),
        ),
        (
            Vec3::new(-0.992688, 0.89113176, -1.2291785),
            glam::Quat::from_xyzw(-0.04696106, -0.51848596, -0.028534064, 0.8533187),
        ),
        (
            Vec3::new(1.3597162, 1.7892476, -1.3825871),
            glam::Quat::from_xyzw(-0.28361285, 0.61028075, 0.24842998, 0.6967092),
        ),
    ];
    for (c, (p, q)) in scene.cameras.iter().zip(expect) {
        assert!(
            (c.position - p).length() < 1e-4,
            "{}: {}",
            c.name,
            c.position
        );
        assert!(
            c.rotation.dot(q).abs() > 1.0 - 1e-5,
            "{}: {} vs {q}",
            c.name,
            c.rotation
        );
        assert!((c.yfov - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
        assert!((c.aspect.unwrap() - 16.0 / 9.0).abs() < 1e-5);
        assert!(c.position.cmpge(lo).all() && c.position.cmple(hi).all());
    }
}

#[test]
fn emissive_strength_multiplies_the_emissive_factor() {
    let Some(path) = shared_scene("khronos/EmissiveStrengthTest/EmissiveStrengthTest.gltf") else {
        return;
    };
    let scene = load(&path);
    let doc = json(&path);
    let mut checked = 0;
    for m in doc["materials"].as_array().unwrap() {
        let name = m["name"].as_str().unwrap();
        let factor = m["emissiveFactor"]
            .as_array()
            .map(|f| Vec3::from_array(std::array::from_fn(|i| f[i].as_f64().unwrap() as f32)))
            .unwrap_or(Vec3::ZERO);
        let strength = m
            .pointer("/extensions/KHR_materials_emissive_strength/emissiveStrength")
            .map(|s| s.as_f64().unwrap() as f32)
            .unwrap_or(1.0);
        let loaded = material(&scene, name);
        assert!(
            (loaded.emissive - factor * strength).length() < 1e-5,
            "{name}: {} != {factor} × {strength}",
            loaded.emissive
        );
        checked += 1;
    }
    assert_eq!(checked, 6);
    // The names say the strength: Emit16 is 16 × (0.1, 0.5, 0.9).
    let e16 = material(&scene, "Emit16").emissive;
    assert!((e16 - Vec3::new(1.6, 8.0, 14.4)).length() < 1e-5, "{e16}");
    assert!(!material(&scene, "FlatBackdrop").is_emissive());
    assert!(material(&scene, "Emit1").is_emissive());

    check_triangles(&scene, instanced_triangles(&doc), 90);
    check_bounds(&scene, 5.0, 40.0);
    // Five emissive cubes of 12 triangles each.
    let emissive = (0..scene.triangle_count() as u32)
        .filter(|&i| {
            let m = scene.triangle_shading(i).material as usize;
            scene.materials[m].is_emissive()
        })
        .count();
    assert_eq!(emissive, 60);
}

#[test]
fn metal_rough_spheres_load() {
    let Some(path) =
        shared_scene("khronos/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf")
    else {
        return;
    };
    let scene = load(&path);
    let doc = json(&path);
    check_triangles(&scene, instanced_triangles(&doc), 1_040_000);
    // Millimetre-sized: the whole grid is a few centimetres across.
    check_bounds(&scene, 0.005, 0.5);
    // The materials sweep metallic and roughness exactly as the file says.
    for m in doc["materials"].as_array().unwrap() {
        let name = m["name"].as_str().unwrap();
        let pbr = &m["pbrMetallicRoughness"];
        let loaded = material(&scene, name);
        let f = |k: &str, default: f32| pbr[k].as_f64().map_or(default, |v| v as f32);
        assert_eq!(loaded.metallic, f("metallicFactor", 1.0), "{name}");
        assert_eq!(loaded.roughness, f("roughnessFactor", 1.0), "{name}");
        assert_eq!(loaded.double_sided, m["doubleSided"] == true, "{name}");
    }
    // Every triangle has smooth vertex normals, all unit length.
    for i in (0..scene.triangle_count() as u32).step_by(97) {
        let n = scene.triangle_shading(i).normals.expect("vertex normals");
        for n in n {
            assert!((n.length() - 1.0).abs() < 1e-4, "{n}");
        }
    }
}
