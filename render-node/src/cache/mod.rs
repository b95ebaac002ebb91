//! The render cache on the GPU (Walter, Drettakis & Parker; `papers/render-cache.md`): a
//! fixed-size cache of shaded points shared by every eye, projected and filtered into each
//! eye's image by compute shaders, which also choose the pixels to sample next.
//!
//! Per frame ([`RenderCache::draw`]), for each eye: clear, z-buffered projection
//! (`cache/project.wgsl`), 3×3 depth cull and 3×3 interpolation with the priority image
//! (`cache/filter.wgsl`), error-diffusion choice of pixels (`cache/dither.wgsl`); then
//! aging of all points (`cache/age.wgsl`). Samples come back through
//! [`RenderCache::insert`] (`cache/insert.wgsl`). Every pass is linear in pixels or points.
//!
//! Each shader file has a small module beside it in `cache/` that owns its pipelines and
//! bind group layout, makes its bind groups and records its passes; [`RenderCache::new`]
//! assembles them.

use std::time::Duration;

use holocave_cave::Size;

use crate::EyeView;
use crate::gpu::Gpu;

mod age;
mod budget;
mod buffers;
mod dither;
mod field_buffers;
mod filter;
mod insert;
mod objects;
mod project;
mod read_back;
mod recorder;
mod records;
mod shade_field;

pub use objects::{ObjectMove, SKY_SHARE, ShadowLight};

use budget::exactly;
use buffers::{EyeBuffers, Passes, SharedBuffers, VlfBuffers};
use recorder::Recorder;
use records::{EyeParams, InsertParams};
pub use records::{GpuPoint, NewSample};

/// Points per replacement group (the oldest of a group is replaced, groups round robin).
pub const GROUP_SIZE: u32 = 8;
/// A surface id for rays that escaped the scene.
pub const BACKGROUND: u32 = u32::MAX - 1;
/// Moving objects whose points the cache tells apart (the high byte of a surface id holds
/// the object's index + 1; 254 marks a point that shows an object beyond a mirror or
/// glass, 255 is the reserved ids', [`BACKGROUND`] and the holodeck's hits); a point on
/// any further object counts as one of the static scene's, and is never blended over an
/// object.
pub const MAX_OBJECTS: usize = 253;

/// What a cached point's sample saw, for the cache to move, drop or count it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleSurface {
    /// The static scene.
    Scene,
    /// Moving object `k` (its index), the point lying on it.
    Object(usize),
    /// A moving object beyond a mirror or glass (the point on the static surface that
    /// shows it): it is dropped when any object moves, and never counts.
    ObjectBeyond,
}

/// The surface id of a point: its material, and what it saw (see `OBJECT_SHIFT` in
/// `gpu/common.wgsl`), so that points on an object move with it and only ever stand
/// for it.
pub fn surface_id(material: u32, seen: SampleSurface) -> u32 {
    let object = match seen {
        SampleSurface::Object(k) if k < MAX_OBJECTS => k as u32 + 1,
        SampleSurface::ObjectBeyond => 254,
        _ => 0,
    };
    (object << 24) | (material & 0x00ff_ffff)
}

/// Wall-clock time of each step of [`RenderCache::draw`] (all eyes), measured by
/// submitting each step on its own and waiting for it (only with `timed`).
#[derive(Clone, Copy, Debug, Default)]
pub struct StepTimes {
    pub clear: Duration,
    pub projection: Duration,
    pub depth_cull: Duration,
    /// Interpolation and the priority image (one pass).
    pub interpolation_priority: Duration,
    /// The light field's lookup and blend (one pass; zero without a light field).
    pub vlf: Duration,
    pub dither: Duration,
    pub aging: Duration,
    /// Copying the chosen pixels back to the CPU.
    pub readback: Duration,
}

impl StepTimes {
    pub fn total(&self) -> Duration {
        self.clear
            + self.projection
            + self.depth_cull
            + self.interpolation_priority
            + self.vlf
            + self.dither
            + self.aging
            + self.readback
    }
}

