//! glTF 2.0 loading (`.gltf` with external or embedded buffers, and `.glb`).
//!
//! Real files are imperfect, so the loader is lenient where it can be and says what it
//! did: an unsupported extension listed as required is ignored with a warning (an error
//! under strict loading); a missing or undecodable texture falls back to the material's
//! factors; degenerate triangles are dropped. Bad geometry (non-finite vertices,
//! out-of-range indices, accessors outside their buffers) is an error naming the file,
//! mesh and primitive. Only each texture's core `source` image is read, so alternates
//! from extensions such as `MSFT_texture_dds` are never loaded.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::{Document, Semantic, mesh::Mode};
use rayon::prelude::*;

use crate::camera::NamedCamera;
use crate::daylight::Daylight;
use crate::error::SceneError;
use crate::light::{PunctualKind, PunctualLight};
use crate::material::{Material, TextureRef};
use crate::objects::{ObjectParts, Placement};
use crate::parts::{SceneParts, TriangleShading};
use crate::scene::Scene;
use crate::texture::{Encoding, Texture};

/// Extensions whose meaning holocave implements.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_ior",
];

/// How to load a scene.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Refuse files that require an extension holocave does not implement.
    pub strict: bool,
    /// Daylight file; when `None`, `<scene stem>.daylight.toml` beside the scene is used
    /// if it exists.
    pub daylight: Option<PathBuf>,
    /// A time (and weather) for the daylight: the sun from the daylight file's `[site]` (or
    /// the weather file's location) at that time; with weather, the hour's sun and Perez
    /// sky. `None`: the daylight file as written.
    pub moment: Option<crate::daylight::Moment>,
    /// Movable objects, besides the nodes the file marks movable (see [`ObjectSpec`]).
    pub objects: Vec<ObjectSpec>,
}

impl LoadOptions {
    /// Lenient loading with the nodes `names` as movable objects, one node each.
    pub fn with_objects(names: &[&str]) -> LoadOptions {
        LoadOptions {
            objects: names.iter().map(|n| ObjectSpec::node(n)).collect(),
            ..LoadOptions::default()
        }
    }
}

/// A movable object: the named glTF nodes, each with its whole sub-tree. A node marked
/// `"extras": {"holocave": {"movable": true}}` in the file is an object too, named as
/// the node, unless a spec already claims it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectSpec {
    pub name: String,
    /// glTF node names; the first node's placement is the object's rest placement.
    pub nodes: Vec<String>,
}

impl ObjectSpec {
    /// The object of one node, named as the node.
    pub fn node(name: &str) -> ObjectSpec {
        ObjectSpec {
            name: name.into(),
            nodes: vec![name.into()],
        }
    }
}

/// The daylight file looked for beside a scene.
pub fn default_daylight_path(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().unwrap_or_default().to_string_lossy();
    scene.with_file_name(format!("{stem}.daylight.toml"))
}

/// The daylight a scene at `scene` is loaded with: the file `daylight` (else the one
/// beside the scene, if present) at `moment`; a moment without a file takes the weather
/// file's site and sky.
pub fn load_daylight(
    scene: &Path,
    daylight: Option<&Path>,
    moment: Option<&crate::daylight::Moment>,
) -> Result<Daylight, SceneError> {
    let beside = default_daylight_path(scene);
    let path = daylight.or_else(|| Some(beside.as_path()).filter(|p| p.exists()));
    match (path, moment) {
        (Some(p), _) => Daylight::load_at(p, moment),
        (None, Some(_)) => Daylight::parse_at("", Path::new("(no daylight file)"), moment),
        (None, None) => Ok(Daylight::default()),
    }
}

struct Loader<'a> {
    path: &'a Path,
    doc: &'a Document,
    buffers: &'a [gltf::buffer::Data],
    parts: SceneParts,
    /// Per glTF node, the object it names directly (its sub-tree follows it).
    claims: Vec<Option<usize>>,
    /// Per object, the node whose world transform gives its rest placement.
    first_nodes: Vec<usize>,
    /// Lights and cameras found under movable nodes (they stay static).
    static_under_objects: usize,
}

