//! The material data a hit needs, on the GPU (`surfaces.wgsl` beside this file), uploaded
//! once per scene: per static triangle its vertex normals, face normal, texture
//! coordinates and material (80 bytes); per material its base colour factor and texture
//! and the table of its directional albedo towards a viewer
//! ([`holocave_vlf::surface::albedo_towards`]: 32 steps of `a + b · base`); the base colour
//! textures' texels as the CPU holds them (RGBA8) with the CPU's values of each code. From a hit
//! the shader reads the shading normal, the base colour and the albedo towards the eye in
//! the CPU's operations ([`holocave_scene::Scene::surface`], `Material::params`,
//! `Texture::sample`): the same numbers up to the float bound `tests/vlf_base.rs` derives.
//!
//! A material whose albedo varies over its surface other than through its base colour (a
//! metallic-roughness texture: a table per texel) has no table here, nor one whose
//! texture does not fit the device's largest storage binding beside the others'; the
//! pixels that see it are shaded on the CPU.

use bytemuck::{Pod, Zeroable};
use glam::Vec2;
use holocave_scene::Scene;
use holocave_scene::texture::srgb_table;
use holocave_scene::{Encoding, Hit};
use holocave_vlf::surface::{TOWARDS_STEPS, towards_table};

use crate::gpu::Gpu;

/// `NO_SURFACE` in the shader.
const NONE: u32 = u32::MAX;
/// `HAS_NORMALS` in the shader.
const HAS_NORMALS: u32 = 1 << 31;

/// `TriangleSurface` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct TriangleSurface {
    n0: [f32; 4],
    n1: [f32; 4],
    n2: [f32; 4],
    ng: [f32; 4],
    uv2: [f32; 2],
    material: u32,
    pad: u32,
}

/// `MaterialSurface` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct MaterialSurface {
    base_color: [f32; 4],
    texture: u32,
    table: u32,
    pad: [u32; 2],
}

/// One scene's surfaces on the GPU: the six buffers `surfaces.wgsl` binds, in its
/// binding order, and which materials it shades.
pub struct SceneSurfaces {
    pub(super) buffers: [wgpu::Buffer; 6],
    /// Per static triangle: whether the GPU has its material's table (and texture).
    shaded: Vec<bool>,
}

impl SceneSurfaces {
    /// `scene`'s surfaces uploaded to `gpu`; `None`, with a warning that says why, where
    /// its triangles' data exceed one of the adapter's storage bindings.
    pub fn new(gpu: &Gpu, scene: &Scene) -> Option<SceneSurfaces> {
        let limits = gpu.device.limits();
        let limit = (limits.max_storage_buffer_binding_size)
            .min(limits.max_buffer_size)
            .min(u64::from(u32::MAX));
        let bytes = (scene.triangle_count() * std::mem::size_of::<TriangleSurface>()) as u64;
        if bytes > limit {
            tracing::warn!(
                "material data not on the GPU: the scene's triangles take {bytes} bytes there, \
                 the adapter binds at most {limit}; the light field's lookups are sent whole"
            );
            return None;
        }
        let triangles = triangle_surfaces(scene);
        // The base colour textures that fit one binding, in the materials' order.
        let limit = limit as usize / 4;
        let mut texels: Vec<[u8; 4]> = Vec::new();
        let mut textures: Vec<[u32; 4]> = Vec::new();
        let mut placed = vec![None; scene.textures.len()];
        let mut towards: Vec<[f32; 4]> = Vec::new();
        let mut on_gpu = Vec::with_capacity(scene.materials.len());
        let materials: Vec<MaterialSurface> = (scene.materials.iter())
            .map(|m| {
                let texture = m.base_color_texture.map(|r| {
                    let t = &scene.textures[r.texture as usize];
                    let n = t.texels().len();
                    *placed[r.texture as usize].get_or_insert_with(|| {
                        if texels.len() + n > limit {
                            return NONE;
                        }
                        textures.push([
                            texels.len() as u32,
                            t.width(),
                            t.height(),
                            u32::from(t.encoding() == Encoding::Srgb),
                        ]);
                        texels.extend_from_slice(t.texels());
                        textures.len() as u32 - 1
                    })
                });
                let shaded = m.metallic_roughness_texture.is_none() && texture != Some(NONE);
                on_gpu.push(shaded);
                let table = if shaded {
                    let first = towards.len() as u32;
                    let params = m.params(&scene.textures, Vec2::ZERO);
                    for (a, b) in towards_table(&params) {
                        towards.push(a.extend(0.0).to_array());
                        towards.push(b.extend(0.0).to_array());
                    }
                    first
                } else {
                    NONE
                };
                MaterialSurface {
                    base_color: m.base_color.to_array(),
                    texture: texture.unwrap_or(NONE),
                    table,
                    pad: [0; 2],
                }
            })
            .collect();
        debug_assert_eq!(towards.len() % (2 * TOWARDS_STEPS), 0);
        let shaded = on_gpu.iter().filter(|&&on| on).count();
        tracing::info!(
            "material data on the GPU: {shaded} of {} materials shaded there, {} textures \
             ({:.1} MB of texels); the others' pixels shaded on the CPU",
            on_gpu.len(),
            textures.len(),
            texels.len() as f64 * 4e-6,
        );
        // Each 8-bit code's linear value read as sRGB, then as linear: the CPU's values.
        let codes: Vec<f32> = (srgb_table().iter().copied())
            .chain((0..=255u8).map(|c| c as f32 / 255.0))
            .collect();
        let upload = |label, bytes: &[u8]| {
            // A binding is never empty.
            gpu.storage_init(label, if bytes.is_empty() { &[0; 16] } else { bytes })
        };
        Some(SceneSurfaces {
            buffers: [
                upload("gpu surfaces: triangles", bytemuck::cast_slice(&triangles)),
                upload("gpu surfaces: materials", bytemuck::cast_slice(&materials)),
                upload(
                    "gpu surfaces: albedo tables",
                    bytemuck::cast_slice(&towards),
                ),
                upload("gpu surfaces: textures", bytemuck::cast_slice(&textures)),
                upload("gpu surfaces: texels", bytemuck::cast_slice(&texels)),
                upload("gpu surfaces: texel codes", bytemuck::cast_slice(&codes)),
            ],
            shaded: (0..scene.triangle_count() as u32)
                .map(|i| on_gpu.get(scene.triangle_shading(i).material as usize) == Some(&true))
                .collect(),
        })
    }

