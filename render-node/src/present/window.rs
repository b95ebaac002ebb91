//! A render node's windows (winit 0.30, X11): opened from a wall's window settings — monitor
//! by index or name, position and size in pixels, fullscreen borderless or exclusive,
//! cursor hidden — with one wgpu device whose adapter can present to all of them.
//!
//! winit runs its event loop on the main thread only, so [`run`] runs it on the calling
//! thread and the node's frame loop on a thread of its own (scoped: it may borrow). Esc
//! or closing a window sets a flag the frame loop reads ([`Screens::closed`]); a resize
//! reaches the window's [`Presenter`] through its [`SharedSize`]; the navigating keys and
//! the mouse go to [`Screens::desk`] ([`crate::node::desk`]). The event loop ends when the frame
//! loop returns.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{Scope, ScopedJoinHandle};

use holocave_cave::{Fullscreen, Monitor, Size, WindowSettings};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop, EventLoopProxy};
use winit::keyboard::{Key, NamedKey, PhysicalKey};
use winit::monitor::MonitorHandle;
use winit::window::{Window, WindowId};

use crate::node::desk::{DeskFeed, DeskKeys, control_of};
use crate::present::{Presenter, SharedSize};
use crate::{Gpu, RenderNodeError};

/// One window to open.
#[derive(Clone, Debug)]
pub struct WindowSpec {
    /// The title (`holocave <wall>`; screenshots find the window by it).
    pub title: String,
    pub settings: WindowSettings,
    /// Its size in pixels (the settings' size, or what the layout needs).
    pub size: Size,
}

#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    #[error("cannot open windows: {0} (is DISPLAY set to a running X server?)")]
    EventLoop(String),
    #[error("{0}")]
    Monitor(String),
    #[error("creating the window {title:?}: {message}")]
    Create { title: String, message: String },
    #[error("{0}")]
    Surface(String),
    #[error(transparent)]
    Gpu(#[from] RenderNodeError),
    #[error("the frame loop panicked")]
    Panicked,
    #[error("{0}")]
    Layout(String),
    #[error("opening the present log {path}: {message}")]
    PresentLog { path: String, message: String },
}

/// The windows as the frame loop sees them: the device, one presenter per window (in the
/// order given), and whether the user asked to stop.
pub struct Screens {
    pub gpu: Gpu,
    pub presenters: Vec<Presenter>,
    closed: Arc<AtomicBool>,
    /// The desk user's keys and mouse in these windows (sent to the master).
    pub desk: DeskFeed,
}

impl Screens {
    /// True once Esc was pressed in a window or a window was closed.
    pub fn closed(&self) -> bool {
        self.closed.load(Ordering::Acquire)
    }

    /// The flag behind [`Screens::closed`], for closures.
    pub fn closed_flag(&self) -> Arc<AtomicBool> {
        self.closed.clone()
    }
}

enum UserEvent {
    /// The frame loop has returned.
    Done,
}

/// Sends [`UserEvent::Done`] when dropped, also when the frame loop panics.
struct DoneOnDrop(EventLoopProxy<UserEvent>);

impl Drop for DoneOnDrop {
    fn drop(&mut self) {
        let _ = self.0.send_event(UserEvent::Done);
    }
}

struct App<'scope, 'env, F, T> {
    scope: &'scope Scope<'scope, 'env>,
    specs: &'env [WindowSpec],
    body: Option<F>,
    proxy: EventLoopProxy<UserEvent>,
    handle: Option<ScopedJoinHandle<'scope, T>>,
    sizes: Vec<(WindowId, SharedSize)>,
    closed: Arc<AtomicBool>,
    error: Option<WindowError>,
    desk: DeskFeed,
    /// The window a mouse drag started in (the cursor is followed there only).
    drag_window: Option<WindowId>,
}

/// Opens `specs`' windows, then runs `body` with them on a thread of its own while this
/// thread (which must be the process's main thread) runs the event loop; returns what
/// `body` returned.
pub fn run<T, F>(specs: &[WindowSpec], body: F) -> Result<T, WindowError>
where
    T: Send,
    F: FnOnce(Screens) -> T + Send,
{
    let event_loop = EventLoop::<UserEvent>::with_user_event()
        .build()
        .map_err(|e| WindowError::EventLoop(e.to_string()))?;
    let proxy = event_loop.create_proxy();
    std::thread::scope(|scope| {
        let mut app = App {
            scope,
            specs,
            body: Some(body),
            proxy,
            handle: None,
            sizes: Vec::new(),
            closed: Arc::new(AtomicBool::new(false)),
            error: None,
            desk: DeskFeed::default(),
            drag_window: None,
        };
        let ran = event_loop.run_app(&mut app);
        if let Some(e) = app.error.take() {
            return Err(e);
        }
        ran.map_err(|e| WindowError::EventLoop(e.to_string()))?;
        match app.handle.take() {
            Some(h) => h.join().map_err(|_| WindowError::Panicked),
            None => Err(WindowError::EventLoop(
                "the event loop ended before the windows opened".into(),
            )),
        }
    })
}

