//! Small glTF files built here, good and bad: every container form (`.gltf` with an
//! external or a data-URI buffer, `.glb`), every way of giving triangles, transforms
//! (instancing, hierarchy, mirroring), and every kind of bad input. A bad input is an
//! error that names the file and the problem, never a panic.

use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{Quat, Vec3};
use holocave_scene::generate::GltfWriter;
use holocave_scene::{LoadOptions, Scene, SceneError};
use serde_json::{Value, json};

/// One mesh of one primitive, as a glTF document plus its binary buffer.
struct Mini {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    indices: Option<Vec<u32>>,
    /// The scene's nodes; by default one node drawing mesh 0.
    nodes: Vec<Value>,
    /// Root nodes of the scene (indices into `nodes`); by default all of them.
    roots: Option<Vec<usize>>,
    extensions_required: Vec<&'static str>,
    mode: Option<u32>,
}

impl Mini {
    fn new(positions: &[[f32; 3]], indices: Option<&[u32]>) -> Self {
        Self {
            positions: positions.to_vec(),
            normals: None,
            indices: indices.map(<[u32]>::to_vec),
            nodes: vec![json!({ "name": "node", "mesh": 0 })],
            roots: None,
            extensions_required: vec![],
            mode: None,
        }
    }

    /// The document (its buffer without a URI) and the buffer's bytes.
    fn build(&self) -> (Value, Vec<u8>) {
        let mut bin = Vec::new();
        let mut views = vec![];
        let mut accessors = vec![];
        let mut push_vec3 = |bin: &mut Vec<u8>, v: &[[f32; 3]]| {
            let offset = bin.len();
            for p in v {
                for c in p {
                    bin.extend_from_slice(&c.to_le_bytes());
                }
            }
            views.push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": v.len() * 12 }));
            // min/max over the finite values (glTF requires them for POSITION).
            let mut lo = [f32::MAX; 3];
            let mut hi = [f32::MIN; 3];
            for p in v {
                for k in 0..3 {
                    if p[k].is_finite() {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
            }
            accessors.push(json!({
                "bufferView": views.len() - 1, "componentType": 5126, "count": v.len(),
                "type": "VEC3", "min": lo, "max": hi
            }));
            accessors.len() - 1
        };
        let pos = push_vec3(&mut bin, &self.positions);
        let mut attributes = json!({ "POSITION": pos });
        if let Some(n) = &self.normals {
            attributes["NORMAL"] = json!(push_vec3(&mut bin, n));
        }
        let mut primitive = json!({ "attributes": attributes });
        if let Some(idx) = &self.indices {
            let offset = bin.len();
            for i in idx {
                bin.extend_from_slice(&i.to_le_bytes());
            }
            views.push(json!({ "buffer": 0, "byteOffset": offset, "byteLength": idx.len() * 4 }));
            accessors.push(json!({
                "bufferView": views.len() - 1, "componentType": 5125, "count": idx.len(), "type": "SCALAR"
            }));
            primitive["indices"] = json!(accessors.len() - 1);
        }
        if let Some(mode) = self.mode {
            primitive["mode"] = json!(mode);
        }
        let roots = self
            .roots
            .clone()
            .unwrap_or_else(|| (0..self.nodes.len()).collect());
        let mut doc = json!({
            "asset": { "version": "2.0" },
            "scene": 0,
            "scenes": [{ "nodes": roots }],
            "nodes": self.nodes,
            "meshes": [{ "name": "thing", "primitives": [primitive] }],
            "accessors": accessors,
            "bufferViews": views,
            "buffers": [{ "byteLength": bin.len() }],
        });
        if !self.extensions_required.is_empty() {
            doc["extensionsUsed"] = json!(self.extensions_required);
            doc["extensionsRequired"] = json!(self.extensions_required);
        }
        (doc, bin)
    }
}

/// Writes `name.gltf` with its buffer in `name.bin` beside it.
fn write_external(dir: &Path, name: &str, (mut doc, bin): (Value, Vec<u8>)) -> PathBuf {
    doc["buffers"][0]["uri"] = json!(format!("{name}.bin"));
    std::fs::write(dir.join(format!("{name}.bin")), bin).unwrap();
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    path
}

/// Writes `name.gltf` with its buffer as a base64 data URI.
fn write_data_uri(dir: &Path, name: &str, (mut doc, bin): (Value, Vec<u8>)) -> PathBuf {
    let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
    doc["buffers"][0]["uri"] = json!(format!("data:application/octet-stream;base64,{b64}"));
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_string(&doc).unwrap()).unwrap();
    path
}

/// The bytes of a binary glTF: header, JSON chunk, BIN chunk (glTF 2.0 §4.4).
fn glb_bytes(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn write_glb(dir: &Path, name: &str, (doc, bin): (Value, Vec<u8>)) -> PathBuf {
    let path = dir.join(format!("{name}.glb"));
    std::fs::write(&path, glb_bytes(&doc, &bin)).unwrap();
    path
}

fn write_json(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(doc).unwrap()).unwrap();
    path
}

/// Loads leniently, catching panics: a panic is a test failure of its own.
fn try_load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    match std::panic::catch_unwind(AssertUnwindSafe(|| Scene::load(path, opts))) {
        Ok(r) => r,
        Err(_) => panic!("loading {} panicked", path.display()),
    }
}

