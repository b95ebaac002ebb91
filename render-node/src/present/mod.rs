//! Presenting a wall in a window, split for swap lock: [`Presenter::prepare`] acquires the
//! surface texture, draws the eyes into it (layout and tone mapping on the GPU,
//! `present/screen.wgsl`), submits and waits for the GPU — all before the node says
//! Ready; [`Presenter::show`] presents it when the master's Swap comes;
//! [`Presenter::abandon`] drops it when a newer frame state comes first.
//!
//! A lost or outdated surface is reconfigured and that frame skipped; a timeout or an
//! occluded window skips the frame; a resize (the window's size, as the event loop last
//! saw it) reconfigures the surface before the next frame. None of these is an error.
//!
//! Beside it, everything else between a drawn frame and what a person sees of it:
//! - [`tonemap`]: Ward Larson's histogram adjustment (camera and human modes) and false
//!   colour, at display; [`falsecolor`]: luminance on a logarithmic scale with a legend;
//! - [`vision`]: what a person would see (veiling glare, acuity, colour loss), for the
//!   human mode, on the CPU and the GPU;
//! - [`window`]: the node's windows (winit) and their GPU device; [`wall_windows`]: a
//!   wall's windows frame by frame (tone curve, prepare before Ready, show on Swap, the
//!   present log) and the skew between walls read from those logs;
//! - [`output`]: a headless node's files (frame images, `presented.log`) and their reader;
//!   [`mosaic`]: the unfolded CAVE as one picture.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use holocave_cave::{Eye, PresentMode, Size, WindowSettings};

use crate::gpu::Gpu;
use crate::present::tonemap::ToneCurve;

pub mod falsecolor;
mod luminance;
pub mod mosaic;
pub mod output;
mod screen;
pub mod tonemap;
pub mod vision;
pub mod wall_windows;
pub mod window;

pub use luminance::Histogrammer;

use screen::ScreenPass;

/// A window's size as the event loop last saw it (width in the high half), shared with
/// the thread that draws.
#[derive(Clone, Debug, Default)]
pub struct SharedSize(Arc<AtomicU64>);

impl SharedSize {
    pub fn new(size: Size) -> SharedSize {
        let s = SharedSize::default();
        s.set(size);
        s
    }

    pub fn set(&self, size: Size) {
        let word = (u64::from(size.width) << 32) | u64::from(size.height);
        self.0.store(word, Ordering::Release);
    }

    pub fn get(&self) -> Size {
        let v = self.0.load(Ordering::Acquire);
        Size::new((v >> 32) as u32, v as u32)
    }
}

/// What [`Presenter::prepare`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prepared {
    /// A frame is drawn and waits for [`Presenter::show`].
    Ready,
    /// No frame this time (the reason is logged); the next prepare tries again.
    Skipped(Skip),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// The window has no area (minimised).
    Empty,
    Timeout,
    Occluded,
    /// The surface was outdated or lost and has been reconfigured.
    Reconfigured,
    Validation,
}

/// Time spent presenting, summed over frames.
#[derive(Clone, Copy, Debug, Default)]
pub struct PresentTimes {
    /// Frames drawn into the surface.
    pub prepared: u64,
    /// Frames presented.
    pub shown: u64,
    pub skipped: u64,
    pub abandoned: u64,
    /// Acquiring the surface texture.
    pub acquire: Duration,
    /// Recording, submitting and waiting for the draw into the surface.
    pub draw: Duration,
    /// The present call.
    pub present: Duration,
}

/// One window's surface and the pass that draws a wall into it.
pub struct Presenter {
    gpu: Gpu,
    /// The window's surface (`remake` holds the window, so it outlives the surface).
    surface: wgpu::Surface<'static>,
    remake: SurfaceMaker,
    config: wgpu::SurfaceConfiguration,
    pass: ScreenPass,
    pub settings: WindowSettings,
    size: SharedSize,
    pending: Option<wgpu::SurfaceTexture>,
    /// Reconfigure before the next acquire (suboptimal texture).
    stale: bool,
    /// The window size the surface was last configured for.
    requested: Size,
    pub times: PresentTimes,
}

impl std::fmt::Debug for Presenter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Presenter")
            .field("settings", &self.settings)
            .field("size", &(self.config.width, self.config.height))
            .finish_non_exhaustive()
    }
}

/// Gives the window again, to make a new surface when the old one is lost.
pub type SurfaceMaker = Box<dyn Fn() -> wgpu::SurfaceTarget<'static> + Send + Sync>;

