//! `--tone`: how a command's images are tone-mapped, shared by every command that writes
//! pictures (a leaf: it names no other command).

use clap::ValueEnum;
use holocave_render_node::{ToneMapper, ToneMode};

/// How a node's images are tone-mapped.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Tone {
    /// Ward Larson's histogram adjustment, as a camera would.
    Camera,
    /// What a person would see: Ward Larson's histogram adjustment with human contrast
    /// sensitivity, veiling glare, acuity and colour loss.
    Human,
    /// Luminance in cd/m² in false colour (0.001 to 100 000, logarithmic) with a legend.
    Falsecolor,
    /// The tracer's Reinhard preview (PNG previews only).
    Reinhard,
}

impl Tone {
    /// The flag's value naming this mode.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Tone::Camera => "camera",
            Tone::Human => "human",
            Tone::Falsecolor => "falsecolor",
            Tone::Reinhard => "reinhard",
        }
    }

    /// The tone mapper of a scene whose radiance is `efficacy` lm/W (`None`: the tracer's
    /// Reinhard preview).
    pub(crate) fn mapper(self, efficacy: f32) -> Option<ToneMapper> {
        let mode = match self {
            Tone::Camera => ToneMode::Camera,
            Tone::Human => ToneMode::Human,
            Tone::Falsecolor => ToneMode::FalseColor,
            Tone::Reinhard => return None,
        };
        Some(ToneMapper::with_efficacy(mode, efficacy))
    }
}