impl Scene {
    /// Loads a glTF (`.gltf` or `.glb`) scene (see the module's notes).
    pub fn load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
        load(path, opts)
    }
}

fn load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.into(),
        source,
    })?;
    let gltf =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| SceneError::Parse {
            path: path.into(),
            message: e.to_string(),
        })?;
    let mut warnings = check_extensions(path, &gltf.document, opts.strict)?;
    validate(path, &gltf.document)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, &gltf.document, base, gltf.blob.clone())?;

    let (textures, texture_map, tex_warnings) = load_textures(path, &gltf.document, base, &buffers);
    warnings.extend(tex_warnings);

    // The daylight file is the scene's settings: its `[[object]]`s join the options'.
    let daylight = load_daylight(path, opts.daylight.as_deref(), opts.moment.as_ref())?;
    let mut specs = opts.objects.clone();
    specs.extend(daylight.objects.iter().cloned());
    let (objects, claims, first_nodes) = resolve_objects(path, &gltf.document, &specs)?;
    let mut loader = Loader {
        path,
        doc: &gltf.document,
        buffers: &buffers,
        claims,
        first_nodes,
        static_under_objects: 0,
        parts: SceneParts {
            name: path
                .file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .into(),
            textures,
            warnings,
            objects,
            ..Default::default()
        },
    };
    loader.parts.materials = gltf
        .document
        .materials()
        .map(|m| convert_material(&m, &texture_map))
        .collect();
    // Primitives without a material use glTF's default, appended last.
    loader.parts.materials.push(Material::default());

    let scene = gltf
        .document
        .default_scene()
        .or_else(|| gltf.document.scenes().next());
    let seen = match scene {
        Some(scene) => loader.visit_scene(&scene)?,
        None => {
            let w = "the file has no scene; nothing to draw".to_string();
            tracing::warn!("{}: {w}", path.display());
            vec![false; gltf.document.nodes().len()]
        }
    };
    loader.finish_objects(&seen)?;
    loader.parts.daylight = daylight;
    for w in &loader.parts.warnings {
        tracing::warn!("{}: {w}", path.display());
    }
    let parts = loader.parts;
    Scene::from_parts(parts, path)
}

/// The objects (still empty), the object each node names directly, and each object's
/// first node.
type ResolvedObjects = (Vec<ObjectParts>, Vec<Option<usize>>, Vec<usize>);

/// The movable objects asked for by `specs` and marked in the file. Refuses a node name that is not in the file or names several nodes, and a node
/// claimed by two objects.
fn resolve_objects(
    path: &Path,
    doc: &Document,
    specs: &[ObjectSpec],
) -> Result<ResolvedObjects, SceneError> {
    let err = |message: String| SceneError::Objects {
        path: path.into(),
        message,
    };
    let mut objects: Vec<ObjectParts> = Vec::new();
    let mut claims: Vec<Option<usize>> = vec![None; doc.nodes().len()];
    let mut first_nodes = Vec::new();
    let mut claim = |objects: &[ObjectParts], node: usize, k: usize| match claims[node] {
        Some(other) if other != k => Err(err(format!(
            "node {node} is claimed by two objects, {:?} and {:?}",
            objects[other].name, objects[k].name
        ))),
        _ => {
            claims[node] = Some(k);
            Ok(())
        }
    };
    for spec in specs {
        let k = objects.len();
        objects.push(ObjectParts {
            name: spec.name.clone(),
            ..Default::default()
        });
        if spec.nodes.is_empty() {
            return Err(err(format!("object {:?} names no nodes", spec.name)));
        }
        for name in &spec.nodes {
            let found: Vec<usize> = doc
                .nodes()
                .filter(|n| n.name() == Some(name.as_str()))
                .map(|n| n.index())
                .collect();
            let node = match found[..] {
                [node] => node,
                [] => {
                    return Err(err(format!(
                        "object {:?}: node {name:?} is not in the scene",
                        spec.name
                    )));
                }
                _ => {
                    return Err(err(format!(
                        "object {:?}: node name {name:?} is ambiguous ({} nodes have it)",
                        spec.name,
                        found.len()
                    )));
                }
            };
            claim(&objects, node, k)?;
            if first_nodes.len() == k {
                first_nodes.push(node);
            }
        }
    }
    for node in doc.nodes() {
        if claims[node.index()].is_some() || !marked_movable(&node) {
            continue;
        }
        let name = node
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("node {}", node.index()));
        claims[node.index()] = Some(objects.len());
        first_nodes.push(node.index());
        objects.push(ObjectParts {
            name,
            ..Default::default()
        });
    }
    Ok((objects, claims, first_nodes))
}

