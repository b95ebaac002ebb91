//! The light field on the cache's GPU: its values, split over storage buffers within the
//! adapter's binding limit and updated where gathers changed them, its prior, each eye's
//! lookups, and the field's shading alone for tests.

use holocave_tracer::film::Image;
use holocave_vlf::Lookup;

use super::RenderCache;
use super::buffers::{VLF_BUFFERS, VlfBuffers};
use super::recorder::Recorder;
use super::records::VlfParams;
use crate::RenderNodeError;

impl RenderCache {
    /// Draws a Virtual Light Field under the cache's samples from now on: `values`, the
    /// irradiance of every element then the radiance of every glossy tile's bins (from a
    /// `.vlf` file: `holocave_vlf::State::values`), worth `prior` samples in each pixel (see
    /// `cache/shade_field.wgsl`). Each frame needs every eye's lookups ([`Self::set_lookups`]).
    pub fn set_vlf(&mut self, values: &[[f32; 3]], prior: f32) -> Result<(), RenderNodeError> {
        let limit = self.gpu.device.limits().max_storage_buffer_binding_size;
        // Floats per buffer: what one binding holds, in whole 256-byte blocks.
        let chunk = ((limit / 4) & !63).min(u64::from(u32::MAX / VLF_BUFFERS as u32)) as usize;
        self.set_vlf_split(values, prior, chunk)
    }

    /// [`Self::set_vlf`] with the values split into buffers of `chunk` floats.
    fn set_vlf_split(
        &mut self,
        values: &[[f32; 3]],
        prior: f32,
        chunk: usize,
    ) -> Result<(), RenderNodeError> {
        let flat: &[f32] = bytemuck::cast_slice(values);
        let limit = 4 * chunk;
        if flat.len() > chunk * VLF_BUFFERS {
            return Err(RenderNodeError::Vlf(format!(
                "the light field's values take {} bytes; this adapter binds {VLF_BUFFERS} buffers of at most {limit} bytes",
                flat.len() * 4
            )));
        }
        let irr: Vec<wgpu::Buffer> = (0..VLF_BUFFERS)
            .map(|b| {
                let part = &flat[(b * chunk).min(flat.len())..((b + 1) * chunk).min(flat.len())];
                let data: &[f32] = if part.is_empty() { &[0.0; 3] } else { part };
                self.gpu
                    .storage_init("vlf irradiance", bytemuck::cast_slice(data))
            })
            .collect();
        let eyes = self
            .eyes
            .iter()
            .map(|e| {
                let n = u64::from(e.width) * u64::from(e.height);
                let params = self
                    .gpu
                    .uniform("vlf params", std::mem::size_of::<VlfParams>() as u64);
                let p = VlfParams {
                    width: e.width,
                    height: e.height,
                    index_bits: self.index_bits,
                    prior,
                    chunk: chunk as u32,
                    spread: 0.0,
                    _pad: [0; 2],
                };
                self.gpu
                    .queue
                    .write_buffer(&params, 0, bytemuck::bytes_of(&p));
                let lookups = self
                    .gpu
                    .storage("vlf lookups", std::mem::size_of::<Lookup>() as u64 * n);
                let bg = self.passes.vlf.bind_group(
                    &self.gpu,
                    [
                        &params,
                        &lookups,
                        &irr[0],
                        &self.points,
                        &e.key,
                        &e.color,
                        &e.priority,
                        &e.counters,
                        &irr[1],
                        &irr[2],
                        &irr[3],
                    ],
                );
                (params, lookups, bg)
            })
            .collect();
        self.vlf = Some(VlfBuffers {
            irradiance: irr,
            chunk,
            floats: flat.len(),
            eyes,
        });
        Ok(())
    }

    /// New values for the light field [`Self::set_vlf`] gave (as many, in the same order:
    /// the gathers kept in its elements), of which those in `changed` are sent; nothing
    /// without a light field, or for values of another length.
    pub fn update_vlf_values(&mut self, values: &[[f32; 3]], changed: &[std::ops::Range<usize>]) {
        let Some(v) = &self.vlf else { return };
        let flat: &[f32] = bytemuck::cast_slice(values);
        if flat.len() != v.floats {
            return;
        }
        for r in changed {
            // The range in floats, cut where one buffer of `chunk` floats ends.
            let (mut at, end) = (3 * r.start.min(values.len()), 3 * r.end.min(values.len()));
            while at < end {
                let (b, offset) = (at / v.chunk, at % v.chunk);
                let upto = end.min((b + 1) * v.chunk);
                self.gpu.queue.write_buffer(
                    &v.irradiance[b],
                    4 * offset as u64,
                    bytemuck::cast_slice(&flat[at..upto]),
                );
                at = upto;
            }
        }
    }