/// The render cache of one render node: points shared by its eyes, images per eye.
pub struct RenderCache {
    gpu: Gpu,
    capacity: u32,
    ngroups: u32,
    cursor: u32,
    max_chosen: u32,
    batch: u32,
    frame: u32,
    /// Low bits of a pixel key holding the point index (enough for `capacity`, with the
    /// all-ones index left for "empty").
    index_bits: u32,
    points: wgpu::Buffer,
    samples: wgpu::Buffer,
    insert_params: wgpu::Buffer,
    age_bg: wgpu::BindGroup,
    eyes: Vec<EyeBuffers>,
    passes: Passes,
    vlf: Option<VlfBuffers>,
    /// Scratch for [`exactly`]: one flag per pixel of the largest eye, all false between
    /// frames.
    taken: Vec<bool>,
}

impl RenderCache {
    /// The cache a wall's node uses: `eyes` images of `size`, room for every pixel of every
    /// eye and a quarter more (points off screen survive a head turn), and up to twice the
    /// `samples` an eye asks for per frame chosen.
    pub fn for_wall(gpu: Gpu, size: Size, eyes: usize, samples: u32) -> RenderCache {
        let capacity = size.width * size.height * eyes as u32 * 5 / 4;
        RenderCache::new(gpu, &vec![size; eyes], capacity, samples.saturating_mul(2))
    }

    /// Samples an eye asks for per frame unless told: a sixteenth of its pixels.
    pub fn default_samples(size: Size) -> u32 {
        (size.width * size.height / 16).max(1)
    }

    /// A cache of `capacity` points (rounded up to whole groups) for eyes of the given
    /// sizes; at most `max_chosen` pixels are chosen per eye and frame.
    pub fn new(gpu: Gpu, eyes: &[Size], capacity: u32, max_chosen: u32) -> RenderCache {
        let ngroups = capacity.div_ceil(GROUP_SIZE).max(1);
        let capacity = ngroups * GROUP_SIZE;
        let max_chosen = max_chosen.max(1);
        // At most 2^24 points, so that at least 8 bits of a pixel key quantise the miss.
        let index_bits = (32 - capacity.leading_zeros()).max(1);
        assert!(
            index_bits <= 24,
            "a render cache holds at most 2^24 - 1 points ({capacity} asked for)"
        );
        let batch = max_chosen.min(ngroups);
        let empty = GpuPoint {
            pos: [0.0, 0.0, 0.0, 2.0e6],
            rad: [0.0; 4],
            origin: [0.0; 4],
            square: [0.0; 4],
        };
        let points = gpu.storage_init(
            "points",
            bytemuck::cast_slice(&vec![empty; capacity as usize]),
        );
        let visible = gpu.storage("visible", 4 * u64::from(capacity));
        let samples = gpu.storage(
            "samples",
            std::mem::size_of::<NewSample>() as u64 * u64::from(batch),
        );
        let matched = gpu.storage("matched", 4 * u64::from(batch));
        let insert_params = gpu.uniform("insert params", 32);

        let passes = Passes::new(&gpu);
        let shared = SharedBuffers {
            points: &points,
            visible: &visible,
            samples: &samples,
            matched: &matched,
            insert_params: &insert_params,
        };
        let eyes: Vec<EyeBuffers> = (eyes.iter())
            .map(|&size| EyeBuffers::new(&gpu, &passes, shared, size, max_chosen))
            .collect();
        let age_bg = passes
            .age
            .bind_group(&gpu, [&eyes[0].params, &points, &visible]);
        RenderCache {
            gpu,
            capacity,
            ngroups,
            cursor: 0,
            max_chosen,
            batch,
            frame: 0,
            index_bits,
            points,
            samples,
            insert_params,
            age_bg,
            eyes,
            passes,
            vlf: None,
            taken: Vec::new(),
        }
    }

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    pub fn eye_count(&self) -> usize {
        self.eyes.len()
    }

    pub fn eye_size(&self, eye: usize) -> Size {
        Size::new(self.eyes[eye].width, self.eyes[eye].height)
    }