/// Whether a node's extras say `{"holocave": {"movable": true}}`.
fn marked_movable(node: &gltf::Node) -> bool {
    node.extras().as_ref().is_some_and(|raw| {
        serde_json::from_str::<serde_json::Value>(raw.get())
            .is_ok_and(|v| v.pointer("/holocave/movable") == Some(&serde_json::Value::Bool(true)))
    })
}

/// Unsupported required extensions: an error under strict loading, else warnings.
fn check_extensions(path: &Path, doc: &Document, strict: bool) -> Result<Vec<String>, SceneError> {
    let mut warnings = Vec::new();
    for ext in doc.extensions_required() {
        if SUPPORTED_EXTENSIONS.contains(&ext) {
            continue;
        }
        if strict {
            return Err(SceneError::UnsupportedExtension {
                path: path.into(),
                extension: ext.into(),
            });
        }
        warnings.push(format!(
            "required extension {ext} is not supported: its data is ignored and the core glTF data is used"
        ));
    }
    Ok(warnings)
}

/// glTF's own validation, minus its complaints about required extensions (decided
/// above).
fn validate(path: &Path, doc: &Document) -> Result<(), SceneError> {
    let json = doc.as_json();
    let mut errors = Vec::new();
    // gltf-json's validator indexes `accessors` with each primitive's POSITION index
    // without checking it (it panics on a bad one), so those are checked first.
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &prim.attributes {
                if index.value() >= json.accessors.len() {
                    errors.push(format!(
                        "meshes[{m}].primitives[{p}].attributes[\"{}\"]: accessor {} does not exist ({} accessors)",
                        semantic_name(semantic),
                        index.value(),
                        json.accessors.len()
                    ));
                }
            }
        }
    }
    if !errors.is_empty() {
        return Err(SceneError::Invalid {
            path: path.into(),
            message: errors.join("; "),
        });
    }
    use gltf::json::validation::Validate;
    json.validate(json, gltf::json::Path::new, &mut |path, err| {
        let p = path().to_string();
        if !p.starts_with("extensionsRequired") && !p.starts_with("extensionsUsed") {
            errors.push(format!("{p}: {err}"));
        }
    });
    if errors.is_empty() {
        return Ok(());
    }
    let more = if errors.len() > 5 {
        format!(" (and {} more)", errors.len() - 5)
    } else {
        String::new()
    };
    errors.truncate(5);
    Err(SceneError::Invalid {
        path: path.into(),
        message: format!("{}{more}", errors.join("; ")),
    })
}

fn semantic_name(s: &gltf::json::validation::Checked<gltf::json::mesh::Semantic>) -> String {
    match s {
        gltf::json::validation::Checked::Valid(s) => s.to_string(),
        gltf::json::validation::Checked::Invalid => "invalid".into(),
    }
}

