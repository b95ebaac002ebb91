//! VRPN's button and analog messages, byte for byte (as `vrpn_Button.C` and
//! `vrpn_Analog.C` of VRPN 07.x write them), and picking one device's events out of a
//! stream of messages.
//!
//! - `vrpn_Button Change`: big-endian `i32` button number, `i32` state (non-zero: pressed);
//!   8 bytes.
//! - `vrpn_Button States`: big-endian `i32` count `n`, then `n` `i32` states; `4 + 4n`
//!   bytes, `n` at most 256 (`vrpn_BUTTON_MAX_BUTTONS`).
//! - `vrpn_Analog Channel`: the channel count as a big-endian `f64`, then that many
//!   `f64` values; `8 + 8n` bytes, `n` at most 128 (`vrpn_CHANNEL_MAX`).

use crate::input::{InputEvent, InputSample};
use crate::vrpn_wire::{Message, RemoteNames};

/// The button change message's type name.
pub const BUTTON_CHANGE: &str = "vrpn_Button Change";
/// The all-buttons message's type name.
pub const BUTTON_STATES: &str = "vrpn_Button States";
/// The analog report's type name.
pub const ANALOG_CHANNEL: &str = "vrpn_Analog Channel";
/// Most buttons a VRPN button device has.
pub const MAX_BUTTONS: usize = 256;
/// Most channels a VRPN analog device has.
pub const MAX_CHANNELS: usize = 128;

/// A button or analog message that does not follow VRPN's layout.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputWireError {
    #[error("`{BUTTON_CHANGE}` payload is {len} bytes, expected 8")]
    ChangeLength { len: usize },
    #[error("`{BUTTON_CHANGE}` names button {index}, outside 0..{MAX_BUTTONS}")]
    ButtonIndex { index: i32 },
    #[error("`{BUTTON_STATES}` payload is {len} bytes, too short for its count")]
    StatesShort { len: usize },
    #[error(
        "`{BUTTON_STATES}` announces {count} buttons in a {len}-byte payload (expected {MAX_BUTTONS} at most, 4 + 4 × count bytes)"
    )]
    StatesCount { count: i32, len: usize },
    #[error("`{ANALOG_CHANNEL}` payload is {len} bytes, too short for its count")]
    AnalogShort { len: usize },
    #[error(
        "`{ANALOG_CHANNEL}` announces {count} channels in a {len}-byte payload (expected a whole number up to {MAX_CHANNELS}, 8 + 8 × count bytes)"
    )]
    AnalogCount { count: f64, len: usize },
}

fn be_i32(p: &[u8], at: usize) -> i32 {
    i32::from_be_bytes(p[at..at + 4].try_into().expect("4 bytes"))
}

fn be_f64(p: &[u8], at: usize) -> f64 {
    f64::from_be_bytes(p[at..at + 8].try_into().expect("8 bytes"))
}

/// Decodes a `vrpn_Button Change` payload.
pub fn decode_button_change(p: &[u8]) -> Result<InputEvent, InputWireError> {
    if p.len() != 8 {
        return Err(InputWireError::ChangeLength { len: p.len() });
    }
    let index = be_i32(p, 0);
    if !(0..MAX_BUTTONS as i32).contains(&index) {
        return Err(InputWireError::ButtonIndex { index });
    }
    Ok(InputEvent::Button {
        index: index as u32,
        pressed: be_i32(p, 4) != 0,
    })
}

/// Decodes a `vrpn_Button States` payload.
pub fn decode_button_states(p: &[u8]) -> Result<InputEvent, InputWireError> {
    if p.len() < 4 {
        return Err(InputWireError::StatesShort { len: p.len() });
    }
    let count = be_i32(p, 0);
    if !(0..=MAX_BUTTONS as i32).contains(&count) || p.len() != 4 + 4 * count as usize {
        return Err(InputWireError::StatesCount {
            count,
            len: p.len(),
        });
    }
    Ok(InputEvent::Buttons(
        (0..count as usize)
            .map(|i| be_i32(p, 4 + 4 * i) != 0)
            .collect(),
    ))
}

