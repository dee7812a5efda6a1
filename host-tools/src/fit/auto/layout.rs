//! How the averaged winners of every target sit on the hub: the model's
//! channels (one per dataset input and reference), one feature list shared
//! by every output, and each output's row of coefficients, within the
//! hub's capacity ([`MAX_CHANNELS`] channels, [`MAX_FB_FEATURES`] features).
//!
//! Targets may choose different input forms. A temperature read in both
//! forms takes two channels (its change from the run's first sample and
//! its logged value). When that would exceed the hub's channels, the
//! change-form members are rewritten on the logged channels, exactly: a
//! feature is a first-order filter with unit steady-state gain started in
//! steady state, so it is linear and passes a constant through unchanged,
//! `F(x - x0) = F(x) - x0`; and `x0`, the run's first sample, is itself a
//! feature, a filter whose pole is 1 ([`HOLD_TAU_S`]), which holds the value
//! it started with. A change-form regression `sum_f b_f F_f(x - x0)` is then
//! `sum_f b_f F_f(x) - (sum_f b_f) x0` per input.
//!
//! The search's filter grids cannot give more features than the hub holds
//! (at most 32 channels of 7 features or 16 temperatures of 12 in both
//! forms, plus the heat sources': a test in mod.rs counts them);
//! [`Layout::check`] still refuses in one line what the hub would not take.

use super::features::Role;
use super::search::Member;
use super::table::Form;
use anyhow::{anyhow, bail, Result};
use model_core::fbank::{FbOutput, Feature, FilterBank, HOLD_TAU_S, MAX_FB_FEATURES};
use model_core::model::MAX_CHANNELS;
use model_core::Reference;

/// One model channel: a dataset input, the grid form whose values give
/// its calibration envelope, and the reference the hub subtracts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    /// Dataset input index.
    pub input: usize,
    /// Form of the calibration values (its envelope).
    pub form: Form,
    /// What the hub subtracts from the reading.
    pub reference: Reference,
}

/// The model input of dataset input `i` with role `role` in `form`.
pub fn reference(role: Role, form: Form) -> Reference {
    match (role, form) {
        (Role::Temperature, Form::Change) => Reference::First,
        _ => Reference::Absolute,
    }
}

/// The winners on the hub.
#[derive(Clone, Debug)]
pub struct Layout {
    /// Model channels, in model input order.
    pub channels: Vec<Channel>,
    /// Features, shared by every output (channel indices).
    pub features: Vec<Feature>,
    /// Per target: intercept and one coefficient per feature.
    pub rows: Vec<(f64, Vec<f64>)>,
}

impl Layout {
    /// Of every target's members (`winners[t]`, each in its own form),
    /// rewritten on logged channels when reading both forms would exceed
    /// the hub's channels.
    pub fn of(roles: &[Role], winners: &[&[Member]]) -> Result<Self> {
        let rewrite = channels(roles, winners, false).len() > MAX_CHANNELS;
        Self::build(roles, winners, rewrite)
    }

    /// [`Layout::of`] with the rewrite chosen by the caller.
    fn build(roles: &[Role], winners: &[&[Member]], rewrite: bool) -> Result<Self> {
        let channels = channels(roles, winners, rewrite);
        let channel_of = |i: usize, form: Form| {
            let r = reference(roles[i], hub_form(form, rewrite));
            channels
                .iter()
                .position(|c| c.input == i && c.reference == r)
        };
        let (features, rows) = averaged_rows(roles, winners, rewrite, &channel_of)?;
        Ok(Self {
            channels,
            features,
            rows,
        })
    }

    /// The bank model-core runs: the features and one output per target
    /// (rows padded with zeros to every feature).
    pub fn bank(&self) -> Result<FilterBank> {
        let cap = || anyhow!("auto: capacity");
        let mut outputs = heapless::Vec::new();
        for (o, (intercept, row)) in self.rows.iter().enumerate() {
            let mut coef = row.clone();
            coef.resize(self.features.len(), 0.0);
            outputs
                .push(FbOutput {
                    output: u8::try_from(o)?,
                    intercept: *intercept,
                    coef: heapless::Vec::from_slice(&coef).map_err(|_| cap())?,
                })
                .map_err(|_| anyhow!("auto: too many outputs"))?;
        }
        Ok(FilterBank {
            features: heapless::Vec::from_slice(&self.features).map_err(|_| cap())?,
            outputs,
        })
    }

