//! A minimal glTF 2.0 writer: triangle meshes with normals, materials as JSON, nodes
//! with translation/rotation/scale, and one base64-embedded buffer. Output is
//! deterministic (same input, same bytes).

use base64::Engine;
use glam::{Quat, Vec3};
use serde_json::{Value, json};

/// Builds one glTF document.
#[derive(Default)]
pub struct GltfWriter {
    buffer: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    nodes: Vec<Value>,
    cameras: Vec<Value>,
    extensions_used: Vec<&'static str>,
}

impl GltfWriter {
    /// Adds a material (a glTF material object); returns its index.
    pub fn material(&mut self, m: Value) -> usize {
        for ext in [
            "KHR_materials_emissive_strength",
            "KHR_materials_transmission",
            "KHR_materials_ior",
            "KHR_materials_specular",
        ] {
            if m.pointer(&format!("/extensions/{ext}")).is_some()
                && !self.extensions_used.contains(&ext)
            {
                self.extensions_used.push(ext);
            }
        }
        self.materials.push(m);
        self.materials.len() - 1
    }

    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.buffer.len().is_multiple_of(4) {
            self.buffer.push(0);
        }
        self.views.push(json!({
            "buffer": 0, "byteOffset": self.buffer.len(), "byteLength": bytes.len(), "target": target
        }));
        self.buffer.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn vec3_accessor(&mut self, v: &[Vec3]) -> usize {
        let bytes: Vec<u8> = v
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.push_view(&bytes, 34962);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in v {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": v.len(), "type": "VEC3",
            "min": lo.to_array(), "max": hi.to_array()
        }));
        self.accessors.len() - 1
    }

    /// Adds a mesh of one indexed triangle primitive; returns its index.
    pub fn mesh(
        &mut self,
        name: &str,
        positions: &[Vec3],
        normals: &[Vec3],
        indices: &[u32],
        material: usize,
    ) -> usize {
        let pos = self.vec3_accessor(positions);
        let nor = self.vec3_accessor(normals);
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34963);
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5125, "count": indices.len(), "type": "SCALAR"
        }));
        let idx = self.accessors.len() - 1;
        self.meshes.push(json!({
            "name": name,
            "primitives": [{ "attributes": { "POSITION": pos, "NORMAL": nor }, "indices": idx, "material": material }]
        }));
        self.meshes.len() - 1
    }

    /// Places a mesh in the scene.
    pub fn node(
        &mut self,
        name: &str,
        mesh: usize,
        translation: Vec3,
        rotation: Quat,
        scale: Vec3,
    ) {
        self.nodes.push(json!({
            "name": name, "mesh": mesh,
            "translation": translation.to_array(), "rotation": rotation.to_array(), "scale": scale.to_array()
        }));
    }

    /// Adds a perspective camera at `position` looking along `rotation · −Z`.
    pub fn camera(&mut self, name: &str, position: Vec3, rotation: Quat, yfov: f32) {
        self.cameras.push(json!({ "name": name, "type": "perspective", "perspective": { "yfov": yfov, "znear": 0.01 } }));
        self.nodes.push(json!({
            "name": name, "camera": self.cameras.len() - 1,
            "translation": position.to_array(), "rotation": rotation.to_array()
        }));
    }

    /// The finished document as pretty-printed JSON.
    pub fn finish(self) -> String {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.buffer)
        );
        let mut doc = json!({
            "asset": { "version": "2.0", "generator": "holocave scene generate" },
            "scene": 0,
            "scenes": [{ "nodes": (0..self.nodes.len()).collect::<Vec<_>>() }],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{ "byteLength": self.buffer.len(), "uri": uri }],
        });
        if !self.cameras.is_empty() {
            doc["cameras"] = Value::Array(self.cameras);
        }
        if !self.extensions_used.is_empty() {
            doc["extensionsUsed"] = json!(self.extensions_used);
        }
        let mut s = serde_json::to_string_pretty(&doc).expect("JSON values always serialise");
        s.push('\n');
        s
    }
}