    /// Draws every eye from the cache, chooses the pixels each eye should sample next
    /// (`targets[eye]` of them, at most `max_chosen` and the eye's pixel count), ages the
    /// points, and returns the chosen pixel indices per eye. With `timed`, adds each
    /// step's time to `times`.
    pub fn draw(
        &mut self,
        views: &[EyeView],
        targets: &[u32],
        timed: bool,
        times: &mut StepTimes,
    ) -> Vec<Vec<u32>> {
        assert_eq!(views.len(), self.eyes.len(), "one view per eye");
        self.frame = self.frame.wrapping_add(1);
        for (i, (e, v)) in self.eyes.iter().zip(views).enumerate() {
            let params = EyeParams {
                view_proj: v.view_proj.to_cols_array_2d(),
                eye: v.eye().extend(v.near).to_array(),
                width: e.width,
                height: e.height,
                npoints: self.capacity,
                target_samples: targets.get(i).copied().unwrap_or(0).min(self.max_chosen),
                max_chosen: self.max_chosen,
                frame: self.frame,
                eye_index: i as u32,
                index_bits: self.index_bits,
            };
            self.gpu
                .queue
                .write_buffer(&e.params, 0, bytemuck::bytes_of(&params));
        }
        let p = &self.passes;
        let mut r = Recorder::new(&self.gpu, timed);
        for (i, e) in self.eyes.iter().enumerate() {
            let n = e.width * e.height;
            p.project.clear(&mut r, &e.project_bg, n);
            r.step(&mut times.clear);
            p.project.project(&mut r, &e.project_bg, self.capacity);
            r.step(&mut times.projection);
            p.filter.cull(&mut r, &e.filter_bg, n);
            r.step(&mut times.depth_cull);
            p.filter.interpolate(&mut r, &e.filter_bg, n);
            r.step(&mut times.interpolation_priority);
            if let Some(v) = &self.vlf {
                p.vlf.blend(&mut r, &v.eyes[i].2, n);
                r.step(&mut times.vlf);
            }
            p.dither.dither(&mut r, &e.dither_bg, e.width, e.height);
            r.step(&mut times.dither);
        }
        p.age.age(&mut r, &self.age_bg, self.capacity);
        r.step(&mut times.aging);
        for e in &self.eyes {
            let enc = r.enc();
            enc.copy_buffer_to_buffer(&e.counters, 0, &e.staging, 0, 16);
            enc.copy_buffer_to_buffer(&e.chosen, 0, &e.staging, 16, 4 * u64::from(self.max_chosen));
        }
        r.submit();
        let (gpu, max_chosen, frame) = (&self.gpu, self.max_chosen, self.frame);
        let taken = &mut self.taken;
        let chosen: Vec<Vec<u32>> = self
            .eyes
            .iter_mut()
            .enumerate()
            .map(|(i, e)| {
                let bytes = gpu.map_read(&e.staging);
                let words: &[u32] = bytemuck::cast_slice(&bytes);
                // The dither appends in whatever order its tiles run: sorted, the choice
                // is the same on every run. A choice that overflowed the list lost pixels
                // that depend on that order: it is dropped, and `exactly` chooses instead.
                let mut chosen = match words {
                    [_, count, _, _, list @ ..] if *count <= max_chosen => {
                        let mut c = list[..*count as usize].to_vec();
                        c.sort_unstable();
                        c
                    }
                    [_, count, ..] => {
                        tracing::debug!(
                            "eye {i}: the dither chose {count} pixels, more than the {max_chosen} listed; choosing evenly instead"
                        );
                        Vec::new()
                    }
                    _ => {
                        // No read-back (a lost device): nothing chosen.
                        e.last_chosen.clear();
                        return Vec::new();
                    }
                };
                let target = targets.get(i).copied().unwrap_or(0).min(max_chosen);
                let seed = frame ^ ((i as u32) << 16);
                exactly(&mut chosen, target, e.width * e.height, taken, seed);
                e.last_chosen.clone_from(&chosen);
                chosen
            })
            .collect();
        r.step(&mut times.readback);
        chosen
    }

    /// Tells the cache that moving objects moved (the render cache paper's §4): the points
    /// on each moved object move with it and are resampled first, the points in its
    /// shadow where it was or is now, towards any of `lights`, are dropped. Takes effect
    /// for the next [`Self::draw`].
    pub fn move_objects(&mut self, moves: &[ObjectMove], lights: &[ShadowLight]) {
        if moves.is_empty() {
            return;
        }
        let mut r = Recorder::new(&self.gpu, false);
        self.passes
            .objects
            .apply(&mut r, &self.points, self.capacity, moves, lights);
        r.submit();
    }