fn load_buffers(
    path: &Path,
    doc: &Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let err = |message: String| SceneError::Buffer {
            path: path.into(),
            buffer: buffer.index(),
            message,
        };
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| err("refers to the GLB binary chunk, which is missing".into()))?,
            gltf::buffer::Source::Uri(uri) => read_uri(base, uri).map_err(err)?,
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "holds {} bytes, the file declares {}",
                data.len(),
                buffer.length()
            )));
        }
        out.push(gltf::buffer::Data(data));
    }
    Ok(out)
}

/// Reads a data URI or a file relative to the glTF file.
fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or("data URI is not base64")?;
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| format!("bad base64 data URI: {e}"));
    }
    let rel = urlencoding::decode(uri).map_err(|e| format!("bad URI {uri:?}: {e}"))?;
    let file = base.join(rel.as_ref());
    std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))
}

/// How each image is used decides its encoding: base colour and emissive are sRGB.
fn texture_uses(doc: &Document) -> HashMap<usize, Encoding> {
    let mut uses = HashMap::new();
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        for (info, enc) in [
            (pbr.base_color_texture(), Encoding::Srgb),
            (m.emissive_texture(), Encoding::Srgb),
            (pbr.metallic_roughness_texture(), Encoding::Linear),
        ] {
            if let Some(info) = info {
                uses.insert(info.texture().index(), enc);
            }
        }
    }
    uses
}

/// Decodes every texture a material uses, in parallel. Returns the textures, a map from
/// glTF texture index to ours, and warnings for the ones that could not be read.
fn load_textures(
    path: &Path,
    doc: &Document,
    base: &Path,
    buffers: &[gltf::buffer::Data],
) -> (Vec<Texture>, HashMap<usize, u32>, Vec<String>) {
    let mut wanted: Vec<(usize, Encoding)> = texture_uses(doc).into_iter().collect();
    wanted.sort_by_key(|(i, _)| *i);
    let textures: Vec<_> = doc.textures().collect();
    let decoded: Vec<Result<Texture, String>> = wanted
        .par_iter()
        .map(|&(index, encoding)| {
            let image = textures[index].source().ok_or_else(|| {
                format!(
                    "texture {index} has no core image, only extension alternates \
                     (such as MSFT_texture_dds) that holocave does not read"
                )
            })?;
            let name = image.name().map(str::to_string);
            let (bytes, label) = match image.source() {
                gltf::image::Source::Uri { uri, .. } => {
                    let label = name.unwrap_or_else(|| uri.to_string());
                    (read_uri(base, uri), label)
                }
                gltf::image::Source::View { view, .. } => {
                    let label = name.unwrap_or_else(|| format!("image {}", image.index()));
                    let data = &buffers[view.buffer().index()];
                    let range = view.offset()..view.offset() + view.length();
                    let bytes = data
                        .get(range)
                        .map(<[u8]>::to_vec)
                        .ok_or_else(|| "buffer view lies outside its buffer".to_string());
                    (bytes, label)
                }
            };
            let bytes = bytes.map_err(|e| format!("texture {label}: {e}"))?;
            let img = image::load_from_memory(&bytes)
                .map_err(|e| format!("texture {label}: cannot decode: {e}"))?
                .to_rgba8();
            let (w, h) = img.dimensions();
            if w == 0 || h == 0 {
                return Err(format!("texture {label}: empty image"));
            }
            let texels = img.pixels().map(|p| p.0).collect();
            Ok(Texture::new(label, w, h, texels, encoding))
        })
        .collect();
    let mut out = Vec::new();
    let mut map = HashMap::new();
    let mut warnings = Vec::new();
    for ((index, _), t) in wanted.iter().zip(decoded) {
        match t {
            Ok(t) => {
                map.insert(*index, out.len() as u32);
                out.push(t);
            }
            Err(e) => warnings.push(format!("{e}; its materials fall back to their factors")),
        }
    }
    let _ = path;
    (out, map, warnings)
}