impl<'scope, 'env, F, T> ApplicationHandler<UserEvent> for App<'scope, 'env, F, T>
where
    T: Send + 'scope,
    F: FnOnce(Screens) -> T + Send + 'scope,
{
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let Some(body) = self.body.take() else {
            return;
        };
        match self.open(event_loop) {
            Ok(screens) => {
                let done = DoneOnDrop(self.proxy.clone());
                self.handle = Some(self.scope.spawn(move || {
                    let _done = done;
                    body(screens)
                }));
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, _: &ActiveEventLoop, id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => {
                self.closed.store(true, Ordering::Release);
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key: Key::Named(NamedKey::Escape),
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => self.closed.store(true, Ordering::Release),
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state,
                        repeat: false,
                        ..
                    },
                ..
            } if control_of(code).is_some() => {
                self.desk
                    .update(|k| k.key(code, state == ElementState::Pressed));
            }
            WindowEvent::CursorMoved { position, .. }
                if self.drag_window.is_none_or(|w| w == id) =>
            {
                self.desk.update(|k| k.cursor(position.x, position.y));
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => {
                        self.drag_window = down.then_some(id);
                        self.desk.update(|k| k.left_button(down));
                    }
                    MouseButton::Right => self.desk.update(|k| k.right_button(down)),
                    _ => {}
                }
            }
            WindowEvent::Focused(false) => {
                self.drag_window = None;
                self.desk.update(DeskKeys::release_all);
            }
            WindowEvent::Resized(size) => {
                if let Some((_, s)) = self.sizes.iter().find(|(w, _)| *w == id) {
                    s.set(Size::new(size.width, size.height));
                }
            }
            _ => {}
        }
    }

    fn user_event(&mut self, event_loop: &ActiveEventLoop, event: UserEvent) {
        match event {
            UserEvent::Done => event_loop.exit(),
        }
    }
}