fn load_ok(path: &Path) -> Scene {
    try_load(path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("loading {}: {e}", path.display()))
}

/// Loads a file that must fail; checks that the message names the file and contains
/// each of `needles`, and returns the error.
fn load_err(path: &Path, needles: &[&str]) -> SceneError {
    load_err_with(path, &LoadOptions::default(), needles)
}

fn load_err_with(path: &Path, opts: &LoadOptions, needles: &[&str]) -> SceneError {
    let err = match try_load(path, opts) {
        Ok(_) => panic!("{} loaded, but must fail", path.display()),
        Err(e) => e,
    };
    let msg = err.to_string();
    let file = path.file_name().unwrap().to_string_lossy();
    assert!(msg.contains(&*file), "{msg:?} does not name {file}");
    for n in needles {
        assert!(
            msg.to_lowercase().contains(&n.to_lowercase()),
            "{msg:?} does not mention {n:?}"
        );
    }
    err
}

/// Two triangles forming the unit square in z = 0, facing +Z.
const SQUARE: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];
const SQUARE_IDX: [u32; 6] = [0, 1, 2, 0, 2, 3];

fn tri_set(scene: &Scene) -> Vec<[Vec3; 3]> {
    (0..scene.triangle_count() as u32)
        .map(|i| *scene.triangle(i))
        .collect()
}

fn face_normal(t: &[Vec3; 3]) -> Vec3 {
    (t[1] - t[0]).cross(t[2] - t[0]).normalize()
}

// ---------------------------------------------------------------------------------------
// Containers and ways of giving triangles
// ---------------------------------------------------------------------------------------

#[test]
fn external_data_uri_and_glb_give_the_same_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let mini = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    let external = load_ok(&write_external(dir.path(), "ext", mini.build()));
    let data_uri = load_ok(&write_data_uri(dir.path(), "uri", mini.build()));
    let glb = load_ok(&write_glb(dir.path(), "bin", mini.build()));
    assert_eq!(external.triangle_count(), 2);
    for s in [&external, &data_uri, &glb] {
        assert_eq!(tri_set(s), tri_set(&external));
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        let n = face_normal(s.triangle(0));
        assert!((n - Vec3::Z).length() < 1e-6, "{n}");
    }
    assert_eq!(glb.name, "bin");
    // The square is hit where expected, with the right barycentrics.
    let ray = holocave_scene::Ray::new(Vec3::new(0.75, 0.25, 1.0), -Vec3::Z);
    let hit = glb.closest_hit(&ray, f32::INFINITY).expect("hit");
    assert!((hit.t - 1.0).abs() < 1e-6);
    let sp = glb.surface(&hit);
    assert!((sp.position - Vec3::new(0.75, 0.25, 0.0)).length() < 1e-6);
}

