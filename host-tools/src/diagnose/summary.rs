//! The figures a caller most often needs of a diagnosis, typed: the
//! verdict, the deciding look's best candidate, the gap per channel and the
//! deployment comparison. The whole diagnosis stays `diagnose --json`'s
//! object (built in mod.rs); this is its one reader, so callers (the demo,
//! scripts over the library) never index it by key themselves.

use serde_json::Value;
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
    /// Reads the brief from a diagnosis object (`diagnose --json`'s).
    pub fn of(v: &Value) -> Summary {
        let text = |x: &Value| x.as_str().map(str::to_string);
        let best = v["effects"].get(0).and_then(|e| {
            Some(Effect {
                name: text(&e["name"])?,
                shrink_pct: e["shrink_pct"].as_f64().unwrap_or(f64::NAN),
                rms_before: e["rms_before"].as_f64().unwrap_or(f64::NAN),
                rms_after: e["rms_after"].as_f64().unwrap_or(f64::NAN),
            })
        });
        let gap_rms = v["gap"]
            .as_object()
            .map(|m| {
                m.iter()
                    .filter_map(|(k, g)| Some((k.clone(), g["rms"].as_f64()?)))
                    .collect()
            })
            .unwrap_or_default();
        let dep = &v["deployment"];
        let rmse = |key: &str| dep[key]["rmse_um"].as_f64();
        let deployment = rmse("trained_on_sim").map(|on_sim_um| Deployment {
            model: text(&dep["model"]).unwrap_or_default(),
            effect: text(&dep["effect"]),
            on_sim_um,
            on_sim_plus_effect_um: rmse("trained_on_sim_plus_effect"),
            on_real_fit_part_um: rmse("trained_on_real_fit_part"),
        });
        Summary {
            verdict: text(&v["verdict"]).unwrap_or_default(),
            main_channel: text(&v["main_channel"]).unwrap_or_default(),
            holdout_from_t_s: v["holdout_from_t_s"].as_f64().unwrap_or(f64::NAN),
            best,
            gap_rms,
            deployment,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn reads_the_verdict_the_best_effect_and_the_deployment() {
        let v = json!({
            "verdict": "ambient", "main_channel": "T2", "holdout_from_t_s": 43200.0,
            "effects": [{"name": "ambient", "shrink_pct": 75.3, "rms_before": 0.14, "rms_after": 0.03},
                        {"name": "none", "shrink_pct": 0.0, "rms_before": 0.14, "rms_after": 0.14}],
            "gap": {"dz_um": {"rms": 1.5}, "T2": {"rms": 0.2}},
            "deployment": {"model": "mlr", "effect": "ambient",
                "trained_on_sim": {"rmse_um": 3.4}, "trained_on_sim_plus_effect": {"rmse_um": 3.42},
                "trained_on_real_fit_part": {"rmse_um": 0.22}},
        });
        let s = Summary::of(&v);
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
        let v = json!({"verdict": "none", "effects": [], "deployment": {"model": "mlr", "note": "no displacement channel"}});
        let s = Summary::of(&v);
        assert!(s.best.is_none() && s.deployment.is_none());
        assert_eq!(s.verdict, "none");
    }
}
