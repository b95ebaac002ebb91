//! An Xvfb X server of a test's own, and screenshots of its windows (`xwd`).
//!
//! Windowed runs of the binary happen under it as subprocesses (winit wants the main
//! thread). Without Xvfb or xwd a test skips with a message, except where
//! HOLOCAVE_REQUIRE_SHARED=1 (CI), where it fails (`common::require`).

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::require;

/// A running Xvfb; killed when dropped.
pub struct Xvfb {
    child: Child,
    /// `:N`.
    pub display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Xvfb {
    /// Starts Xvfb on a free display (it picks one and tells us: `-displayfd`), with one
    /// `width`x`height` 24-bit screen. `None` (after saying why) where Xvfb or xwd is
    /// missing and HOLOCAVE_REQUIRE_SHARED is not 1.
    pub fn start(width: u32, height: u32) -> Option<Xvfb> {
        if !require::programs(&["Xvfb", "xwd"], "apt-get install xvfb x11-apps") {
            return None;
        }
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-nolisten", "tcp", "-screen", "0"])
            .arg(format!("{width}x{height}x24"))
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .stdin(Stdio::null())
            .spawn()
            .expect("starting Xvfb");
        // Xvfb writes the display number once it accepts connections.
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("Xvfb's stdout"))
            .read_line(&mut line)
            .expect("reading Xvfb's display number");
        let n: u32 = line
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("Xvfb gave no display number (got {line:?})"));
        Some(Xvfb {
            child,
            display: format!(":{n}"),
        })
    }

    /// A screenshot of the window named `name`, or the reason there is none.
    pub fn screenshot(&self, name: &str) -> Result<image::RgbImage, String> {
        let out = Command::new("xwd")
            .args(["-silent", "-display", &self.display, "-name", name])
            .output()
            .map_err(|e| format!("running xwd: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "xwd -name {name:?}: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        parse_xwd(&out.stdout)
    }
}

/// A 24-bit TrueColor XWD file (as `xwd` writes it) as an RGB image.
pub fn parse_xwd(data: &[u8]) -> Result<image::RgbImage, String> {
    if data.len() < 100 {
        return Err(format!("XWD file of {} bytes: no header", data.len()));
    }
    let field = |i: usize| u32::from_be_bytes(data[i * 4..i * 4 + 4].try_into().unwrap());
    let header_size = field(0) as usize;
    let (format, width, height) = (field(2), field(4), field(5));
    let byte_order = field(7);
    let bits_per_pixel = field(11);
    let bytes_per_line = field(12) as usize;
    let masks = [field(14), field(15), field(16)];
    let ncolors = field(19) as usize;
    if format != 2 || bits_per_pixel != 32 {
        return Err(format!(
            "XWD: pixmap format {format}, {bits_per_pixel} bits per pixel (expected ZPixmap, 32)"
        ));
    }
    let start = header_size + ncolors * 12;
    let need = start + bytes_per_line * height as usize;
    if data.len() < need {
        return Err(format!(
            "XWD: {} bytes, {need} needed for {width}x{height}",
            data.len()
        ));
    }
    let channel = |v: u32, mask: u32| ((v & mask) >> mask.trailing_zeros()) as u8;
    let mut img = image::RgbImage::new(width, height);
    for y in 0..height as usize {
        for x in 0..width as usize {
            let o = start + y * bytes_per_line + x * 4;
            let b: [u8; 4] = data[o..o + 4].try_into().unwrap();
            let v = if byte_order == 0 {
                u32::from_le_bytes(b)
            } else {
                u32::from_be_bytes(b)
            };
            img.put_pixel(
                x as u32,
                y as u32,
                image::Rgb([
                    channel(v, masks[0]),
                    channel(v, masks[1]),
                    channel(v, masks[2]),
                ]),
            );
        }
    }
    Ok(img)
}

/// The largest difference of any channel of any pixel (`None`: the sizes differ).
pub fn max_difference(a: &image::RgbImage, b: &image::RgbImage) -> Option<u8> {
    if a.dimensions() != b.dimensions() {
        return None;
    }
    Some(
        a.pixels()
            .zip(b.pixels())
            .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c])))
            .max()
            .unwrap_or(0),
    )
}

/// Reads `child`'s stdout line by line until one contains `marker` (true) or it ends or
/// `limit` passes (false); the lines read so far are returned too.
pub fn wait_for_line(child: &mut Child, marker: &str, limit: Duration) -> (bool, String) {
    let stdout = child.stdout.take().expect("piped stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut r = BufReader::new(stdout);
        loop {
            let mut line = String::new();
            match r.read_line(&mut line) {
                Ok(0) | Err(_) => return,
                Ok(_) => {
                    if tx.send(line).is_err() {
                        return;
                    }
                }
            }
        }
    });
    let end = Instant::now() + limit;
    let mut seen = String::new();
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) => {
                seen += &line;
                if line.contains(marker) {
                    return (true, seen);
                }
            }
            Err(_) => break,
        }
    }
    (false, seen)
}

/// Everything left on `child`'s stderr (after it exits).
pub fn stderr_of(child: &mut Child) -> String {
    let mut s = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut s);
    }
    s
}

/// Window-manager requests to this X server (x11rb), as a user's window manager would
/// send them: find a window by name, resize it, ask it to close.
pub struct WindowManager {
    conn: x11rb::rust_connection::RustConnection,
    root: u32,
}

impl WindowManager {
    pub fn connect(x: &Xvfb) -> WindowManager {
        use x11rb::connection::Connection;
        let (conn, screen) = x11rb::connect(Some(&x.display)).expect("connecting to Xvfb");
        let root = conn.setup().roots[screen].root;
        WindowManager { conn, root }
    }

