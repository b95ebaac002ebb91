//! The tunable parameters of the tracking pipeline as they appear in a CAVE config's
//! `[tracking]` section. The defaults are the values tuned on the HoloLens traces with
//! `holocave tracking tune` (the README's "Tracking and frusta" section gives the tuning
//! table and its caveats).

use serde::{Deserialize, Serialize};

use crate::guard::GuardConfig;
use crate::one_euro::OneEuroParams;
use crate::predict::{ConstantVelocityParams, DespParams, PredictorKind};

/// One Euro jitter filter settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilterConfig {
    pub enabled: bool,
    pub position: OneEuroParams,
    pub orientation: OneEuroParams,
}

impl Default for FilterConfig {
    fn default() -> Self {
        FilterConfig {
            enabled: false,
            position: OneEuroParams {
                min_cutoff: 1.0,
                beta: 1.0,
                d_cutoff: 1.0,
            },
            orientation: OneEuroParams {
                min_cutoff: 1.0,
                beta: 1.0,
                d_cutoff: 1.0,
            },
        }
    }
}

/// Prediction settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PredictionConfig {
    pub method: PredictorKind,
    pub constant_velocity: ConstantVelocityParams,
    pub desp: DespParams,
}

impl Default for PredictionConfig {
    fn default() -> Self {
        PredictionConfig {
            method: PredictorKind::Desp,
            constant_velocity: ConstantVelocityParams {
                position_time_constant_ms: 5.0,
                orientation_time_constant_ms: 5.0,
            },
            desp: DespParams {
                position_time_constant_ms: 5.0,
                orientation_time_constant_ms: 5.0,
            },
        }
    }
}

/// Everything the pipeline from raw samples to predicted pose needs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingParams {
    pub guard: GuardConfig,
    pub filter: FilterConfig,
    pub prediction: PredictionConfig,
}
