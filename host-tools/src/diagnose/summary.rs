//! The figures a caller most often needs of a diagnosis: the verdict, the
//! deciding look's best candidate, the gap per channel and the deployment
//! comparison, read from the typed outcome ([`super::outcome::Diagnosis`]).

use super::outcome::{finite, Diagnosis};
use std::collections::BTreeMap;

/// A diagnosis in brief.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The verdict: an effect's name or `none`.
    pub verdict: String,
    /// The channel the verdict explains.
    pub main_channel: String,
    /// Where the held-out part starts, s.
    pub holdout_from_t_s: f64,
    /// The deciding look's best candidate (the first of its `effects`).
    pub best: Option<Effect>,
    /// Rms of the gap (real - sim) per channel, in its unit.
    pub gap_rms: BTreeMap<String, f64>,
    /// A compensation model trained on the sim, on sim + effect and on the
    /// real fit part, scored on the real hold-out (`None` when not figured).
    pub deployment: Option<Deployment>,
}

/// One candidate's held-out figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Effect {
    /// The candidate.
    pub name: String,
    /// `100 (1 - after / before)`.
    pub shrink_pct: f64,
    /// Held-out rms before, in the channel's unit.
    pub rms_before: f64,
    /// Held-out rms after.
    pub rms_after: f64,
}

/// The deployment comparison (deploy.rs).
#[derive(Clone, Debug, PartialEq)]
pub struct Deployment {
    /// The compensation model's kind.
    pub model: String,
    /// The effect added to the sim, if any.
    pub effect: Option<String>,
    /// Held-out rmse trained on the sim, um.
    pub on_sim_um: f64,
    /// Held-out rmse trained on sim + effect, um.
    pub on_sim_plus_effect_um: Option<f64>,
    /// Held-out rmse trained on the real fit part, um.
    pub on_real_fit_part_um: Option<f64>,
}

impl Summary {
    /// The brief of a diagnosis.
    pub fn of(d: &Diagnosis) -> Summary {
        let best = d.effects.first().map(|e| Effect {
            name: e.name.clone(),
            shrink_pct: e.shrink_pct,
            rms_before: e.rms_before,
            rms_after: e.rms_after,
        });
        let gap_rms = d
            .gap
            .iter()
            .filter_map(|(k, g)| Some((k.clone(), finite(g.rms)?)))
            .collect();
        let deployment = d.deployment.comparison().and_then(|c| {
            Some(Deployment {
                model: c.model.clone(),
                effect: c.effect.clone(),
                on_sim_um: c.trained_on_sim.rmse_um()?,
                on_sim_plus_effect_um: c
                    .trained_on_sim_plus_effect
                    .as_ref()
                    .and_then(|t| t.rmse_um()),
                on_real_fit_part_um: c.trained_on_real_fit_part.rmse_um(),
            })
        });
        Summary {
            verdict: d.verdict.clone(),
            main_channel: d.main_channel.clone(),
            holdout_from_t_s: d.holdout_from_t_s,
            best,
            gap_rms,
            deployment,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::outcome::{self, Comparison, Gap, Trained};
    use super::*;

    fn effect(name: &str, shrink_pct: f64, rms_before: f64, rms_after: f64) -> outcome::Effect {
        outcome::Effect {
            confidence: None,
            fit_rms: 0.0,
            model: String::new(),
            name: name.into(),
            p_adjusted: None,
            p_value: None,
            pair: None,
            params: BTreeMap::new(),
            ratio_to_none: 1.0,
            rms_after,
            rms_after_first_alone: None,
            rms_before,
            shrink_pct,
        }
    }

    fn gap(rms: f64) -> Gap {
        Gap { max_abs: rms, rms }
    }

    fn scored(rmse_um: f64) -> Trained {
        Trained::Scored {
            reduction_pct: 0.0,
            rmse_um,
        }
    }

    fn diagnosis(
        verdict: &str,
        effects: Vec<outcome::Effect>,
        deployment: outcome::Deployment,
    ) -> Diagnosis {
        Diagnosis {
            bands: Vec::new(),
            deployment,
            effects,
            gap: BTreeMap::from([("dz_um".into(), gap(1.5)), ("T2".into(), gap(0.2))]),
            gate: None,
            holdout_from_t_s: 43200.0,
            looks: Vec::new(),
            main_channel: "T2".into(),
            main_gap_snr: 10.0,
            physical: None,
            rule: String::new(),
            second: None,
            verdict: verdict.into(),
            where_: Vec::new(),
        }
    }

    #[test]
    fn reads_the_verdict_the_best_effect_and_the_deployment() {
        let dep = Comparison {
            effect: Some("ambient".into()),
            held_out_uncompensated_rms_um: 30.0,
            improvement_pct: Some(-0.6),
            inputs: vec!["T1".into()],
            model: "mlr".into(),
            note: None,
            target: "dz_um".into(),
            trained_on: String::new(),
            trained_on_real_fit_part: scored(0.22),
            trained_on_sim: scored(3.4),
            trained_on_sim_plus_effect: Some(scored(3.42)),
        };
        let effects = vec![
            effect("ambient", 75.3, 0.14, 0.03),
            effect("none", 0.0, 0.14, 0.14),
        ];
        let d = diagnosis(
            "ambient",
            effects,
            outcome::Deployment::Compared(Box::new(dep)),
        );
        let s = Summary::of(&d);
        assert_eq!(
            (s.verdict.as_str(), s.main_channel.as_str()),
            ("ambient", "T2")
        );
        let best = s.best.unwrap();
        assert_eq!((best.name.as_str(), best.shrink_pct), ("ambient", 75.3));
        assert_eq!(s.gap_rms.get("dz_um"), Some(&1.5));
        let dep = s.deployment.unwrap();
        assert_eq!(
            (
                dep.on_sim_um,
                dep.on_sim_plus_effect_um,
                dep.on_real_fit_part_um
            ),
            (3.4, Some(3.42), Some(0.22))
        );
    }

    #[test]
    fn a_verdict_without_a_deployment_has_none() {
        let skipped = outcome::Deployment::Skipped {
            model: "mlr".into(),
            note: "no displacement channel".into(),
        };
        let s = Summary::of(&diagnosis("none", Vec::new(), skipped));
        assert!(s.best.is_none() && s.deployment.is_none());
        assert_eq!(s.verdict, "none");
    }
}
