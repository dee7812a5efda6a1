//! From node temperatures to the spindle's elongation and tilt, the five
//! probe readings, and the tool-tip displacement.
//!
//! Rises are taken from a reference state (the run's initial equilibrium,
//! the "cold sample" of a measurement), `dT_i = T_i - T_i,ref`:
//!
//! ```text
//! E      = sum_{shaft, housing, structure} alpha_i * L_i * dT_i          (um; + towards the workpiece)
//! theta_x = k_yaw_fr (dT_fb - dT_rb) + k_yaw_ho dT_ho                     (urad; yaw, XZ plane)
//! theta_y = k_pitch_fr (dT_fb - dT_rb) + k_pitch_st dT_st                 (urad; pitch, YZ plane)
//! ```
//!
//! The probes see the tilted axis about the deflection centre O at
//! `l_defl_mm` above the nose: the near radial probe (at the nose) moves
//! `l_defl tan(theta)`, the far one `(l_defl - a) tan(theta)`, and S5 reads E.
//! The tool-tip displacement `dx, dy, dz` is then computed from the probe
//! readings with model-core's five-point geometry
//! ([`model_core::geometry`]), exactly as a measurement would, so the
//! run file is self-consistent: `dz ~ -E` (the tip moves towards the
//! workpiece, -Z), `dx ~ (l_defl + tool) theta_x`.

use super::machine::{Expansion, Node, Probes};
use super::network::State;
use model_core::geometry::{
    spindle_drift, GeometryError, ProbeReadings, SpindleDrift, ToolTipDrift,
};

/// um per (um/(m K) * mm * K): lengths are in mm, alpha per metre.
const M_PER_MM: f64 = 1e-3;

/// The expansion model of one machine with its reference state.
#[derive(Debug, Clone)]
pub struct ExpansionModel {
    params: Expansion,
    probes: Probes,
    reference: State,
}

impl ExpansionModel {
    /// Expansion relative to the node temperatures `reference`.
    pub fn new(params: &Expansion, probes: &Probes, reference: State) -> ExpansionModel {
        ExpansionModel {
            params: params.clone(),
            probes: probes.clone(),
            reference,
        }
    }

    /// Elongation and tilts at node temperatures `t`.
    pub fn drift(&self, t: &State) -> SpindleDrift {
        let p = &self.params;
        let rise = |n: Node| t[n.index()] - self.reference[n.index()];
        let e_um = M_PER_MM
            * (p.shaft_alpha_um_per_m_k * p.shaft_length_mm * rise(Node::Shaft)
                + p.housing_alpha_um_per_m_k * p.housing_length_mm * rise(Node::Housing)
                + p.structure_alpha_um_per_m_k * p.structure_length_mm * rise(Node::Structure));
        let front_rear = rise(Node::FrontBearing) - rise(Node::RearBearing);
        let yaw_urad = p.yaw_front_rear_urad_per_k * front_rear
            + p.yaw_housing_urad_per_k * rise(Node::Housing);
        let pitch_urad = p.pitch_front_rear_urad_per_k * front_rear
            + p.pitch_structure_urad_per_k * rise(Node::Structure);
        SpindleDrift {
            elongation_um: e_um,
            yaw_rad: yaw_urad * 1e-6,
            pitch_rad: pitch_urad * 1e-6,
        }
    }

    /// Noise-free probe changes for a drift (the inverse of
    /// [`spindle_drift`]): near probes at the nose, far probes `spacing_mm`
    /// further up, S5 the elongation.
    pub fn probe_changes(&self, d: &SpindleDrift) -> ProbeReadings {
        let near_um = self.probes.l_defl_mm * 1e3;
        let far_um = (self.probes.l_defl_mm - self.probes.spacing_mm) * 1e3;
        let (tx, ty) = (d.yaw_rad.tan(), d.pitch_rad.tan());
        ProbeReadings {
            s1_um: near_um * tx,
            s2_um: near_um * ty,
            s3_um: far_um * tx,
            s4_um: far_um * ty,
            s5_um: d.elongation_um,
        }
    }

    /// Tool-tip displacement from probe changes, through model-core's
    /// five-point geometry.
    pub fn tool_tip(
        &self,
        changes: &ProbeReadings,
        tool_mm: f64,
    ) -> Result<ToolTipDrift, GeometryError> {
        spindle_drift(changes, self.probes.spacing_mm)?
            .tool_tip_drift(self.probes.l_defl_mm, tool_mm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::machine::Machine;

    #[test]
    fn probes_round_trip_through_the_geometry() {
        let m = Machine::default_machine();
        let x = ExpansionModel::new(&m.expansion, &m.probes, State::repeat(20.0));
        let mut t = State::repeat(20.0);
        t[Node::Shaft.index()] += 8.0;
        t[Node::Housing.index()] += 4.5;
        t[Node::Structure.index()] += 1.9;
        t[Node::FrontBearing.index()] += 8.2;
        t[Node::RearBearing.index()] += 9.4;
        let d = x.drift(&t);
        let back = spindle_drift(&x.probe_changes(&d), m.probes.spacing_mm);
        let back = back.unwrap_or(SpindleDrift {
            elongation_um: f64::NAN,
            yaw_rad: f64::NAN,
            pitch_rad: f64::NAN,
        });
        assert!((back.yaw_rad - d.yaw_rad).abs() < 1e-15);
        assert!((back.pitch_rad - d.pitch_rad).abs() < 1e-15);
        let tip = x.tool_tip(&x.probe_changes(&d), 100.0).unwrap_or_default();
        // dz ~ -E, dx ~ (l_defl + tool) * yaw.
        assert!((tip.z_um + d.elongation_um).abs() < 1e-3, "{tip:?} {d:?}");
        assert!((tip.x_um - 400e3 * d.yaw_rad).abs() < 1e-3, "{tip:?} {d:?}");
    }
}