fn srgb_factor_is_linear(c: [f32; 4]) -> Vec4 {
    // glTF factors are already linear.
    Vec4::from_array(c)
}

fn convert_material(m: &gltf::Material, textures: &HashMap<usize, u32>) -> Material {
    let tex = |info: Option<gltf::texture::Info>| {
        info.and_then(|i| textures.get(&i.texture().index()))
            .map(|&t| TextureRef { texture: t })
    };
    let pbr = m.pbr_metallic_roughness();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let (specular, specular_color) = match m.specular() {
        Some(s) => (
            s.specular_factor(),
            Vec3::from_array(s.specular_color_factor()),
        ),
        None => (1.0, Vec3::ONE),
    };
    let finite = |x: f32, default: f32| if x.is_finite() { x } else { default };
    Material {
        name: m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material {}", m.index().unwrap_or(0))),
        base_color: srgb_factor_is_linear(pbr.base_color_factor()),
        base_color_texture: tex(pbr.base_color_texture()),
        metallic: finite(pbr.metallic_factor(), 1.0),
        roughness: finite(pbr.roughness_factor(), 1.0),
        metallic_roughness_texture: tex(pbr.metallic_roughness_texture()),
        emissive: Vec3::from_array(m.emissive_factor()) * finite(strength, 1.0),
        emissive_texture: tex(m.emissive_texture()),
        specular: finite(specular, 1.0),
        specular_color,
        transmission: m
            .transmission()
            .map(|t| finite(t.transmission_factor(), 0.0))
            .unwrap_or(0.0),
        ior: m
            .ior()
            .filter(|i| i.is_finite() && *i >= 1.0)
            .unwrap_or(1.5),
        double_sided: m.double_sided(),
    }
}

/// A mesh as errors name it: its name, or `#` and its index.
fn mesh_label(mesh: &gltf::Mesh) -> String {
    mesh.name()
        .map(str::to_string)
        .unwrap_or_else(|| format!("#{}", mesh.index()))
}

