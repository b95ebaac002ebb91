//! The pipeline of `screen.wgsl`: the eyes' images laid out, tone-mapped and drawn into
//! a window's surface texture.

use bytemuck::{Pod, Zeroable};
use holocave_cave::{Layout, Size, WindowSettings};

use crate::gpu::{Gpu, with_common};
use crate::present::falsecolor::{FalseColor, Legend};
use crate::present::tonemap::{TONE_BINS, ToneCurve};

/// The shader (compiled after `common.wgsl`, as the compute passes are).
pub(crate) const SOURCE: &str = include_str!("screen.wgsl");

/// `ScreenParams` in `screen.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ScreenParams {
    window: [u32; 2],
    eye_size: [u32; 2],
    arrangement: u32,
    first: u32,
    second: u32,
    flags: u32,
    linear: u32,
    log_min: f32,
    log_max: f32,
    log_scale: f32,
    cdf: [[f32; 4]; 26],
    efficacy: f32,
    fc_log_min: f32,
    fc_decades: f32,
    legend_w: u32,
    legend_h: u32,
    pad: [u32; 3],
}

const FLIP_X: u32 = 1;
const FLIP_Y: u32 = 2;
const ENCODE_SRGB: u32 = 4;
const HAS_MAPPING: u32 = 8;
const FALSE_COLOR: u32 = 16;

/// The render pipeline for one surface format.
pub struct ScreenPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    /// The surface stores sRGB codes itself (an `*Srgb` format): the shader writes
    /// linear values.
    srgb_target: bool,
    /// The false-colour legend's pixels on the GPU, for the eye size and scale it was made
    /// for.
    legend: wgpu::Buffer,
    legend_for: Option<(Size, FalseColor)>,
    legend_size: Size,
}

/// A legend's pixels as the shader reads them: `0x00BBGGRR` per pixel.
fn legend_words(l: &Legend) -> Vec<u32> {
    l.pixels
        .iter()
        .map(|p| u32::from(p[0]) | u32::from(p[1]) << 8 | u32::from(p[2]) << 16)
        .collect()
}

impl ScreenPass {
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> ScreenPass {
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("tonemap"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    storage(1),
                    storage(2),
                    storage(3),
                ],
            });
        let module = gpu
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("tonemap"),
                source: wgpu::ShaderSource::Wgsl(with_common(SOURCE).into()),
            });
        let pl = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("tonemap"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let pipeline = gpu
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("tonemap"),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
        let uniform = gpu.uniform("screen", std::mem::size_of::<ScreenParams>() as u64);
        ScreenPass {
            pipeline,
            layout,
            uniform,
            srgb_target: format.is_srgb(),
            legend: gpu.storage("false-colour legend", 16),
            legend_for: None,
            legend_size: Size::new(0, 0),
        }
    }

    /// Records drawing `eyes` (the colour buffers of the layout's first and second eye, each
    /// `eye_size` pixels) into `target` (`window` pixels) as `settings` lay them out, under
    /// `curve` (`None`: black).
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        window: Size,
        settings: &WindowSettings,
        eyes: [&wgpu::Buffer; 2],
        eye_size: Size,
        curve: Option<&ToneCurve>,
    ) {
        let mut screen = ScreenParams::laid_out(window, settings, eye_size, self.srgb_target);
        if let Some(fc) = curve.and_then(|c| c.false_color) {
            screen.flags |= FALSE_COLOR;
            screen.fc_log_min = fc.log_min;
            screen.fc_decades = fc.decades;
            self.update_legend(gpu, eye_size, fc);
            (screen.legend_w, screen.legend_h) = (self.legend_size.width, self.legend_size.height);
        }
        if let Some(c) = curve {
            screen.map_with(c);
        }
        gpu.queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&screen));
        let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: eyes[0].as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: eyes[1].as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: self.legend.as_entire_binding(),
                },
            ],
        });
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("tonemap"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.draw(0..3, 0..1);
    }

    /// The false-colour legend for `eye_size` and `fc`, made again only when either changed.
    fn update_legend(&mut self, gpu: &Gpu, eye_size: Size, fc: FalseColor) {
        if self.legend_for == Some((eye_size, fc)) {
            return;
        }
        let legend = Legend::new(&fc, eye_size.width, eye_size.height);
        self.legend_size = legend
            .as_ref()
            .map_or(Size::new(0, 0), |l| Size::new(l.width, l.height));
        if let Some(l) = legend {
            self.legend = gpu.storage_init(
                "false-colour legend",
                bytemuck::cast_slice(&legend_words(&l)),
            );
        }
        self.legend_for = Some((eye_size, fc));
    }
}