    /// Adds samples that eye `eye` asked for (their pixels index its image).
    pub fn insert(&mut self, eye: usize, samples: &[NewSample]) {
        for chunk in samples.chunks(self.batch as usize) {
            let params = InsertParams {
                count: chunk.len() as u32,
                cursor: self.cursor,
                ngroups: self.ngroups,
                group_size: GROUP_SIZE,
                npoints: self.capacity,
                index_bits: self.index_bits,
                width: self.eyes[eye].width,
                height: self.eyes[eye].height,
            };
            self.cursor = (self.cursor + chunk.len() as u32) % self.ngroups;
            self.gpu
                .queue
                .write_buffer(&self.insert_params, 0, bytemuck::bytes_of(&params));
            self.gpu
                .queue
                .write_buffer(&self.samples, 0, bytemuck::cast_slice(chunk));
            let mut r = Recorder::new(&self.gpu, false);
            let e = &self.eyes[eye];
            let pixels = e.width * e.height;
            self.passes
                .insert
                .insert(&mut r, &e.insert_bg, chunk.len() as u32, pixels);
            r.submit();
        }
    }
}

/// The structs uploaded to the cache's shaders against their WGSL declarations, parsed
/// as the pipelines compile them (`common.wgsl` first).
#[cfg(test)]
mod layout_tests {
    use std::mem::{offset_of, size_of};

    use super::objects::MoveParams;
    use super::records::VlfParams;
    use super::{
        EyeParams, GpuPoint, InsertParams, NewSample, ObjectMove, ShadowLight, insert, objects,
        shade_field,
    };
    use crate::gpu::layout::{assert_same_layout, every_field};
    use crate::gpu::with_common;
    use holocave_vlf::Lookup;

    #[test]
    fn common_wgsl_point_and_eye_params_are_laid_out_as_in_rust() {
        let src = with_common(insert::SOURCE);
        every_field!(GpuPoint {
            pos,
            rad,
            origin,
            square
        });
        assert_same_layout(
            &src,
            "Point",
            size_of::<GpuPoint>(),
            &[
                ("pos", offset_of!(GpuPoint, pos)),
                ("rad", offset_of!(GpuPoint, rad)),
                ("origin", offset_of!(GpuPoint, origin)),
                ("square", offset_of!(GpuPoint, square)),
            ],
        );
        every_field!(EyeParams {
            view_proj,
            eye,
            width,
            height,
            npoints,
            target_samples,
            max_chosen,
            frame,
            eye_index,
            index_bits
        });
        assert_same_layout(
            &src,
            "EyeParams",
            size_of::<EyeParams>(),
            &[
                ("view_proj", offset_of!(EyeParams, view_proj)),
                ("eye", offset_of!(EyeParams, eye)),
                ("width", offset_of!(EyeParams, width)),
                ("height", offset_of!(EyeParams, height)),
                ("npoints", offset_of!(EyeParams, npoints)),
                ("target_samples", offset_of!(EyeParams, target_samples)),
                ("max_chosen", offset_of!(EyeParams, max_chosen)),
                ("frame", offset_of!(EyeParams, frame)),
                ("eye_index", offset_of!(EyeParams, eye_index)),
                ("index_bits", offset_of!(EyeParams, index_bits)),
            ],
        );
    }