    /// A one-line refusal when the hub does not take it.
    pub fn check(&self) -> Result<()> {
        if self.channels.len() > MAX_CHANNELS {
            bail!(
                "auto: the model would read {} inputs; the hub takes at most {MAX_CHANNELS}",
                self.channels.len()
            );
        }
        if self.features.len() > MAX_FB_FEATURES {
            bail!(
                "auto: {} filter features; the hub takes at most {MAX_FB_FEATURES} (give fewer --inputs)",
                self.features.len()
            );
        }
        Ok(())
    }
}

/// The form a member's channels take on the hub: its own, or with the
/// rewrite the logged one.
fn hub_form(form: Form, rewrite: bool) -> Form {
    if rewrite {
        Form::Absolute
    } else {
        form
    }
}

/// Every (dataset input, reference) pair a member uses, in dataset order,
/// change-form channels first; with `rewrite`, every input on its logged
/// channel.
fn channels(roles: &[Role], winners: &[&[Member]], rewrite: bool) -> Vec<Channel> {
    let mut out: Vec<Channel> = Vec::new();
    for form in Form::ALL {
        for (i, &role) in roles.iter().enumerate() {
            let used = winners
                .iter()
                .flat_map(|m| m.iter())
                .any(|m| m.form == form && m.features.iter().any(|f| f.input == i));
            let form = hub_form(form, rewrite);
            let reference = reference(role, form);
            if used && !out.iter().any(|c| c.input == i && c.reference == reference) {
                out.push(Channel {
                    input: i,
                    form,
                    reference,
                });
            }
        }
    }
    if rewrite {
        out.sort_by_key(|c| c.input);
    }
    out
}

/// Features (model channels) and each target's averaged row `(intercept,
/// coefficients)`; a row is as long as the features seen up to its target
/// (shorter rows end in zeros).
type AveragedRows = (Vec<Feature>, Vec<(f64, Vec<f64>)>);