impl ScreenParams {
    /// The uniform for drawing eyes of `eye_size` into a `window` as `settings` lay them
    /// out (into an sRGB target or not), with no tone curve yet: black.
    fn laid_out(
        window: Size,
        settings: &WindowSettings,
        eye_size: Size,
        srgb_target: bool,
    ) -> ScreenParams {
        let mut flags = 0;
        if settings.flip_x {
            flags |= FLIP_X;
        }
        if settings.flip_y {
            flags |= FLIP_Y;
        }
        if !srgb_target {
            flags |= ENCODE_SRGB;
        }
        ScreenParams {
            window: [window.width, window.height],
            eye_size: [eye_size.width, eye_size.height],
            arrangement: match settings.layout {
                Layout::Mono | Layout::Left | Layout::Right => 0,
                Layout::SideBySide => 1,
                Layout::TopBottom => 2,
                Layout::Anaglyph => 3,
            },
            first: 0,
            second: 1,
            flags,
            linear: 0,
            log_min: 0.0,
            log_max: 1.0,
            log_scale: 0.0,
            cdf: [[0.0; 4]; 26],
            efficacy: 179.0,
            fc_log_min: 0.0,
            fc_decades: 1.0,
            legend_w: 0,
            legend_h: 0,
            pad: [0; 3],
        }
    }