/// Decodes a `vrpn_Analog Channel` payload.
pub fn decode_analog(p: &[u8]) -> Result<InputEvent, InputWireError> {
    if p.len() < 8 {
        return Err(InputWireError::AnalogShort { len: p.len() });
    }
    let count = be_f64(p, 0);
    let whole = count.fract() == 0.0 && (0.0..=MAX_CHANNELS as f64).contains(&count);
    if !whole || p.len() != 8 + 8 * count as usize {
        return Err(InputWireError::AnalogCount {
            count,
            len: p.len(),
        });
    }
    Ok(InputEvent::Axes(
        (0..count as usize).map(|i| be_f64(p, 8 + 8 * i)).collect(),
    ))
}

/// The payload VRPN's `vrpn_Button::encode_to` writes.
pub fn encode_button_change(index: i32, state: i32) -> Vec<u8> {
    [index.to_be_bytes(), state.to_be_bytes()].concat()
}

/// The payload VRPN's `vrpn_Button::encode_states_to` writes.
pub fn encode_button_states(states: &[i32]) -> Vec<u8> {
    let mut out = (states.len() as i32).to_be_bytes().to_vec();
    for s in states {
        out.extend_from_slice(&s.to_be_bytes());
    }
    out
}

/// The payload VRPN's `vrpn_Analog::encode_to` writes.
pub fn encode_analog(channels: &[f64]) -> Vec<u8> {
    let mut out = (channels.len() as f64).to_be_bytes().to_vec();
    for c in channels {
        out.extend_from_slice(&c.to_be_bytes());
    }
    out
}

/// Which kind of input device a client follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    Buttons,
    Analog,
}

impl InputKind {
    /// The message types this kind reads (announced to the server by name).
    pub fn types(self) -> &'static [&'static str] {
        match self {
            InputKind::Buttons => &[BUTTON_CHANGE, BUTTON_STATES],
            InputKind::Analog => &[ANALOG_CHANNEL],
        }
    }
}

/// Picks one button or analog device's events out of a stream of messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputSelector {
    pub device: String,
    pub kind: InputKind,
}