impl<F, T> App<'_, '_, F, T> {
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<Screens, WindowError> {
        let monitors: Vec<MonitorHandle> = event_loop.available_monitors().collect();
        let mut windows = Vec::new();
        for spec in self.specs {
            let window = Arc::new(create_window(event_loop, &monitors, spec)?);
            window.set_cursor_visible(spec.settings.cursor);
            let s = window.inner_size();
            let size = SharedSize::new(Size::new(s.width, s.height));
            self.sizes.push((window.id(), size.clone()));
            windows.push((window, size));
        }
        let (gpu, surfaces) = gpu_for(event_loop, &windows)?;
        let presenters = windows
            .into_iter()
            .zip(surfaces)
            .zip(self.specs)
            .map(|(((window, size), surface), spec)| {
                let remake: crate::present::SurfaceMaker =
                    Box::new(move || wgpu::SurfaceTarget::from(window.clone()));
                Presenter::new(&gpu, surface, remake, spec.settings.clone(), size)
                    .map_err(WindowError::Surface)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Screens {
            gpu,
            presenters,
            closed: self.closed.clone(),
            desk: self.desk.clone(),
        })
    }
}

fn describe_monitors(monitors: &[MonitorHandle]) -> String {
    if monitors.is_empty() {
        return "none".to_owned();
    }
    monitors
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let (s, p) = (m.size(), m.position());
            format!(
                "{i}: {:?} {}x{} at ({}, {})",
                m.name().unwrap_or_default(),
                s.width,
                s.height,
                p.x,
                p.y
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The monitor a window asks for; an unknown one is an error listing those found.
fn find_monitor(
    monitors: &[MonitorHandle],
    wanted: &Monitor,
    title: &str,
) -> Result<MonitorHandle, WindowError> {
    let found = match wanted {
        Monitor::Index(i) => monitors.get(*i).cloned(),
        Monitor::Name(n) => monitors
            .iter()
            .find(|m| m.name().as_deref() == Some(n.as_str()))
            .cloned(),
    };
    found.ok_or_else(|| {
        WindowError::Monitor(format!(
            "window {title:?}: no monitor {} (monitors found: {})",
            match wanted {
                Monitor::Index(i) => format!("with index {i}"),
                Monitor::Name(n) => format!("named {n:?}"),
            },
            describe_monitors(monitors)
        ))
    })
}

fn create_window(
    event_loop: &ActiveEventLoop,
    monitors: &[MonitorHandle],
    spec: &WindowSpec,
) -> Result<Window, WindowError> {
    let s = &spec.settings;
    let monitor = s
        .monitor
        .as_ref()
        .map(|m| find_monitor(monitors, m, &spec.title))
        .transpose()?;
    let mut attrs = Window::default_attributes()
        .with_title(spec.title.clone())
        .with_inner_size(PhysicalSize::new(
            spec.size.width.max(1),
            spec.size.height.max(1),
        ));
    let origin = monitor
        .as_ref()
        .map_or(PhysicalPosition::new(0, 0), MonitorHandle::position);
    match (s.position, &monitor) {
        (Some([x, y]), _) => {
            attrs = attrs.with_position(PhysicalPosition::new(origin.x + x, origin.y + y));
        }
        (None, Some(_)) => attrs = attrs.with_position(origin),
        (None, None) => {}
    }
    match s.fullscreen {
        Fullscreen::No => {}
        Fullscreen::Borderless => {
            attrs = attrs.with_fullscreen(Some(winit::window::Fullscreen::Borderless(
                monitor.clone().or_else(|| event_loop.primary_monitor()),
            )));
        }
        Fullscreen::Exclusive => {
            let m = monitor
                .clone()
                .or_else(|| event_loop.primary_monitor())
                .or_else(|| monitors.first().cloned())
                .ok_or_else(|| {
                    WindowError::Monitor(format!(
                        "window {:?}: exclusive fullscreen, but no monitor is found",
                        spec.title
                    ))
                })?;
            let modes: Vec<_> = m.video_modes().collect();
            // The mode of the window's size at the highest refresh rate.
            let mode = modes
                .iter()
                .filter(|v| Size::new(v.size().width, v.size().height) == spec.size)
                .max_by_key(|v| v.refresh_rate_millihertz())
                .cloned()
                .ok_or_else(|| {
                    let mut sizes: Vec<String> = modes
                        .iter()
                        .map(|v| Size::new(v.size().width, v.size().height).to_string())
                        .collect();
                    sizes.dedup();
                    WindowError::Monitor(format!(
                        "window {:?}: exclusive fullscreen at {}, but monitor {:?} has no such video mode (it has {})",
                        spec.title,
                        spec.size,
                        m.name().unwrap_or_default(),
                        if sizes.is_empty() { "none".to_owned() } else { sizes.join(", ") }
                    ))
                })?;
            attrs = attrs.with_fullscreen(Some(winit::window::Fullscreen::Exclusive(mode)));
        }
    }
    event_loop
        .create_window(attrs)
        .map_err(|e| WindowError::Create {
            title: spec.title.clone(),
            message: e.to_string(),
        })
}

/// A device on an adapter that can present to every window, and the windows' surfaces:
/// Vulkan first, OpenGL if no Vulkan adapter can (`WGPU_BACKEND` chooses instead).
fn gpu_for(
    event_loop: &ActiveEventLoop,
    windows: &[(Arc<Window>, SharedSize)],
) -> Result<(Gpu, Vec<wgpu::Surface<'static>>), WindowError> {
    let tries: &[Option<wgpu::Backends>] = if std::env::var_os("WGPU_BACKEND").is_some() {
        &[None]
    } else {
        &[Some(wgpu::Backends::VULKAN), Some(wgpu::Backends::GL)]
    };
    let mut last_error = String::from("no backend tried");
    for backends in tries {
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        ));
        if let Some(b) = backends {
            desc.backends = *b;
        }
        let instance = wgpu::Instance::new(desc);
        let surfaces = match windows
            .iter()
            .map(|(w, _)| instance.create_surface(w.clone()))
            .collect::<Result<Vec<_>, _>>()
        {
            Ok(s) => s,
            Err(e) => {
                last_error = format!("creating a surface: {e}");
                continue;
            }
        };
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surfaces.first(),
            apply_limit_buckets: false,
        }));
        let adapter = match adapter {
            Ok(a) => a,
            Err(e) => {
                last_error = e.to_string();
                continue;
            }
        };
        if let Some(i) = surfaces
            .iter()
            .position(|s| s.get_capabilities(&adapter).formats.is_empty())
        {
            last_error = format!(
                "adapter {:?} cannot present to window {i}",
                adapter.get_info().name
            );
            continue;
        }
        return Ok((Gpu::from_adapter(instance, adapter)?, surfaces));
    }
    Err(WindowError::Gpu(RenderNodeError::NoAdapter(format!(
        "none that can present to the windows: {last_error}"
    ))))
}