    /// The tone curve `c` in the uniform.
    fn map_with(&mut self, c: &ToneCurve) {
        self.efficacy = c.efficacy;
        self.flags |= HAS_MAPPING;
        self.linear = u32::from(c.linear);
        self.log_min = c.log_min;
        self.log_max = c.log_max;
        self.log_scale = c.log_scale;
        for (i, v) in c.cdf.iter().enumerate().take(TONE_BINS + 1) {
            self.cdf[i / 4][i % 4] = *v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::present::tonemap::{ToneMapper, ToneMode};
    use glam::Vec3;
    use holocave_tracer::film::Image;

    #[test]
    fn screen_wgsl_params_are_laid_out_as_in_rust() {
        use std::mem::{offset_of, size_of};
        crate::gpu::layout::every_field!(ScreenParams {
            window,
            eye_size,
            arrangement,
            first,
            second,
            flags,
            linear,
            log_min,
            log_max,
            log_scale,
            cdf,
            efficacy,
            fc_log_min,
            fc_decades,
            legend_w,
            legend_h,
            pad
        });
        crate::gpu::layout::assert_same_layout(
            &with_common(SOURCE),
            "ScreenParams",
            size_of::<ScreenParams>(),
            &[
                ("window", offset_of!(ScreenParams, window)),
                ("eye_size", offset_of!(ScreenParams, eye_size)),
                ("arrangement", offset_of!(ScreenParams, arrangement)),
                ("first", offset_of!(ScreenParams, first)),
                ("second", offset_of!(ScreenParams, second)),
                ("flags", offset_of!(ScreenParams, flags)),
                ("linear", offset_of!(ScreenParams, linear)),
                ("log_min", offset_of!(ScreenParams, log_min)),
                ("log_max", offset_of!(ScreenParams, log_max)),
                ("log_scale", offset_of!(ScreenParams, log_scale)),
                ("cdf", offset_of!(ScreenParams, cdf)),
                ("efficacy", offset_of!(ScreenParams, efficacy)),
                ("fc_log_min", offset_of!(ScreenParams, fc_log_min)),
                ("fc_decades", offset_of!(ScreenParams, fc_decades)),
                ("legend_w", offset_of!(ScreenParams, legend_w)),
                ("legend_h", offset_of!(ScreenParams, legend_h)),
                ("_pad0", offset_of!(ScreenParams, pad)),
                ("_pad1", offset_of!(ScreenParams, pad) + 4),
                ("_pad2", offset_of!(ScreenParams, pad) + 8),
            ],
        );
    }

    const W: u32 = 24;
    const H: u32 = 16;

    /// A wide-range image (1e-2 to 1e4 cd/m², coloured, some black pixels) — wide enough
    /// that camera mode uses the histogram curve, not the linear one.
    fn eye_image(seed: u32) -> Image {
        let mut img = Image::new(W, H);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let i = i as u32;
            let t = ((i * 37 + seed * 11) % 97) as f32 / 96.0;
            let l = 10f32.powf(-2.0 + 6.0 * t) / 179.0;
            let hue = (i + seed) % 3;
            let c = match hue {
                0 => Vec3::new(1.0, 0.6, 0.3),
                1 => Vec3::new(0.3, 1.0, 0.5),
                _ => Vec3::new(0.4, 0.5, 1.2),
            };
            *p = if (i + seed).is_multiple_of(13) {
                Vec3::ZERO
            } else {
                c * l
            };
        }
        img
    }

    fn upload(gpu: &Gpu, img: &Image) -> wgpu::Buffer {
        let data: Vec<[f32; 4]> = img.pixels.iter().map(|p| [p.x, p.y, p.z, 1.0]).collect();
        gpu.storage_init("eye", bytemuck::cast_slice(&data))
    }

    /// Draws into an offscreen `format` texture of `size` and reads it back as RGB.
    fn draw(
        gpu: &Gpu,
        format: wgpu::TextureFormat,
        size: Size,
        settings: &WindowSettings,
        eyes: [&wgpu::Buffer; 2],
        curve: Option<&ToneCurve>,
    ) -> image::RgbImage {
        draw_eyes(gpu, format, size, settings, eyes, Size::new(W, H), curve)
    }

    /// [`draw`] of eyes of `eye_size` pixels.
    fn draw_eyes(
        gpu: &Gpu,
        format: wgpu::TextureFormat,
        size: Size,
        settings: &WindowSettings,
        eyes: [&wgpu::Buffer; 2],
        eye_size: Size,
        curve: Option<&ToneCurve>,
    ) -> image::RgbImage {
        let mut pass = ScreenPass::new(gpu, format);
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen"),
            size: wgpu::Extent3d {
                width: size.width,
                height: size.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let row = (size.width * 4).div_ceil(256) * 256;
        let staging = gpu.read_back_buffer("offscreen read-back", u64::from(row * size.height));
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        pass.draw(gpu, &mut enc, &view, size, settings, eyes, eye_size, curve);
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d {
                width: size.width,
                height: size.height,
                depth_or_array_layers: 1,
            },
        );
        gpu.queue.submit([enc.finish()]);
        let bytes = gpu.map_read(&staging);
        image::RgbImage::from_fn(size.width, size.height, |x, y| {
            let o = (y * row + x * 4) as usize;
            image::Rgb([bytes[o], bytes[o + 1], bytes[o + 2]])
        })
    }

    fn max_diff(a: &image::RgbImage, b: &image::RgbImage) -> u8 {
        assert_eq!(a.dimensions(), b.dimensions());
        a.pixels()
            .zip(b.pixels())
            .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c])))
            .max()
            .unwrap()
    }

    /// The CPU's picture of a layout: `ToneMapper::apply` of each eye, laid out, flipped.
    fn cpu_layout(
        settings: &WindowSettings,
        size: Size,
        l: &image::RgbImage,
        r: &image::RgbImage,
    ) -> image::RgbImage {
        let (a, b) = if settings.swap_eyes { (r, l) } else { (l, r) };
        image::RgbImage::from_fn(size.width, size.height, |x, y| {
            let x = if settings.flip_x {
                size.width - 1 - x
            } else {
                x
            };
            let y = if settings.flip_y {
                size.height - 1 - y
            } else {
                y
            };
            match settings.layout {
                Layout::SideBySide if x < W => *a.get_pixel(x, y),
                Layout::SideBySide => *b.get_pixel(x - W, y),
                Layout::TopBottom if y < H => *a.get_pixel(x, y),
                Layout::TopBottom => *b.get_pixel(x, y - H),
                Layout::Anaglyph => {
                    let (p, q) = (a.get_pixel(x, y), b.get_pixel(x, y));
                    image::Rgb([p[0], q[1], q[2]])
                }
                // One eye: the left, whatever `swap_eyes` says.
                _ => *l.get_pixel(x, y),
            }
        })
    }

    #[test]
    fn the_shader_draws_what_the_cpu_tone_mapper_and_layout_give() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        let (left, right) = (eye_image(0), eye_image(5));
        let mut tone = ToneMapper::new(ToneMode::Camera);
        assert!(tone.update(&left, true));
        let curve = tone.curve().unwrap();
        assert!(
            !curve.linear,
            "the test image should need the histogram curve"
        );
        let (l8, r8) = (tone.apply(&left), tone.apply(&right));
        let (lb, rb) = (upload(&gpu, &left), upload(&gpu, &right));
        let mut cases = Vec::new();
        for layout in [
            Layout::Left,
            Layout::SideBySide,
            Layout::TopBottom,
            Layout::Anaglyph,
        ] {
            let mut s = WindowSettings::with_layout(layout);
            cases.push(s.clone());
            s.swap_eyes = true;
            s.flip_x = true;
            cases.push(s.clone());
            s.flip_x = false;
            s.flip_y = true;
            cases.push(s);
        }
        for s in &cases {
            let size = s.window_size(Size::new(W, H));
            let want = cpu_layout(s, size, &l8, &r8);
            for format in [
                wgpu::TextureFormat::Rgba8Unorm,
                wgpu::TextureFormat::Rgba8UnormSrgb,
            ] {
                // The buffers in the order `present::layout_eyes` gives them.
                let eyes = match (s.layout, s.swap_eyes) {
                    (Layout::Left, _) => [&lb, &lb],
                    (_, false) => [&lb, &rb],
                    (_, true) => [&rb, &lb],
                };
                let got = draw(&gpu, format, size, s, eyes, Some(&curve));
                let d = max_diff(&got, &want);
                assert!(d <= 1, "{s:?} into {format:?}: {d} 8-bit steps off");
            }
        }
        // Linear curve too (a narrow-range image), and no mapping (black).
        let mut narrow = left.clone();
        for (i, p) in narrow.pixels.iter_mut().enumerate() {
            *p = Vec3::new(1.0, 0.8, 0.6) * (50.0 + (i % 50) as f32) / 179.0;
        }
        let mut tone = ToneMapper::new(ToneMode::Camera);
        assert!(tone.update(&narrow, true));
        let curve = tone.curve().unwrap();
        assert!(curve.linear);
        let nb = upload(&gpu, &narrow);
        let s = WindowSettings::with_layout(Layout::Left);
        let got = draw(
            &gpu,
            wgpu::TextureFormat::Rgba8Unorm,
            Size::new(W, H),
            &s,
            [&nb, &nb],
            Some(&curve),
        );
        assert!(max_diff(&got, &tone.apply(&narrow)) <= 1);
        let black = draw(
            &gpu,
            wgpu::TextureFormat::Rgba8Unorm,
            Size::new(W, H),
            &s,
            [&nb, &nb],
            None,
        );
        assert!(black.pixels().all(|p| p.0 == [0, 0, 0]));
    }

    #[test]
    fn a_window_of_another_size_scales_each_eye_by_nearest_pixel() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        let left = eye_image(2);
        let mut tone = ToneMapper::new(ToneMode::Camera);
        tone.update(&left, true);
        let l8 = tone.apply(&left);
        let lb = upload(&gpu, &left);
        let mut s = WindowSettings::with_layout(Layout::Left);
        s.size = Some(Size::new(W * 3, H * 2));
        let got = draw(
            &gpu,
            wgpu::TextureFormat::Rgba8Unorm,
            Size::new(W * 3, H * 2),
            &s,
            [&lb, &lb],
            tone.curve().as_ref(),
        );
        let want = image::RgbImage::from_fn(W * 3, H * 2, |x, y| *l8.get_pixel(x / 3, y / 2));
        assert!(max_diff(&got, &want) <= 1);
    }

    #[test]
    fn false_colour_and_its_legend_are_drawn_as_the_cpu_draws_them() {
        let gpu = Gpu::new().expect("a GPU adapter (lavapipe without a GPU)");
        // Big enough for a legend (64 pixels high); luminances over and beyond the scale.
        let (w, h) = (96u32, 72u32);
        let mut img = Image::new(w, h);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            let t = ((i * 37) % 101) as f32 / 100.0;
            *p = Vec3::new(1.0, 0.7, 0.4) * 10f32.powf(-4.0 + 10.0 * t) / 179.0;
            if i % 29 == 0 {
                *p = Vec3::ZERO;
            }
        }
        let tone = ToneMapper::with_efficacy(ToneMode::FalseColor, 179.0);
        let want = tone.apply(&img);
        let buf = upload(&gpu, &img);
        let s = WindowSettings::with_layout(Layout::Left);
        for format in [
            wgpu::TextureFormat::Rgba8Unorm,
            wgpu::TextureFormat::Rgba8UnormSrgb,
        ] {
            let got = draw_eyes(
                &gpu,
                format,
                Size::new(w, h),
                &s,
                [&buf, &buf],
                Size::new(w, h),
                tone.curve().as_ref(),
            );
            let d = max_diff(&got, &want);
            assert!(d <= 1, "{format:?}: {d} 8-bit steps off");
        }
        // The legend is there: the top-left corner is black background, the bar's top red.
        assert_eq!(want.get_pixel(0, 0).0, [0, 0, 0]);
        let red = want.get_pixel(4, 11).0;
        assert!(red[0] > 200 && red[2] < 20, "{red:?}");
    }
}
