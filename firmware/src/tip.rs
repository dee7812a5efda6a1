//! Five-point models on the hub: their outputs (elongation `e_um`, tilts
//! `theta_x_urad`, `theta_y_urad`) become tool-tip offsets with the tool
//! length last received from the CNC (CONTRACT section 5;
//! docs/fivepoint.md).
//!
//! For a model that carries five-point geometry (`ValidModel::five_point`)
//! the pipeline's output lanes are the tip drift `dx_um`, `dy_um`, `dz_um`
//! in that order ([`TIP_OUTPUTS`]), whatever the order of the model's own
//! outputs: every sample, the model's E, θx, θy go through model-core's
//! exact geometry (`model_core::fivepoint::TipMap::tool_tip`, seed 001
//! Eq. 1–4: `dx ≈ (l_defl + tool) θx`, `dy ≈ (l_defl + tool) θy`,
//! `dz ≈ −E`). A tool change therefore moves dx and dy at the next sample,
//! through the slew limiter like any other change, with no new model.
//!
//! Which inputs a lane reads: dx those of θx, dy those of θy, dz those of E
//! (the exact dz also has `L·θ²/2`, of order 1e-3 µm at thermal angles,
//! computed from the model's θ even while a θ input is faulty and held).
//! Until the first tool length arrives, dx and dy have no valid value: they
//! are handled like outputs whose input is stale (STALE flag, hold, ramp to
//! zero), while dz, which does not depend on the tool, is computed with a
//! zero tool length (its error is `tool·θ²/2`, under 0.01 µm).

use model_core::fivepoint::TipMap;
pub use model_core::fivepoint::TIP_OUTPUTS;
use model_core::ValidModel;

use crate::offsets::MAX_OUTPUTS;

/// Lanes (bit `k`: lane `k`) that need the tool length: dx and dy.
pub const TOOL_LANES: u8 = 0b011;

/// The name of output lane `k` of `model`: the tip axis for a five-point
/// model, else the model's output name.
pub fn lane_name(model: &ValidModel, k: usize) -> Option<&str> {
    match model.five_point() {
        Some(_) => TIP_OUTPUTS.get(k).copied(),
        None => model.outputs().get(k).map(|n| n.as_str()),
    }
}

/// Per lane, the inputs it reads, from the model's per-output masks `deps`
/// (unchanged for a model without five-point geometry).
pub fn lane_deps(tip: Option<&TipMap>, deps: [u32; MAX_OUTPUTS]) -> [u32; MAX_OUTPUTS] {
    let Some(tip) = tip else {
        return deps;
    };
    let mut lanes = [0; MAX_OUTPUTS];
    for (lane, source) in lanes.iter_mut().zip(tip.source_outputs()) {
        *lane = deps.get(source).copied().unwrap_or(0);
    }
    lanes
}

/// Replaces the model's outputs in `values` by the tip drift `[dx, dy, dz]`
/// for `tool_mm` (zero when none has arrived yet; the caller holds dx and
/// dy then). False, leaving `values` as they were, when the geometry
/// refuses the outputs (a tilt at ±90°, an overflow): a model fault.
pub fn to_tool_tip(tip: &TipMap, values: &mut [f64; MAX_OUTPUTS], tool_mm: Option<f64>) -> bool {
    match tip.tool_tip(values, tool_mm.unwrap_or(0.0)) {
        Ok([dx, dy, dz]) => {
            *values = [0.0; MAX_OUTPUTS];
            for (v, d) in values.iter_mut().zip([dx, dy, dz]) {
                *v = d;
            }
            true
        }
        Err(_) => false,
    }
}