    /// What the light field is worth from now on, in samples per pixel (see
    /// [`Self::set_vlf`]): `prior` where a pixel's samples spread as the display's do,
    /// `spread` their variance over `μ² + 0.01` ([`crate::light_field::prior::Measured::spread`]),
    /// scaled in each pixel by how its own samples spread (`cache/shade_field.wgsl`); with
    /// `spread` 0, `prior` in every pixel. Nothing without a light field.
    pub fn set_vlf_prior(&mut self, prior: f32, spread: f32) {
        if let Some(v) = &self.vlf {
            for (params, _, _) in &v.eyes {
                for (field, value) in [
                    (std::mem::offset_of!(VlfParams, prior), prior),
                    (std::mem::offset_of!(VlfParams, spread), spread),
                ] {
                    self.gpu
                        .queue
                        .write_buffer(params, field as u64, bytemuck::bytes_of(&value));
                }
            }
        }
    }

    /// What each pixel of eye `eye` sees of the light field this frame (one per pixel,
    /// rows from the top). Does nothing without [`Self::set_vlf`].
    pub fn set_lookups(&mut self, eye: usize, lookups: &[Lookup]) {
        let Some(v) = &self.vlf else { return };
        let e = &self.eyes[eye];
        assert_eq!(
            lookups.len(),
            (e.width * e.height) as usize,
            "one lookup per pixel"
        );
        self.gpu
            .queue
            .write_buffer(&v.eyes[eye].1, 0, bytemuck::cast_slice(lookups));
    }

    /// Eye `eye`'s lookups on the GPU (sixteen words a pixel, as [`Self::set_lookups`]
    /// writes them), for a pass that writes them there; `None` without [`Self::set_vlf`].
    pub fn lookups_buffer(&self, eye: usize) -> Option<&wgpu::Buffer> {
        Some(&self.vlf.as_ref()?.eyes.get(eye)?.1)
    }

    /// The light field alone in eye `eye` (its lookups shaded on the GPU): the shader's
    /// side of the CPU/GPU comparison, and a picture of the base itself. Overwrites the
    /// eye's image until the next [`Self::draw`].
    pub fn vlf_image(&mut self, eye: usize) -> Option<Image> {
        let v = self.vlf.as_ref()?;
        let e = &self.eyes[eye];
        let mut r = Recorder::new(&self.gpu, false);
        self.passes
            .vlf
            .lookup(&mut r, &v.eyes[eye].2, e.width * e.height);
        r.submit();
        Some(self.image(eye))
    }
}

#[cfg(test)]
mod tests {
    use holocave_cave::Size;
    use holocave_vlf::Lookup;

    use super::RenderCache;
    use crate::gpu::Gpu;

    /// The light field's values split over the four buffers (here 300 floats each, a
    /// value's three floats straddling a boundary at every 100th element) read as one
    /// array: each pixel's element, looked up on the GPU, is the value the CPU holds; and
    /// more values than four buffers hold are refused, not drawn.
    #[test]
    fn values_split_over_buffers_read_as_one() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        let (w, h) = (20u32, 19u32);
        let mut cache = RenderCache::new(gpu, &[Size::new(w, h)], 64, 64);
        let values: Vec<[f32; 3]> = (0..380).map(|i| [i as f32, 0.5 * i as f32, 1.0]).collect();
        cache.set_vlf_split(&values, 0.0, 300).unwrap();
        let lookups: Vec<Lookup> = (0..w * h)
            .map(|i| Lookup {
                base: i,
                res: 1,
                weight: [1.0; 3],
                ..Lookup::NONE
            })
            .collect();
        cache.set_lookups(0, &lookups);
        let image = cache.vlf_image(0).unwrap();
        for (i, px) in image.pixels.iter().enumerate() {
            assert_eq!(px.to_array(), values[i], "element {i}");
        }
        let too_many = vec![[0.0; 3]; 401];
        assert!(cache.set_vlf_split(&too_many, 0.0, 300).is_err());
    }
}