#[test]
fn glb_with_an_external_buffer_and_a_percent_encoded_uri() {
    let dir = tempfile::tempdir().unwrap();
    let (mut doc, bin) = Mini::new(&SQUARE, Some(&SQUARE_IDX)).build();
    std::fs::write(dir.path().join("my data.bin"), &bin).unwrap();
    doc["buffers"][0]["uri"] = json!("my%20data.bin");
    let path = dir.path().join("x.glb");
    std::fs::write(&path, glb_bytes(&doc, &[])).unwrap();
    assert_eq!(load_ok(&path).triangle_count(), 2);
}

#[test]
fn generated_writer_output_with_data_uri_loads() {
    // GltfWriter (the generator's) embeds its buffer as a data URI.
    let dir = tempfile::tempdir().unwrap();
    let mut w = GltfWriter::default();
    let m = w.material(json!({ "name": "grey", "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1.0] } }));
    let p: Vec<Vec3> = SQUARE.iter().map(|p| Vec3::from_array(*p)).collect();
    let mesh = w.mesh("square", &p, &[Vec3::Z; 4], &SQUARE_IDX, m);
    w.node("a", mesh, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let path = dir.path().join("w.gltf");
    std::fs::write(&path, w.finish()).unwrap();
    let s = load_ok(&path);
    assert_eq!(s.triangle_count(), 2);
    assert_eq!(s.materials[0].name, "grey");
    assert_eq!(s.triangle_shading(0).material, 0);
    assert_eq!(s.triangle_shading(0).normals, Some([Vec3::Z; 3]));
}

#[test]
fn non_indexed_triangles_load() {
    let dir = tempfile::tempdir().unwrap();
    let flat: Vec<[f32; 3]> = SQUARE_IDX.iter().map(|&i| SQUARE[i as usize]).collect();
    let s = load_ok(&write_external(
        dir.path(),
        "flat",
        Mini::new(&flat, None).build(),
    ));
    let indexed = load_ok(&write_external(
        dir.path(),
        "indexed",
        Mini::new(&SQUARE, Some(&SQUARE_IDX)).build(),
    ));
    assert_eq!(tri_set(&s), tri_set(&indexed));
    // Without NORMAL the face normal is used.
    assert_eq!(s.triangle_shading(0).normals, None);
}

#[test]
fn triangle_strips_and_fans_keep_their_winding() {
    let dir = tempfile::tempdir().unwrap();
    // Strip 0-1-3-2 of the square: triangles (0,1,3) and (3,1,2) both facing +Z.
    let mut strip = Mini::new(&SQUARE, Some(&[0, 1, 3, 2]));
    strip.mode = Some(5);
    let s = load_ok(&write_external(dir.path(), "strip", strip.build()));
    // Fan 0-1-2-3: (0,1,2), (0,2,3).
    let mut fan = Mini::new(&SQUARE, Some(&[0, 1, 2, 3]));
    fan.mode = Some(6);
    let f = load_ok(&write_external(dir.path(), "fan", fan.build()));
    for scene in [&s, &f] {
        assert_eq!(scene.triangle_count(), 2);
        for t in tri_set(scene) {
            assert!((face_normal(&t) - Vec3::Z).length() < 1e-6);
        }
    }
    // Lines have no surface: skipped with a warning, and then the file has no triangles.
    let mut lines = Mini::new(&SQUARE, Some(&[0, 1, 1, 2]));
    lines.mode = Some(1);
    let path = write_external(dir.path(), "lines", lines.build());
    load_err(&path, &["no triangles"]);
}

// ---------------------------------------------------------------------------------------
// Transforms
// ---------------------------------------------------------------------------------------

#[test]
fn instancing_draws_one_mesh_at_every_node() {
    let dir = tempfile::tempdir().unwrap();
    let mut mini = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    mini.nodes = vec![
        json!({ "mesh": 0, "translation": [0.0, 0.0, 0.0] }),
        json!({ "mesh": 0, "translation": [5.0, 0.0, 0.0] }),
        // A parent moved by +10 in y and scaled by 2, whose child draws the mesh moved by
        // +1 in x in the parent's frame: world = T(0,10,0) S(2) T(1,0,0).
        json!({ "translation": [0.0, 10.0, 0.0], "scale": [2.0, 2.0, 2.0], "children": [3] }),
        json!({ "mesh": 0, "translation": [1.0, 0.0, 0.0] }),
        // A matrix node (column-major): rotation of 90° about Z, then +3 in z.
        json!({ "mesh": 0, "matrix": [0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 3.0, 1.0] }),
    ];
    mini.roots = Some(vec![0, 1, 2, 4]);
    let s = load_ok(&write_external(dir.path(), "inst", mini.build()));
    assert_eq!(s.triangle_count(), 8, "4 instances of 2 triangles");
    let tris = tri_set(&s);
    let square = |f: &dyn Fn(Vec3) -> Vec3| -> Vec<[Vec3; 3]> {
        SQUARE_IDX
            .chunks(3)
            .map(|c| std::array::from_fn(|k| f(Vec3::from_array(SQUARE[c[k] as usize]))))
            .collect()
    };
    let expected = [
        square(&|p| p),
        square(&|p| p + Vec3::X * 5.0),
        square(&|p| (p + Vec3::X) * 2.0 + Vec3::Y * 10.0),
        square(&|p| Vec3::new(-p.y, p.x, p.z + 3.0)),
    ];
    for inst in expected {
        for t in inst {
            assert!(
                tris.iter()
                    .any(|u| (0..3).all(|k| (u[k] - t[k]).length() < 1e-5)),
                "missing instance triangle {t:?}; have {tris:?}"
            );
        }
    }
    let (lo, hi) = s.bounds();
    assert_eq!(lo, Vec3::new(-1.0, 0.0, 0.0));
    assert_eq!(hi, Vec3::new(6.0, 12.0, 3.0));
}

#[test]
fn negative_scale_keeps_faces_and_normals_outward() {
    let dir = tempfile::tempdir().unwrap();
    // A unit cube with outward winding and outward vertex normals (from the generator's
    // shapes: 24 vertices, flat per face), mirrored in x, and in x and y, and in all three.
    let mut w = GltfWriter::default();
    let m = w.material(json!({ "name": "white" }));
    let (p, n, i) = cube_shape();
    let mesh = w.mesh("cube", &p, &n, &i, m);
    let scales = [
        Vec3::new(-1.0, 1.0, 1.0),
        Vec3::new(-2.0, -1.0, 1.0),
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, 1.0, 1.0),
    ];
    let centres: Vec<Vec3> = (0..scales.len())
        .map(|k| Vec3::new(k as f32 * 5.0, 0.0, 0.0))
        .collect();
    for (s, c) in scales.iter().zip(&centres) {
        w.node("cube", mesh, *c, Quat::from_rotation_y(0.3), *s);
    }
    let path = dir.path().join("mirrored.gltf");
    std::fs::write(&path, w.finish()).unwrap();
    let scene = load_ok(&path);
    assert_eq!(scene.triangle_count(), 12 * scales.len());
    for i in 0..scene.triangle_count() as u32 {
        let t = scene.triangle(i);
        let centroid = (t[0] + t[1] + t[2]) / 3.0;
        let c = centres
            .iter()
            .min_by(|a, b| a.distance(centroid).total_cmp(&b.distance(centroid)))
            .unwrap();
        let outward = (centroid - *c).normalize();
        let ng = face_normal(t);
        assert!(
            ng.dot(outward) > 0.5,
            "triangle {i}: face normal {ng} points inward"
        );
        let normals = scene.triangle_shading(i).normals.expect("vertex normals");
        for n in normals {
            assert!((n.length() - 1.0).abs() < 1e-5, "{n}");
            assert!(
                n.dot(ng) > 0.999,
                "triangle {i}: vertex normal {n} vs face {ng}"
            );
        }
    }
    // A ray from outside each cube meets a front face: its normal faces the ray.
    for c in &centres {
        for dir in [Vec3::X, -Vec3::Y, Vec3::Z] {
            let ray = holocave_scene::Ray::new(*c - dir * 2.5, dir);
            let hit = scene.closest_hit(&ray, f32::INFINITY).expect("hit");
            let sp = scene.surface(&hit);
            assert!(
                sp.geometric_normal.dot(dir) < 0.0,
                "back face hit from outside"
            );
            assert!(sp.shading_normal.dot(dir) < 0.0);
        }
    }
}

/// An axis-aligned unit cube centred at the origin, outward winding and normals.
fn cube_shape() -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let mut p = vec![];
    let mut n = vec![];
    let mut idx = vec![];
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut nn = Vec3::ZERO;
            nn[axis] = sign;
            let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
            a[(axis + 1) % 3] = 1.0;
            b[(axis + 2) % 3] = 1.0;
            if sign < 0.0 {
                std::mem::swap(&mut a, &mut b);
            }
            let o = nn * 0.5 - (a + b) * 0.5;
            let base = p.len() as u32;
            p.extend([o, o + a, o + a + b, o + b]);
            n.extend([nn; 4]);
            idx.extend([0, 1, 2, 0, 2, 3].map(|i| i + base));
        }
    }
    (p, n, idx)
}