    /// The top-level window whose WM_NAME is `name`.
    pub fn find(&self, name: &str) -> Option<u32> {
        use x11rb::protocol::xproto::{AtomEnum, ConnectionExt};
        let tree = self.conn.query_tree(self.root).ok()?.reply().ok()?;
        tree.children.into_iter().find(|&w| {
            self.conn
                .get_property(false, w, AtomEnum::WM_NAME, AtomEnum::ANY, 0, 256)
                .ok()
                .and_then(|c| c.reply().ok())
                .is_some_and(|p| p.value == name.as_bytes())
        })
    }

    /// Resizes the window named `name` to `w`x`h` pixels.
    pub fn resize(&self, name: &str, w: u32, h: u32) {
        use x11rb::connection::Connection;
        use x11rb::protocol::xproto::{ConfigureWindowAux, ConnectionExt};
        let win = self
            .find(name)
            .unwrap_or_else(|| panic!("no window {name:?}"));
        self.conn
            .configure_window(win, &ConfigureWindowAux::new().width(w).height(h))
            .expect("resizing");
        self.conn.flush().expect("flushing");
    }

    /// Asks the window named `name` to close (WM_DELETE_WINDOW, what a window manager sends
    /// when the user closes a window).
    pub fn close(&self, name: &str) {
        use x11rb::connection::Connection;
        use x11rb::protocol::xproto::{ClientMessageEvent, ConnectionExt, EventMask};
        let win = self
            .find(name)
            .unwrap_or_else(|| panic!("no window {name:?}"));
        let atom = |n: &[u8]| {
            self.conn
                .intern_atom(false, n)
                .expect("interning")
                .reply()
                .expect("an atom")
                .atom
        };
        let (protocols, delete) = (atom(b"WM_PROTOCOLS"), atom(b"WM_DELETE_WINDOW"));
        let event = ClientMessageEvent::new(32, win, protocols, [delete, 0, 0, 0, 0]);
        self.conn
            .send_event(false, win, EventMask::NO_EVENT, event)
            .expect("sending WM_DELETE_WINDOW");
        self.conn.flush().expect("flushing");
    }
}

impl WindowManager {
    /// Presses and releases Esc in the window named `name`.
    pub fn press_escape(&self, name: &str) {
        const ESCAPE: u32 = 0xff1b;
        self.key(name, ESCAPE, true);
        self.key(name, ESCAPE, false);
    }

    /// Presses (`down`) or releases the key whose keysym is `keysym` in the window named
    /// `name` (focus given to it, the key sent through XTEST like a real keyboard's).
    pub fn key(&self, name: &str, keysym: u32, down: bool) {
        use x11rb::connection::Connection;
        use x11rb::protocol::xproto::{
            ConnectionExt, InputFocus, KEY_PRESS_EVENT, KEY_RELEASE_EVENT,
        };
        use x11rb::protocol::xtest::ConnectionExt as _;
        let win = self
            .find(name)
            .unwrap_or_else(|| panic!("no window {name:?}"));
        let setup = self.conn.setup();
        let (min, max) = (setup.min_keycode, setup.max_keycode);
        let map = self
            .conn
            .get_keyboard_mapping(min, max - min + 1)
            .expect("asking for the keyboard mapping")
            .reply()
            .expect("the keyboard mapping");
        let per = usize::from(map.keysyms_per_keycode).max(1);
        let code = map
            .keysyms
            .chunks(per)
            .position(|syms| syms.contains(&keysym))
            .map(|i| min + i as u8)
            .unwrap_or_else(|| panic!("no keycode for keysym {keysym:#x}"));
        self.conn
            .set_input_focus(InputFocus::PARENT, win, x11rb::CURRENT_TIME)
            .expect("focusing");
        let kind = if down {
            KEY_PRESS_EVENT
        } else {
            KEY_RELEASE_EVENT
        };
        self.conn
            .xtest_fake_input(kind, code, x11rb::CURRENT_TIME, self.root, 0, 0, 0)
            .expect("XTEST");
        self.conn.flush().expect("flushing");
    }
}

impl WindowManager {
    /// Moves the pointer to (`x`, `y`) in the window named `name`'s coordinates.
    pub fn pointer(&self, name: &str, x: i16, y: i16) {
        use x11rb::connection::Connection;
        use x11rb::protocol::xproto::{ConnectionExt, MOTION_NOTIFY_EVENT};
        use x11rb::protocol::xtest::ConnectionExt as _;
        let win = self
            .find(name)
            .unwrap_or_else(|| panic!("no window {name:?}"));
        let at = self
            .conn
            .translate_coordinates(win, self.root, x, y)
            .expect("asking where the window is")
            .reply()
            .expect("where the window is");
        self.conn
            .xtest_fake_input(
                MOTION_NOTIFY_EVENT,
                0,
                x11rb::CURRENT_TIME,
                self.root,
                at.dst_x,
                at.dst_y,
                0,
            )
            .expect("XTEST");
        self.conn.flush().expect("flushing");
    }

    /// Presses (`down`) or releases mouse button `button` (1: left) where the pointer is.
    pub fn button(&self, button: u8, down: bool) {
        use x11rb::connection::Connection;
        use x11rb::protocol::xproto::{BUTTON_PRESS_EVENT, BUTTON_RELEASE_EVENT};
        use x11rb::protocol::xtest::ConnectionExt as _;
        let kind = if down {
            BUTTON_PRESS_EVENT
        } else {
            BUTTON_RELEASE_EVENT
        };
        self.conn
            .xtest_fake_input(kind, button, x11rb::CURRENT_TIME, self.root, 0, 0, 0)
            .expect("XTEST");
        self.conn.flush().expect("flushing");
    }
}