    /// Whether the GPU shades what `hit` sees of its surface (its material's table there).
    pub fn shades(&self, hit: &Hit) -> bool {
        (self.shaded.get(hit.triangle as usize)).is_some_and(|&on| on)
    }
}

/// Every triangle's shading normals, texture coordinates and material, as the GPU reads
/// them.
fn triangle_surfaces(scene: &Scene) -> Vec<TriangleSurface> {
    (0..scene.triangle_count() as u32)
        .map(|i| {
            let s = scene.triangle_shading(i);
            let ng = scene.face_normal(i);
            let n = s.normals.unwrap_or([ng; 3]);
            let (uv, has) = (s.uvs, if s.normals.is_some() { HAS_NORMALS } else { 0 });
            TriangleSurface {
                n0: n[0].extend(uv[0].x).to_array(),
                n1: n[1].extend(uv[0].y).to_array(),
                n2: n[2].extend(uv[1].x).to_array(),
                ng: ng.extend(uv[1].y).to_array(),
                uv2: uv[2].to_array(),
                material: s.material | has,
                pad: 0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::*;
    use crate::gpu::layout::{assert_same_layout, every_field};
    use crate::gpu::with_common;

    #[test]
    fn the_wgsl_structs_are_laid_out_as_in_rust() {
        let src = with_common(include_str!("surfaces.wgsl"));
        every_field!(TriangleSurface {
            n0,
            n1,
            n2,
            ng,
            uv2,
            material,
            pad
        });
        assert_same_layout(
            &src,
            "TriangleSurface",
            size_of::<TriangleSurface>(),
            &[
                ("n0", offset_of!(TriangleSurface, n0)),
                ("n1", offset_of!(TriangleSurface, n1)),
                ("n2", offset_of!(TriangleSurface, n2)),
                ("ng", offset_of!(TriangleSurface, ng)),
                ("uv2", offset_of!(TriangleSurface, uv2)),
                ("material", offset_of!(TriangleSurface, material)),
                ("pad", offset_of!(TriangleSurface, pad)),
            ],
        );
        every_field!(MaterialSurface {
            base_color,
            texture,
            table,
            pad
        });
        let pad = offset_of!(MaterialSurface, pad);
        assert_same_layout(
            &src,
            "MaterialSurface",
            size_of::<MaterialSurface>(),
            &[
                ("base_color", offset_of!(MaterialSurface, base_color)),
                ("texture", offset_of!(MaterialSurface, texture)),
                ("table", offset_of!(MaterialSurface, table)),
                ("pad0", pad),
                ("pad1", pad + 4),
            ],
        );
    }
}