// ---------------------------------------------------------------------------------------
// Degenerate triangles
// ---------------------------------------------------------------------------------------

#[test]
fn degenerate_triangles_are_dropped_with_one_counting_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mut pos = SQUARE.to_vec();
    pos.push([2.0, 2.0, 0.0]); // 4: on the line through 0 and 2
    pos.push([0.0, 0.0, 0.0]); // 5: a copy of vertex 0
    let idx = [
        0, 1, 2, 0, 2, 3, // the square
        0, 0, 1, // repeated index
        0, 2, 4, // collinear
        5, 0, 1, // coincident positions, distinct indices
        1, 1, 1, // a point
    ];
    let s = load_ok(&write_external(
        dir.path(),
        "degenerate",
        Mini::new(&pos, Some(&idx)).build(),
    ));
    assert_eq!(s.triangle_count(), 2);
    let w: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("degenerate"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(w[0].contains('4'), "{}", w[0]);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);

    // Only degenerate triangles: an error, not an empty scene.
    let path = write_external(
        dir.path(),
        "all_degenerate",
        Mini::new(&pos, Some(&[0, 0, 1, 0, 2, 4])).build(),
    );
    load_err(&path, &["no triangles"]);
}

// ---------------------------------------------------------------------------------------
// Textures
// ---------------------------------------------------------------------------------------