impl Presenter {
    /// A presenter on `surface` (made by `gpu`'s instance) of a window whose size
    /// `size` tracks; `remake` gives its window again when the surface is lost.
    pub fn new(
        gpu: &Gpu,
        surface: wgpu::Surface<'static>,
        remake: SurfaceMaker,
        settings: WindowSettings,
        size: SharedSize,
    ) -> Result<Presenter, String> {
        let caps = surface.get_capabilities(&gpu.raw_adapter);
        // A plain 8-bit format (the shader encodes sRGB as the CPU tone mapper does);
        // an sRGB one if that is all there is (the hardware encodes).
        let format = [
            wgpu::TextureFormat::Bgra8Unorm,
            wgpu::TextureFormat::Rgba8Unorm,
        ]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .or_else(|| caps.formats.first().copied())
        .ok_or("the GPU cannot present to this window (no surface formats)")?;
        let wanted = match settings.present_mode {
            PresentMode::Fifo => wgpu::PresentMode::Fifo,
            PresentMode::Mailbox => wgpu::PresentMode::Mailbox,
            PresentMode::Immediate => wgpu::PresentMode::Immediate,
        };
        let present_mode = if caps.present_modes.contains(&wanted) {
            wanted
        } else {
            tracing::warn!(
                "present mode {} is not offered by this surface ({:?}); using fifo",
                settings.present_mode.name(),
                caps.present_modes
            );
            wgpu::PresentMode::Fifo
        };
        let requested = size.get();
        let fitted = fit(
            gpu,
            Size::new(requested.width.max(1), requested.height.max(1)),
        );
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: Default::default(),
            width: fitted.width,
            height: fitted.height,
            present_mode,
            // One frame in flight: the swap-locked frame is the one shown next.
            desired_maximum_frame_latency: 1,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&gpu.device, &config);
        tracing::info!(
            "window surface {fitted}, {format:?}, {present_mode:?}, layout {}",
            settings.layout.name()
        );
        Ok(Presenter {
            gpu: gpu.clone(),
            surface,
            remake,
            pass: ScreenPass::new(gpu, format),
            config,
            settings,
            size,
            pending: None,
            stale: false,
            requested,
            times: PresentTimes::default(),
        })
    }

    /// The surface's size now.
    pub fn surface_size(&self) -> Size {
        Size::new(self.config.width, self.config.height)
    }

    fn reconfigure(&mut self) {
        let requested = self.size.get();
        if requested.area() > 0 {
            let fitted = fit(&self.gpu, requested);
            (self.config.width, self.config.height) = (fitted.width, fitted.height);
            self.requested = requested;
        }
        self.surface.configure(&self.gpu.device, &self.config);
        self.stale = false;
    }

    /// Makes the surface anew for the same window (after [`wgpu::CurrentSurfaceTexture::Lost`]).
    fn recreate(&mut self) {
        match self.gpu.instance.create_surface((self.remake)()) {
            Ok(s) => self.surface = s,
            Err(e) => tracing::error!("recreating the lost surface: {e}"),
        }
        self.reconfigure();
    }

    /// Draws `eyes` (the images, `eye_size` pixels each, of the layout's first and second
    /// eye, see [`layout_eyes`]: the cache's colour buffers, or those images as seen in
    /// human mode) into the next surface texture under `curve`, submits and waits for the
    /// GPU. A frame prepared before and not shown is abandoned first.
    pub fn prepare(
        &mut self,
        eyes: [&wgpu::Buffer; 2],
        eye_size: Size,
        curve: Option<&ToneCurve>,
    ) -> Prepared {
        self.abandon();
        let size = self.size.get();
        if size.area() == 0 {
            self.times.skipped += 1;
            return Prepared::Skipped(Skip::Empty);
        }
        if self.stale || size != self.requested {
            self.reconfigure();
        }
        let t = Instant::now();
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) => t,
            wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
                self.stale = true;
                t
            }
            other => {
                self.times.skipped += 1;
                self.times.acquire += t.elapsed();
                let skip = match other {
                    wgpu::CurrentSurfaceTexture::Timeout => Skip::Timeout,
                    wgpu::CurrentSurfaceTexture::Occluded => Skip::Occluded,
                    wgpu::CurrentSurfaceTexture::Outdated => {
                        self.reconfigure();
                        Skip::Reconfigured
                    }
                    wgpu::CurrentSurfaceTexture::Lost => {
                        self.recreate();
                        Skip::Reconfigured
                    }
                    _ => Skip::Validation,
                };
                tracing::debug!("surface: {skip:?}; frame skipped");
                return Prepared::Skipped(skip);
            }
        };
        self.times.acquire += t.elapsed();
        let t = Instant::now();
        let view = texture.texture.create_view(&Default::default());
        let mut enc = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("present"),
            });
        self.pass.draw(
            &self.gpu,
            &mut enc,
            &view,
            self.surface_size(),
            &self.settings,
            eyes,
            eye_size,
            curve,
        );
        self.gpu.queue.submit([enc.finish()]);
        self.gpu.wait();
        self.times.draw += t.elapsed();
        self.times.prepared += 1;
        self.pending = Some(texture);
        Prepared::Ready
    }

    /// Presents the prepared frame (nothing if none is prepared). True when presented.
    pub fn show(&mut self) -> bool {
        let Some(texture) = self.pending.take() else {
            return false;
        };
        let t = Instant::now();
        self.gpu.queue.present(texture);
        self.times.present += t.elapsed();
        self.times.shown += 1;
        true
    }

    /// Drops the prepared frame without showing it.
    pub fn abandon(&mut self) {
        if self.pending.take().is_some() {
            self.times.abandoned += 1;
        }
    }
}

/// A window size the device can present: larger sides are clamped to its largest texture
/// (the picture then covers part of the window; configuring larger would be an error).
fn fit(gpu: &Gpu, size: Size) -> Size {
    let max = gpu.device.limits().max_texture_dimension_2d;
    let fitted = Size::new(size.width.min(max), size.height.min(max));
    if fitted != size {
        tracing::warn!(
            "a {size} window is larger than this GPU's {max}-pixel textures; drawing {fitted}"
        );
    }
    fitted
}

/// The cache's eye indices of the layout's first and second eye (the same twice for a
/// one-eye layout; swapped with `swap_eyes`); an error naming the missing eye when the
/// wall does not draw it.
pub fn layout_eyes(settings: &WindowSettings, drawn: &[Eye]) -> Result<[usize; 2], String> {
    let index = |e: &Eye| {
        drawn.iter().position(|d| d == e).ok_or_else(|| {
            format!(
                "layout {} shows the {e:?} eye, which this wall does not draw (it draws {drawn:?})",
                settings.layout.name()
            )
        })
    };
    let wanted = settings.layout.eyes();
    let first = index(&wanted[0])?;
    let second = match wanted.get(1) {
        Some(e) => index(e)?,
        None => first,
    };
    Ok(if settings.swap_eyes {
        [second, first]
    } else {
        [first, second]
    })
}