impl Loader<'_> {
    fn geometry_error(&self, mesh: &gltf::Mesh, primitive: usize, message: String) -> SceneError {
        SceneError::Geometry {
            path: self.path.into(),
            mesh: mesh_label(mesh),
            primitive,
            message,
        }
    }

    /// Visits the scene's node trees depth first (pre-order, children in file order),
    /// with an explicit stack so that deep hierarchies cannot overflow the call stack.
    /// A node reached twice (a cycle, or a node with two parents, both invalid glTF) is
    /// an error: following it could loop forever or multiply the work exponentially.
    ///
    /// A node goes to the object that claims it or an ancestor; one under another
    /// object's node is an error. Returns which nodes were reached.
    fn visit_scene(&mut self, scene: &gltf::Scene) -> Result<Vec<bool>, SceneError> {
        let mut seen = vec![false; self.doc.nodes().len()];
        let mut stack: Vec<(gltf::Node, Mat4, Option<usize>)> = scene
            .nodes()
            .map(|n| (n, Mat4::IDENTITY, None))
            .collect::<Vec<_>>();
        stack.reverse();
        while let Some((node, parent, inherited)) = stack.pop() {
            if std::mem::replace(&mut seen[node.index()], true) {
                return Err(SceneError::Invalid {
                    path: self.path.into(),
                    message: format!(
                        "node {} is reached twice in the node hierarchy of scene {} \
                         (a cycle, or a node with two parents)",
                        node.index(),
                        scene.index()
                    ),
                });
            }
            let owner = match (self.claims[node.index()], inherited) {
                (Some(own), Some(above)) if own != above => {
                    return Err(SceneError::Objects {
                        path: self.path.into(),
                        message: format!(
                            "node {} is claimed by two objects, {:?} and {:?} (it lies under the other's node)",
                            node.index(),
                            self.parts.objects[above].name,
                            self.parts.objects[own].name
                        ),
                    });
                }
                (own, above) => own.or(above),
            };
            let world = self.visit(&node, parent, owner)?;
            let first = stack.len();
            stack.extend(node.children().map(|c| (c, world, owner)));
            stack[first..].reverse();
        }
        Ok(seen)
    }

    /// Checks every object's nodes were reached, warns of lights and cameras under
    /// them, and moves each object's triangles into its own frame.
    fn finish_objects(&mut self, seen: &[bool]) -> Result<(), SceneError> {
        for (k, &node) in self.first_nodes.iter().enumerate() {
            let unreached = (0..seen.len()).find(|&n| self.claims[n] == Some(k) && !seen[n]);
            if let Some(n) = unreached.or((!seen[node]).then_some(node)) {
                return Err(SceneError::Objects {
                    path: self.path.into(),
                    message: format!(
                        "object {:?}: node {n} ({:?}) is not in the scene that is drawn",
                        self.parts.objects[k].name,
                        self.doc.nodes().nth(n).and_then(|n| n.name()).unwrap_or("")
                    ),
                });
            }
        }
        if self.static_under_objects > 0 {
            self.parts.warnings.push(format!(
                "{} lights and cameras lie under movable objects; they stay where they are loaded",
                self.static_under_objects
            ));
        }
        for o in &mut self.parts.objects {
            let rest = o.rest;
            for (p, s) in o.positions.iter_mut().zip(&mut o.shading) {
                *p = p.map(|v| rest.to_local_point(v));
                if let Some(n) = &mut s.normals {
                    *n = n.map(|v| rest.to_local_dir(v));
                }
            }
        }
        Ok(())
    }

    /// Adds one node's mesh (to `owner`, the movable object it belongs to, if any),
    /// light and camera; returns its world transform.
    fn visit(
        &mut self,
        node: &gltf::Node,
        parent: Mat4,
        owner: Option<usize>,
    ) -> Result<Mat4, SceneError> {
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if let Some(k) = owner
            && self.first_nodes[k] == node.index()
        {
            self.parts.objects[k].rest = Placement::rigid_part(&world);
        }
        if let Some(mesh) = node.mesh() {
            for (i, prim) in mesh.primitives().enumerate() {
                self.add_primitive(&mesh, i, &prim, &world, owner)?;
            }
        }
        if owner.is_some() {
            self.static_under_objects +=
                usize::from(node.light().is_some()) + usize::from(node.camera().is_some());
        }
        let (_, rotation, position) = world.to_scale_rotation_translation();
        if let Some(light) = node.light() {
            self.add_light(&light, position, rotation);
        }
        if let Some(camera) = node.camera()
            && let gltf::camera::Projection::Perspective(p) = camera.projection()
        {
            self.parts.cameras.push(NamedCamera {
                name: camera
                    .name()
                    .or(node.name())
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("camera {}", camera.index())),
                position,
                rotation,
                yfov: p.yfov(),
                aspect: p.aspect_ratio(),
            });
        }
        Ok(world)
    }

    fn add_light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        position: Vec3,
        rotation: Quat,
    ) {
        use gltf::khr_lights_punctual::Kind;
        let kind = match light.kind() {
            Kind::Point => PunctualKind::Point,
            Kind::Directional => PunctualKind::Directional,
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => PunctualKind::Spot {
                cos_inner: inner_cone_angle.cos(),
                cos_outer: outer_cone_angle.cos(),
            },
        };
        let intensity = Vec3::from_array(light.color()) * light.intensity();
        if !intensity.is_finite() || !position.is_finite() {
            self.parts.warnings.push(format!(
                "light {} has non-finite values; ignored",
                light.index()
            ));
            return;
        }
        self.parts.lights.push(PunctualLight {
            name: light
                .name()
                .map(str::to_string)
                .unwrap_or_else(|| format!("light {}", light.index())),
            kind,
            position,
            direction: (rotation * Vec3::NEG_Z).normalize(),
            intensity,
            range: light.range(),
        });
    }

    /// Checks an accessor before the `gltf` reader sees it: its element type is one the
    /// reader accepts for `what` (it panics on others), it is not sparse, and its bytes
    /// lie inside its buffer view and buffer.
    fn check_accessor(
        &self,
        a: &gltf::Accessor,
        what: &str,
        types: &[(DataType, Dimensions)],
    ) -> Result<(), String> {
        let index = a.index();
        if !types.contains(&(a.data_type(), a.dimensions())) {
            return Err(format!(
                "{what} accessor {index} has type {:?} {:?}, which is not allowed for {what}",
                a.dimensions(),
                a.data_type()
            ));
        }
        if a.sparse().is_some() {
            return Err(format!("{what} accessor {index} is sparse (not supported)"));
        }
        let Some(view) = a.view() else {
            return Err(format!("{what} accessor {index} has no buffer view"));
        };
        if a.count() == 0 {
            return Err(format!("{what} accessor {index} has no elements"));
        }
        let buffer_len = self.buffers[view.buffer().index()].len();
        let view_end = view.offset().checked_add(view.length());
        if view_end.is_none_or(|end| end > buffer_len) {
            return Err(format!(
                "buffer view {} (bytes {} + {}) runs past its buffer's {} bytes",
                view.index(),
                view.offset(),
                view.length(),
                buffer_len
            ));
        }
        let elem = a.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(format!(
                "{what} accessor {index}: buffer view {} has a stride of {stride} bytes, \
                 less than the {elem}-byte element",
                view.index()
            ));
        }
        let need = (a.count() - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(a.offset()))
            .and_then(|n| n.checked_add(elem));
        if need.is_none_or(|need| need > view.length()) {
            return Err(format!(
                "{what} accessor {index} ({} elements from byte {}) needs more than the {} bytes of its buffer view",
                a.count(),
                a.offset(),
                view.length()
            ));
        }
        Ok(())
    }

    /// The index of `prim`'s material among the scene's (the default material, the last,
    /// where it names none or one out of range).
    fn material_of(&self, prim: &gltf::Primitive) -> u32 {
        let last = self.parts.materials.len() - 1;
        prim.material().index().unwrap_or(last).min(last) as u32
    }

    /// Whether `prim`'s position, normal, texture coordinate and index accessors have the
    /// types glTF allows; the problem, said, where not.
    fn check_attributes(&self, prim: &gltf::Primitive) -> Result<(), String> {
        use Dimensions::{Scalar, Vec2 as V2, Vec3 as V3};
        let Some(pos) = prim.get(&Semantic::Positions) else {
            return Err("has no POSITION attribute".into());
        };
        self.check_accessor(&pos, "POSITION", &[(DataType::F32, V3)])?;
        if let Some(a) = prim.get(&Semantic::Normals) {
            self.check_accessor(&a, "NORMAL", &[(DataType::F32, V3)])?;
        }
        if let Some(a) = prim.get(&Semantic::TexCoords(0)) {
            let types = [DataType::F32, DataType::U8, DataType::U16].map(|t| (t, V2));
            self.check_accessor(&a, "TEXCOORD_0", &types)?;
        }
        if let Some(a) = prim.indices() {
            let types = [DataType::U8, DataType::U16, DataType::U32].map(|t| (t, Scalar));
            self.check_accessor(&a, "indices", &types)?;
        }
        Ok(())
    }

    fn add_primitive(
        &mut self,
        mesh: &gltf::Mesh,
        index: usize,
        prim: &gltf::Primitive,
        world: &Mat4,
        owner: Option<usize>,
    ) -> Result<(), SceneError> {
        let err = |this: &Self, m: String| this.geometry_error(mesh, index, m);
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.parts.warnings.push(format!(
                "mesh {:?} primitive {index}: mode {mode:?} has no surface; skipped",
                mesh.name().unwrap_or("")
            ));
            return Ok(());
        }
        self.check_attributes(prim).map_err(|m| err(self, m))?;
        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| err(self, "has no POSITION attribute".into()))?
            .map(Vec3::from_array)
            .collect();
        if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
            return Err(err(
                self,
                format!("vertex {bad} has a NaN or infinite position"),
            ));
        }
        let normals: Option<Vec<Vec3>> = reader
            .read_normals()
            .map(|n| n.map(Vec3::from_array).collect());
        let uvs: Option<Vec<Vec2>> = reader
            .read_tex_coords(0)
            .map(|t| t.into_f32().map(Vec2::from_array).collect());
        same_counts(positions.len(), &normals, &uvs).map_err(|m| err(self, m))?;
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        if let Some(bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(err(
                self,
                format!("index {bad} is out of range ({} vertices)", positions.len()),
            ));
        }
        let triangles = triangles_of(mode, &indices);
        // A mirroring transform reverses the winding; swap two vertices to keep the
        // front face in front (glTF §3.7.4).
        let mirrored = world.determinant() < 0.0;
        let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
        let material = self.material_of(prim);
        let path = self.path;
        let (out_positions, out_shading) = match owner {
            Some(k) => {
                let o = &mut self.parts.objects[k];
                (&mut o.positions, &mut o.shading)
            }
            None => (&mut self.parts.positions, &mut self.parts.shading),
        };
        for tri in triangles {
            let tri = if mirrored {
                [tri[0], tri[2], tri[1]]
            } else {
                tri
            };
            let p = tri.map(|i| world.transform_point3(positions[i as usize]));
            if p.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::Geometry {
                    path: path.into(),
                    mesh: mesh_label(mesh),
                    primitive: index,
                    message: "a transformed vertex is not finite".into(),
                });
            }
            let n = normals
                .as_ref()
                .map(|n| tri.map(|i| (normal_matrix * n[i as usize]).normalize_or_zero()));
            // Unusable vertex normals (zero, NaN) fall back to the face normal.
            let n = n.filter(|n| n.iter().all(|v| v.is_finite() && *v != Vec3::ZERO));
            let uv = uvs
                .as_ref()
                .map(|t| tri.map(|i| t[i as usize]))
                .filter(|t| t.iter().all(|v| v.is_finite()))
                .unwrap_or([Vec2::ZERO; 3]);
            out_positions.push(p);
            out_shading.push(TriangleShading {
                normals: n,
                uvs: uv,
                material,
            });
        }
        let _ = self.doc;
        Ok(())
    }
}