fn textured(dir: &Path, name: &str, image_uri: &str) -> PathBuf {
    let mut mini = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    mini.nodes = vec![json!({ "mesh": 0 })];
    let (mut doc, bin) = mini.build();
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["materials"] = json!([{
        "name": "painted",
        "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.25, 1.0, 1.0], "baseColorTexture": { "index": 0 } }
    }]);
    doc["textures"] = json!([{ "source": 0 }]);
    doc["images"] = json!([{ "uri": image_uri }]);
    write_external(dir, name, (doc, bin))
}

#[test]
fn missing_texture_falls_back_to_factors_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let s = load_ok(&textured(dir.path(), "t", "nowhere.png"));
    let m = &s.materials[0];
    assert_eq!(m.base_color_texture, None);
    assert_eq!(m.base_color, glam::Vec4::new(0.5, 0.25, 1.0, 1.0));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("nowhere.png"), "{}", s.warnings[0]);
    assert!(s.warnings[0].contains("fall back"), "{}", s.warnings[0]);

    // A file that is not an image: the same fallback.
    std::fs::write(dir.path().join("junk.png"), b"not a png").unwrap();
    let s = load_ok(&textured(dir.path(), "j", "junk.png"));
    assert_eq!(s.materials[0].base_color_texture, None);
    assert!(s.warnings[0].contains("decode"), "{}", s.warnings[0]);
}

#[test]
fn data_uri_texture_is_read_as_srgb() {
    let dir = tempfile::tempdir().unwrap();
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([188, 188, 188, 255]));
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let uri = format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&png)
    );
    let s = load_ok(&textured(dir.path(), "t", &uri));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.materials[0];
    assert!(m.base_color_texture.is_some());
    let p = m.params(&s.textures, glam::Vec2::new(0.5, 0.5));
    // sRGB 188 is linear 0.5029; times the factor 0.5.
    assert!(
        (p.base_color.x - 0.5 * 0.5029).abs() < 1e-3,
        "{}",
        p.base_color
    );
}

