//! Materials: glTF's metallic-roughness model with the extensions holocave reads
//! (`KHR_materials_emissive_strength`, `_specular`, `_transmission`, `_ior`).
//!
//! The parameters are stored as glTF gives them; how they scatter light is the tracer's
//! business (`holocave-tracer`'s BSDF).

use glam::{Vec2, Vec3, Vec4};

use crate::texture::Texture;

/// A texture reference: index into `Scene::textures`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
}

/// The surface parameters at one point, textures applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceParams {
    pub base_color: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    /// Emitted radiance (emissive factor × texture × strength).
    pub emission: Vec3,
    pub specular: f32,
    pub specular_color: Vec3,
    pub transmission: f32,
    pub ior: f32,
}

/// glTF's defaults: white, metallic, rough, no emission, the dielectric specular layer at
/// full strength, opaque, index of refraction 1.5.
impl Default for SurfaceParams {
    fn default() -> Self {
        SurfaceParams {
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            emission: Vec3::ZERO,
            specular: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
        }
    }
}

/// One glTF material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA base colour factor.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    pub roughness: f32,
    /// Metallic in B, roughness in G (glTF's layout).
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Emissive factor already multiplied by `KHR_materials_emissive_strength`.
    pub emissive: Vec3,
    pub emissive_texture: Option<TextureRef>,
    /// `KHR_materials_specular`: 0 turns the dielectric specular layer off (pure Lambert).
    pub specular: f32,
    pub specular_color: Vec3,
    /// `KHR_materials_transmission`.
    pub transmission: f32,
    /// `KHR_materials_ior`.
    pub ior: f32,
    pub double_sided: bool,
}

impl Default for Material {
    /// glTF's default material: white, fully metallic, fully rough.
    fn default() -> Self {
        Self {
            name: "default".into(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            specular: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
            double_sided: false,
        }
    }
}

/// What kind of scattering a material can do; the tracer uses it to skip work a scene
/// does not need.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MaterialKind {
    /// Lambert only (no specular layer, not metallic, not transmissive).
    Diffuse,
    /// Rough (microfacet) reflection, possibly over a diffuse base.
    Glossy,
    /// A perfect mirror (roughness 0, metallic).
    Mirror,
    /// Glass: smooth or rough transmission.
    Transmissive,
}

impl Material {
    /// Whether any of the emissive inputs is non-zero.
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }

    /// The scattering kind, judged from the factors (textures only scale them down).
    pub fn kind(&self) -> MaterialKind {
        if self.transmission > 0.0 {
            MaterialKind::Transmissive
        } else if self.metallic >= 1.0
            && self.roughness <= 0.0
            && self.metallic_roughness_texture.is_none()
        {
            MaterialKind::Mirror
        } else if self.metallic <= 0.0
            && self.metallic_roughness_texture.is_none()
            && self.specular <= 0.0
        {
            MaterialKind::Diffuse
        } else {
            MaterialKind::Glossy
        }
    }

    /// The parameters at a surface point, reading the material's textures.
    /// Only the first UV set is kept by the loader, so every texture reads `uv`.
    pub fn params(&self, textures: &[Texture], uv: Vec2) -> SurfaceParams {
        let read = |r: &Option<TextureRef>| r.map(|r| textures[r.texture as usize].sample(uv));
        let mut base = self.base_color.truncate();
        if let Some(t) = read(&self.base_color_texture) {
            base *= t.truncate();
        }
        let (mut metallic, mut roughness) = (self.metallic, self.roughness);
        if let Some(t) = read(&self.metallic_roughness_texture) {
            roughness *= t.y;
            metallic *= t.z;
        }
        let mut emission = self.emissive;
        if let Some(t) = read(&self.emissive_texture) {
            emission *= t.truncate();
        }
        SurfaceParams {
            base_color: base.clamp(Vec3::ZERO, Vec3::ONE),
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            emission,
            specular: self.specular.clamp(0.0, 1.0),
            specular_color: self.specular_color.max(Vec3::ZERO),
            transmission: self.transmission.clamp(0.0, 1.0),
            ior: self.ior,
        }
    }
}