/// The triangles of a primitive drawn in `mode` (triangles, a strip or a fan) from its
/// vertex `indices`, each wound as glTF winds it.
fn triangles_of(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        Mode::TriangleStrip => (2..indices.len())
            .map(|i| {
                if i % 2 == 0 {
                    [indices[i - 2], indices[i - 1], indices[i]]
                } else {
                    [indices[i - 1], indices[i - 2], indices[i]]
                }
            })
            .collect(),
        _ => (2..indices.len())
            .map(|i| [indices[0], indices[i - 1], indices[i]])
            .collect(),
    }
}

/// Whether the normals and texture coordinates, where a primitive has them, number as its
/// `vertices` positions (glTF requires every attribute of a primitive to have the same
/// count); the problem, said, where not.
fn same_counts(
    vertices: usize,
    normals: &Option<Vec<Vec3>>,
    uvs: &Option<Vec<Vec2>>,
) -> Result<(), String> {
    for (name, len) in [
        ("NORMAL", normals.as_ref().map(Vec::len)),
        ("TEXCOORD_0", uvs.as_ref().map(Vec::len)),
    ] {
        if let Some(len) = len
            && len != vertices
        {
            return Err(format!(
                "{name} has {len} elements but POSITION has {vertices}"
            ));
        }
    }
    Ok(())
}