// ---------------------------------------------------------------------------------------
// Bad input: each is an error naming the file and the problem
// ---------------------------------------------------------------------------------------

#[test]
fn missing_file() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["absent.gltf", "absent.glb"] {
        let err = load_err(&dir.path().join(name), &["cannot read"]);
        assert!(matches!(err, SceneError::Io { .. }), "{err:?}");
    }
}

#[test]
fn bad_json() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [
        (
            "truncated.gltf",
            r#"{ "asset": { "version": "2.0" }, "nodes": [ "#,
        ),
        ("garbage.gltf", "this is not JSON"),
        ("empty.gltf", ""),
        (
            "wrong_type.gltf",
            r#"{ "asset": { "version": "2.0" }, "nodes": 7 }"#,
        ),
        ("no_asset.gltf", r#"{ "scenes": [] }"#),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let err = load_err(&path, &["gltf"]);
        assert!(
            matches!(err, SceneError::Parse { .. } | SceneError::Invalid { .. }),
            "{name}: {err:?}"
        );
    }
    // A .glb that is not one.
    let path = dir.path().join("bad.glb");
    std::fs::write(&path, b"glTF\x02\0\0\0\xff\xff\0\0JSON").unwrap();
    load_err(&path, &["gltf"]);
}

#[test]
fn missing_buffer_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_external(
        dir.path(),
        "nobuf",
        Mini::new(&SQUARE, Some(&SQUARE_IDX)).build(),
    );
    std::fs::remove_file(dir.path().join("nobuf.bin")).unwrap();
    let err = load_err(&path, &["buffer 0", "nobuf.bin"]);
    assert!(matches!(err, SceneError::Buffer { .. }), "{err:?}");
}

#[test]
fn short_buffers_and_bad_data_uris() {
    let dir = tempfile::tempdir().unwrap();
    let (doc, bin) = Mini::new(&SQUARE, Some(&SQUARE_IDX)).build();
    // The buffer file is shorter than the declared byteLength.
    let path = write_external(dir.path(), "short", (doc.clone(), bin.clone()));
    std::fs::write(dir.path().join("short.bin"), &bin[..bin.len() / 2]).unwrap();
    load_err(&path, &["buffer 0", "bytes"]);
    // Bad base64.
    let mut d = doc.clone();
    d["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@");
    load_err(&write_json(dir.path(), "b64.gltf", &d), &["base64"]);
    // A GLB whose JSON refers to a binary chunk that is not there.
    let path = dir.path().join("nochunk.glb");
    let mut d = doc.clone();
    d["buffers"][0] = json!({ "byteLength": bin.len() });
    let mut bytes = glb_bytes(&d, &[]);
    // Drop the (empty) BIN chunk header.
    bytes.truncate(bytes.len() - 8);
    let total = bytes.len() as u32;
    bytes[8..12].copy_from_slice(&total.to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
    load_err(&path, &["buffer 0"]);
    // A buffer view that runs past the end of its buffer.
    let mut d = doc.clone();
    d["bufferViews"][0]["byteLength"] = json!(bin.len() * 2);
    load_err(
        &write_external(dir.path(), "view", (d, bin.clone())),
        &["buffer view"],
    );
    // An accessor that needs more bytes than its view has.
    let mut d = doc;
    d["accessors"][0]["count"] = json!(1000);
    load_err(
        &write_external(dir.path(), "accessor", (d, bin)),
        &["accessor"],
    );
}

#[test]
fn non_finite_vertices() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bad) in [
        ("nan", f32::NAN),
        ("inf", f32::INFINITY),
        ("neginf", f32::NEG_INFINITY),
    ] {
        let mut pos = SQUARE.to_vec();
        pos[2][1] = bad;
        let path = write_external(dir.path(), name, Mini::new(&pos, Some(&SQUARE_IDX)).build());
        let err = load_err(&path, &["vertex 2", "NaN or infinite", "thing"]);
        assert!(matches!(err, SceneError::Geometry { .. }), "{err:?}");
    }
    // Finite vertices that a huge node scale makes infinite.
    let mut mini = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    mini.nodes = vec![
        json!({ "mesh": 0, "scale": [1e30, 1e30, 1e30] }),
        json!({ "mesh": 0, "scale": [1e30, 1e30, 1e30], "children": [0] }),
    ];
    mini.roots = Some(vec![1]);
    let path = write_external(dir.path(), "overflow", mini.build());
    load_err(&path, &["not finite"]);
}