/// The members averaged per target into rows over one shared feature list;
/// `channel_of(input, form)` is the model channel. With `rewrite`, a
/// change-form temperature feature goes on the logged channel and its
/// coefficient, negated, onto that channel's hold feature.
fn averaged_rows(
    roles: &[Role],
    winners: &[&[Member]],
    rewrite: bool,
    channel_of: &dyn Fn(usize, Form) -> Option<usize>,
) -> Result<AveragedRows> {
    let mut feats: Vec<Feature> = Vec::new();
    let mut rows: Vec<(f64, Vec<f64>)> = Vec::new();
    for members in winners {
        let mut intercept = 0.0;
        let mut coef: Vec<(Feature, f64)> = Vec::new();
        let w = 1.0 / members.len() as f64;
        for m in *members {
            intercept += w * m.coefs.intercept;
            for (d, b) in m.features.iter().zip(&m.coefs.beta) {
                let ch = channel_of(d.input, m.form).ok_or_else(|| anyhow!("auto: input map"))?;
                let input = u8::try_from(ch)?;
                coef.push((
                    Feature {
                        input,
                        power: d.power,
                        tau_s: d.tau_s,
                    },
                    w * b,
                ));
                if rewrite && m.form == Form::Change && roles[d.input] == Role::Temperature {
                    // F(x - x0) = F(x) - x0 holds for the first power only.
                    if d.power != 1 {
                        bail!(
                            "auto: a squared change-form temperature cannot go on a logged channel"
                        );
                    }
                    let hold = Feature {
                        input,
                        power: 1,
                        tau_s: HOLD_TAU_S,
                    };
                    coef.push((hold, -w * b));
                }
            }
        }
        let mut dense = vec![0.0; feats.len()];
        for (f, b) in coef {
            match feats.iter().position(|g| *g == f) {
                Some(p) => dense[p] += b,
                None => {
                    feats.push(f);
                    dense.push(b);
                }
            }
        }
        rows.push((intercept, dense));
    }
    Ok((feats, rows))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::auto::features::FeatureDef;
    use crate::fit::auto::ridge::Coefs;

    fn member(form: Form, defs: &[(usize, f64)], beta: &[f64], intercept: f64) -> Member {
        Member {
            form,
            features: defs
                .iter()
                .map(|&(input, tau_s)| FeatureDef {
                    input,
                    power: 1,
                    tau_s,
                })
                .collect(),
            coefs: Coefs {
                intercept,
                beta: beta.to_vec(),
            },
            lambda: 0.0,
            fold_coefs: Vec::new(),
        }
    }

    /// Every output of the layout's bank over one run of `t0` (input 0)
    /// and `t1` (input 1), stepped by model-core as the hub steps it:
    /// `[output][sample]`.
    fn predict(l: &Layout, t0: &[f64], t1: &[f64]) -> Vec<Vec<f64>> {
        let name = |s: &str| model_core::Name::try_from(s).unwrap();
        let model = model_core::Model {
            inputs: l
                .channels
                .iter()
                .map(|c| model_core::Channel {
                    name: name(["T0", "T1"][c.input]),
                    reference: c.reference,
                })
                .collect(),
            outputs: ["dx_um", "dz_um"].iter().map(|o| name(o)).collect(),
            dt_s: 30.0,
            params: model_core::Params::Fbank(l.bank().unwrap()),
            bounds: None,
            five_point: None,
        }
        .validate()
        .unwrap();
        let mut state = model_core::ModelState::new();
        let mut out = vec![Vec::new(); 2];
        for (a, b) in t0.iter().zip(t1) {
            let x: Vec<f64> = l.channels.iter().map(|c| [*a, *b][c.input]).collect();
            let mut y = [0.0; 2];
            model.step(&mut state, &x, &mut y).unwrap();
            out[0].push(y[0]);
            out[1].push(y[1]);
        }
        out
    }

    #[test]
    fn a_change_form_member_rewritten_on_logged_channels_predicts_the_same() {
        // Target 0 in change form on T0 (raw and 900 s), target 1 absolute.
        let roles = [Role::Temperature, Role::Temperature];
        let change = [member(
            Form::Change,
            &[(0, 0.0), (0, 900.0), (1, 2700.0)],
            &[2.0, -1.5, 0.7],
            0.0,
        )];
        let absolute = [member(
            Form::Absolute,
            &[(0, 0.0), (1, 0.0)],
            &[0.3, 1.1],
            -4.0,
        )];
        let winners: [&[Member]; 2] = [&change, &absolute];
        let two = Layout::of(&roles, &winners).unwrap();
        assert!(
            two.features.iter().all(|f| f.tau_s != HOLD_TAU_S),
            "4 channels fit the hub: no rewrite"
        );
        assert_eq!(two.channels.len(), 4, "each input read in both forms");
        let one = Layout::build(&roles, &winners, true).unwrap();
        assert_eq!(one.channels.len(), 2, "one logged channel per input");
        assert!(one
            .channels
            .iter()
            .all(|c| c.reference == Reference::Absolute));
        let holds = one
            .features
            .iter()
            .filter(|f| f.tau_s == HOLD_TAU_S)
            .count();
        assert_eq!(holds, 2, "T0 and T1 each hold their first sample");
        // A run that starts warm (21.3 / 19.8 C) and moves.
        let n = 500;
        let t0: Vec<f64> = (0..n)
            .map(|k| 21.3 + 3.0 * (f64::from(k) / 80.0).sin())
            .collect();
        let t1: Vec<f64> = (0..n).map(|k| 19.8 + 0.01 * f64::from(k)).collect();
        let (a, b) = (predict(&two, &t0, &t1), predict(&one, &t0, &t1));
        for row in 0..2 {
            let (a, b) = (&a[row], &b[row]);
            let worst = a
                .iter()
                .zip(b.iter())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            // Rounding only: values near 20 C, coefficients near 1, so
            // each product is exact to ~1e-14 and a few of them add up.
            assert!(worst < 1e-12, "target {row}: {worst}");
        }
    }
}