    #[test]
    fn insert_wgsl_new_sample_and_insert_params_are_laid_out_as_in_rust() {
        let src = with_common(insert::SOURCE);
        every_field!(NewSample {
            pos,
            rad,
            origin,
            weight
        });
        assert_same_layout(
            &src,
            "NewSample",
            size_of::<NewSample>(),
            &[
                ("pos", offset_of!(NewSample, pos)),
                ("rad", offset_of!(NewSample, rad)),
                ("origin", offset_of!(NewSample, origin)),
                ("weight", offset_of!(NewSample, weight)),
            ],
        );
        every_field!(InsertParams {
            count,
            cursor,
            ngroups,
            group_size,
            npoints,
            index_bits,
            width,
            height
        });
        assert_same_layout(
            &src,
            "InsertParams",
            size_of::<InsertParams>(),
            &[
                ("count", offset_of!(InsertParams, count)),
                ("cursor", offset_of!(InsertParams, cursor)),
                ("ngroups", offset_of!(InsertParams, ngroups)),
                ("group_size", offset_of!(InsertParams, group_size)),
                ("npoints", offset_of!(InsertParams, npoints)),
                ("index_bits", offset_of!(InsertParams, index_bits)),
                ("width", offset_of!(InsertParams, width)),
                ("height", offset_of!(InsertParams, height)),
            ],
        );
    }

    #[test]
    fn vlf_wgsl_lookup_and_params_are_laid_out_as_in_rust() {
        let src = with_common(shade_field::SOURCE);
        // `holocave_vlf::Lookup`'s colour arrays are three scalars each in the WGSL.
        let (w, e) = (offset_of!(Lookup, weight), offset_of!(Lookup, emitted));
        assert_same_layout(
            &src,
            "Lookup",
            size_of::<Lookup>(),
            &[
                ("base", offset_of!(Lookup, base)),
                ("res", offset_of!(Lookup, res)),
                ("u", offset_of!(Lookup, u)),
                ("v", offset_of!(Lookup, v)),
                ("wr", w),
                ("wg", w + 4),
                ("wb", w + 8),
                ("er", e),
                ("eg", e + 4),
                ("eb", e + 8),
                ("tile", offset_of!(Lookup, tile)),
                ("bins", offset_of!(Lookup, bins)),
                ("x", offset_of!(Lookup, x)),
                ("y", offset_of!(Lookup, y)),
                ("samples", offset_of!(Lookup, samples)),
                ("object", offset_of!(Lookup, object)),
            ],
        );
        every_field!(VlfParams {
            width,
            height,
            index_bits,
            prior,
            chunk,
            spread,
            _pad
        });
        assert_same_layout(
            &src,
            "VlfParams",
            size_of::<VlfParams>(),
            &[
                ("width", offset_of!(VlfParams, width)),
                ("height", offset_of!(VlfParams, height)),
                ("index_bits", offset_of!(VlfParams, index_bits)),
                ("prior", offset_of!(VlfParams, prior)),
                ("chunk", offset_of!(VlfParams, chunk)),
                ("spread", offset_of!(VlfParams, spread)),
                ("pad1", offset_of!(VlfParams, _pad)),
                ("pad2", offset_of!(VlfParams, _pad) + 4),
            ],
        );
    }

    #[test]
    fn objects_wgsl_move_light_and_params_are_laid_out_as_in_rust() {
        let src = with_common(objects::SOURCE);
        every_field!(ObjectMove {
            delta,
            before,
            after,
            object,
            pad
        });
        assert_same_layout(
            &src,
            "Move",
            size_of::<ObjectMove>(),
            &[
                ("delta", offset_of!(ObjectMove, delta)),
                ("before", offset_of!(ObjectMove, before)),
                ("after", offset_of!(ObjectMove, after)),
                ("object", offset_of!(ObjectMove, object)),
                ("pad0", offset_of!(ObjectMove, pad)),
                ("pad1", offset_of!(ObjectMove, pad) + 4),
                ("pad2", offset_of!(ObjectMove, pad) + 8),
            ],
        );
        every_field!(ShadowLight { at, spread });
        assert_same_layout(
            &src,
            "ShadowLight",
            size_of::<ShadowLight>(),
            &[
                ("at", offset_of!(ShadowLight, at)),
                ("spread", offset_of!(ShadowLight, spread)),
            ],
        );
        every_field!(MoveParams {
            npoints,
            nmoves,
            nlights,
            pad
        });
        assert_same_layout(
            &src,
            "MoveParams",
            size_of::<MoveParams>(),
            &[
                ("npoints", offset_of!(MoveParams, npoints)),
                ("nmoves", offset_of!(MoveParams, nmoves)),
                ("nlights", offset_of!(MoveParams, nlights)),
                ("pad", offset_of!(MoveParams, pad)),
            ],
        );
    }
}