#[test]
fn out_of_range_index() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_external(
        dir.path(),
        "oob",
        Mini::new(&SQUARE, Some(&[0, 1, 2, 0, 2, 4])).build(),
    );
    let err = load_err(&path, &["index 4", "out of range", "4 vertices", "thing"]);
    assert!(matches!(err, SceneError::Geometry { .. }), "{err:?}");
    // u32::MAX as well.
    let path = write_external(
        dir.path(),
        "max",
        Mini::new(&SQUARE, Some(&[0, 1, u32::MAX])).build(),
    );
    load_err(&path, &["out of range"]);
}

#[test]
fn unsupported_required_extension() {
    let dir = tempfile::tempdir().unwrap();
    let mut mini = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    mini.extensions_required = vec!["KHR_materials_emissive_strength", "EXT_made_up"];
    let path = write_external(dir.path(), "ext", mini.build());
    // Lenient: loads, warns about the one it ignores and not about the supported one.
    let s = load_ok(&path);
    assert_eq!(s.triangle_count(), 2);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("EXT_made_up") && s.warnings[0].contains("ignored"));
    // Strict: an error naming the file and the extension.
    let strict = LoadOptions {
        strict: true,
        ..Default::default()
    };
    let err = load_err_with(&path, &strict, &["EXT_made_up", "not supported"]);
    assert!(
        matches!(err, SceneError::UnsupportedExtension { .. }),
        "{err:?}"
    );
    // Strict loading of a file requiring only supported extensions is fine.
    let mut ok = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    ok.extensions_required = vec!["KHR_materials_specular", "KHR_lights_punctual"];
    let path = write_external(dir.path(), "ok", ok.build());
    assert!(try_load(&path, &strict).is_ok());
}

/// A named change to a good document, and what the error must mention.
type Damage = (&'static str, Box<dyn Fn(&mut Value)>, &'static str);

#[test]
fn structurally_invalid_documents() {
    let dir = tempfile::tempdir().unwrap();
    let (doc, bin) = Mini::new(&SQUARE, Some(&SQUARE_IDX)).build();
    let cases: Vec<Damage> = vec![
        (
            "node_mesh",
            Box::new(|d| d["nodes"][0]["mesh"] = json!(9)),
            "mesh",
        ),
        (
            "accessor_ref",
            Box::new(|d| d["meshes"][0]["primitives"][0]["indices"] = json!(42)),
            "indices",
        ),
        (
            "view_ref",
            Box::new(|d| d["accessors"][0]["bufferView"] = json!(42)),
            "bufferView",
        ),
        ("scene_ref", Box::new(|d| d["scene"] = json!(3)), "scene"),
        (
            "component_type",
            Box::new(|d| d["accessors"][0]["componentType"] = json!(1234)),
            "componentType",
        ),
        (
            "no_position",
            Box::new(|d| d["meshes"][0]["primitives"][0]["attributes"] = json!({})),
            "POSITION",
        ),
        (
            "position_type",
            Box::new(|d| d["accessors"][0]["componentType"] = json!(5121)),
            "POSITION accessor 0",
        ),
        (
            "index_type",
            Box::new(|d| d["accessors"][1]["componentType"] = json!(5126)),
            "indices accessor 1",
        ),
        (
            "stride",
            Box::new(|d| d["bufferViews"][0]["byteStride"] = json!(4)),
            "stride",
        ),
        (
            "sparse",
            Box::new(|d| {
                d["accessors"][0]["sparse"] = json!({
                    "count": 1,
                    "indices": { "bufferView": 1, "componentType": 5125 },
                    "values": { "bufferView": 0 }
                })
            }),
            "sparse",
        ),
        (
            "two_parents",
            Box::new(|d| {
                d["nodes"] = json!([{ "mesh": 0 }, { "children": [0] }, { "children": [0] }]);
                d["scenes"][0]["nodes"] = json!([1, 2]);
            }),
            "two parents",
        ),
        (
            "cycle",
            Box::new(|d| d["nodes"][0]["children"] = json!([0])),
            "node",
        ),
    ];
    for (name, mutate, needle) in cases {
        let mut d = doc.clone();
        mutate(&mut d);
        let path = write_external(dir.path(), name, (d, bin.clone()));
        load_err(&path, &[needle]);
    }
}