impl InputSelector {
    /// The event in `msg` when it is a message of the selected device and kind.
    pub fn event(
        &self,
        names: &RemoteNames,
        msg: &Message,
    ) -> Result<Option<InputSample>, InputWireError> {
        if msg.kind < 0 || names.sender(msg.sender) != Some(&self.device) {
            return Ok(None);
        }
        let event = match (self.kind, names.kind(msg.kind)) {
            (InputKind::Buttons, Some(BUTTON_CHANGE)) => decode_button_change(&msg.payload)?,
            (InputKind::Buttons, Some(BUTTON_STATES)) => decode_button_states(&msg.payload)?,
            (InputKind::Analog, Some(ANALOG_CHANNEL)) => decode_analog(&msg.payload)?,
            _ => return Ok(None),
        };
        Ok(Some(InputSample::new(msg.t_ns(), event)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vrpn_wire::{SENDER_DESCRIPTION, StreamDecoder, TYPE_DESCRIPTION, cookie};

    /// Bytes laid out by hand from VRPN's format (not through the encoders above).
    #[test]
    fn hand_built_payloads_decode() {
        // Button 3 pressed: i32 3, i32 1, big-endian.
        let change = [0, 0, 0, 3, 0, 0, 0, 1];
        assert_eq!(
            decode_button_change(&change),
            Ok(InputEvent::Button {
                index: 3,
                pressed: true
            })
        );
        // Button 2 released: the state is the second word, not the first.
        assert_eq!(
            decode_button_change(&[0, 0, 0, 2, 0, 0, 0, 0]),
            Ok(InputEvent::Button {
                index: 2,
                pressed: false
            })
        );
        // Three buttons: up, down, down.
        let states = [0, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1];
        assert_eq!(
            decode_button_states(&states),
            Ok(InputEvent::Buttons(vec![false, true, true]))
        );
        // Two channels, 0.5 and -1.0: f64 2.0 = 0x4000000000000000, 0.5 = 0x3FE0...,
        // -1.0 = 0xBFF0....
        let analog = [
            0x40, 0, 0, 0, 0, 0, 0, 0, 0x3f, 0xe0, 0, 0, 0, 0, 0, 0, 0xbf, 0xf0, 0, 0, 0, 0, 0, 0,
        ];
        assert_eq!(
            decode_analog(&analog),
            Ok(InputEvent::Axes(vec![0.5, -1.0]))
        );
        // The encoders write exactly these bytes.
        assert_eq!(encode_button_change(3, 1), change);
        assert_eq!(encode_button_states(&[0, 1, 1]), states);
        assert_eq!(encode_analog(&[0.5, -1.0]), analog);
    }

    #[test]
    fn payloads_that_break_the_layout_are_errors_saying_how() {
        let e = decode_button_change(&[0, 0, 0, 1]).unwrap_err().to_string();
        assert!(e.contains("4 bytes, expected 8"), "{e}");
        let e = decode_button_change(&encode_button_change(300, 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains("button 300"), "{e}");
        // Count says 4, payload holds 2.
        let mut s = encode_button_states(&[1, 0]);
        s[3] = 4;
        let e = decode_button_states(&s).unwrap_err().to_string();
        assert!(e.contains("4 buttons in a 12-byte payload"), "{e}");
        let mut a = encode_analog(&[0.0, 0.0]);
        a[..8].copy_from_slice(&2.5f64.to_be_bytes());
        let e = decode_analog(&a).unwrap_err().to_string();
        assert!(e.contains("2.5 channels"), "{e}");
        assert!(decode_analog(&[0; 4]).is_err());
        assert!(matches!(
            decode_analog(&encode_analog(&vec![0.0; 129])),
            Err(InputWireError::AnalogCount { .. })
        ));
    }

    #[test]
    fn a_stream_of_messages_yields_only_the_selected_device_and_kind() {
        let t = (10, 250_000);
        let d = |kind, id, name: &str| Message::description(kind, id, name, 0, t);
        let msg = |sender, kind, payload| Message {
            sec: t.0,
            usec: t.1,
            sender,
            kind,
            seq: 0,
            payload,
        };
        let mut bytes = cookie(0).to_vec();
        for m in [
            d(SENDER_DESCRIPTION, 2, "Buttons0"),
            d(SENDER_DESCRIPTION, 3, "Joystick0"),
            d(TYPE_DESCRIPTION, 5, BUTTON_CHANGE),
            d(TYPE_DESCRIPTION, 6, ANALOG_CHANNEL),
            d(TYPE_DESCRIPTION, 7, BUTTON_STATES),
            msg(2, 5, encode_button_change(1, 1)),
            msg(3, 6, encode_analog(&[0.25, 0.75])),
            msg(2, 7, encode_button_states(&[1, 0])),
            msg(3, 5, encode_button_change(0, 1)), // a change from the joystick's sender
        ] {
            bytes.extend(m.encode());
        }
        let buttons = InputSelector {
            device: "Buttons0".into(),
            kind: InputKind::Buttons,
        };
        let axes = InputSelector {
            device: "Joystick0".into(),
            kind: InputKind::Analog,
        };
        let mut dec = StreamDecoder::new();
        // Fed a byte at a time: framing does not depend on how reads split the stream.
        let mut names = RemoteNames::default();
        let (mut b, mut a) = (Vec::new(), Vec::new());
        for byte in bytes {
            dec.feed(&[byte]);
            while let Some(m) = dec.next_message().unwrap() {
                if names.absorb(&m).unwrap() {
                    continue;
                }
                b.extend(buttons.event(&names, &m).unwrap());
                a.extend(axes.event(&names, &m).unwrap());
            }
        }
        let at = 10_250_000_000;
        assert_eq!(
            b,
            vec![
                InputSample::new(
                    at,
                    InputEvent::Button {
                        index: 1,
                        pressed: true
                    }
                ),
                InputSample::new(at, InputEvent::Buttons(vec![true, false])),
            ]
        );
        assert_eq!(
            a,
            vec![InputSample::new(at, InputEvent::Axes(vec![0.25, 0.75]))]
        );
    }
}