#[test]
fn a_file_without_triangles_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_json(
        dir.path(),
        "empty_scene.gltf",
        &json!({ "asset": { "version": "2.0" }, "scenes": [{ "nodes": [] }], "scene": 0 }),
    );
    let err = load_err(&path, &["no triangles"]);
    assert!(matches!(err, SceneError::Empty { .. }), "{err:?}");
}

/// Damaged copies of a good file (truncated at many lengths, single bytes changed, every
/// number in the JSON replaced by odd values): each loads or fails with an error that
/// names the file, and none panics.
#[test]
fn damaged_files_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let mut mini = Mini::new(&SQUARE, Some(&SQUARE_IDX));
    mini.normals = Some(vec![[0.0, 0.0, 1.0]; 4]);
    let (doc, bin) = mini.build();
    let glb = glb_bytes(&doc, &bin);
    let check = |path: &Path| {
        if let Err(e) = try_load(path, &LoadOptions::default()) {
            let file = path.file_name().unwrap().to_string_lossy();
            assert!(e.to_string().contains(&*file), "{e}");
        }
    };
    let path = dir.path().join("cut.glb");
    for len in (0..glb.len()).step_by(3) {
        std::fs::write(&path, &glb[..len]).unwrap();
        check(&path);
    }
    for i in (0..glb.len()).step_by(5) {
        let mut g = glb.clone();
        g[i] ^= 0x5a;
        std::fs::write(&path, &g).unwrap();
        check(&path);
    }
    // Every numeric field of the JSON, one at a time, set to odd values.
    fn numeric_paths(v: &Value, at: String, out: &mut Vec<String>) {
        match v {
            Value::Number(_) => out.push(at),
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    numeric_paths(x, format!("{at}/{i}"), out);
                }
            }
            Value::Object(o) => {
                for (k, x) in o {
                    numeric_paths(x, format!("{at}/{k}"), out);
                }
            }
            _ => {}
        }
    }
    let mut paths = vec![];
    numeric_paths(&doc, String::new(), &mut paths);
    assert!(paths.len() > 20);
    let path = dir.path().join("odd.glb");
    for p in &paths {
        for odd in [
            json!(0),
            json!(1),
            json!(3),
            json!(-1),
            json!(5121),
            json!(5126),
            json!(4294967295u64),
            json!(1e300),
            json!("x"),
        ] {
            let mut d = doc.clone();
            *d.pointer_mut(p).unwrap() = odd;
            std::fs::write(&path, glb_bytes(&d, &bin)).unwrap();
            check(&path);
        }
    }
    // Every object member, one at a time, removed.
    fn member_paths(v: &Value, at: String, out: &mut Vec<(String, String)>) {
        match v {
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    member_paths(x, format!("{at}/{i}"), out);
                }
            }
            Value::Object(o) => {
                for (k, x) in o {
                    out.push((at.clone(), k.clone()));
                    member_paths(x, format!("{at}/{k}"), out);
                }
            }
            _ => {}
        }
    }
    let mut members = vec![];
    member_paths(&doc, String::new(), &mut members);
    for (parent, key) in &members {
        let mut d = doc.clone();
        d.pointer_mut(parent)
            .unwrap()
            .as_object_mut()
            .unwrap()
            .remove(key);
        std::fs::write(&path, glb_bytes(&d, &bin)).unwrap();
        check(&path);
    }
}
