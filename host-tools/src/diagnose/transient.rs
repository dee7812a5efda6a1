//! A heat candidate that explains only transients on a sensor is a lag.
//!
//! Extra heat (cutting power beyond air cutting, a low-speed motor loss)
//! raises a temperature for as long as it flows: its response has a
//! steady-state gain of the sign physics fixes (up, on a temperature). A
//! lagging sensor is a first-order filter of the site it sits on: it
//! shifts the phase of every change and leaves the steady state alone, so
//! what it leaves of the twin's run is a transient after each change of
//! speed or load that decays to zero. Where the cutting heat enters (a ram
//! probe, a tool-side sensor) every load step is such a change, and the
//! two-time-constant heat candidate can draw that transient as a fast
//! response minus a slow one of nearly the same gain: a fit with almost no
//! steady state. When that happens on a temperature look where the lag
//! candidate (whose gain is fixed at 1, [`super::variants`]) passes the
//! look's rule on its own against the baseline (the heat winner has
//! already beaten the raw residual there), the look's verdict is the lag.
//!
//! The steady-state share of a two-response fit is
//! `|g1 + g2| / (|g1| + |g2|)`: 1 when both responses warm the channel, 0
//! when they cancel at steady state.

use super::candidates::Scored;
use super::outcome::Param;

/// Effects that add heat and so must leave a steady-state rise.
pub const HEAT_EFFECTS: [&str; 2] = ["cutting", "motor_loss"];

/// A heat candidate whose steady-state share is below this explains only
/// transients. Development seed 1 (plants a-i, the 117 `cutting` and
/// `motor_loss` verdicts on a temperature look): the two lags of plant i's
/// ram probe called `cutting` had 0.09 and 0.11; the true heat effects
/// 0.14 (a motor loss whose lag candidate left 2.2 x the baseline) and
/// 0.30-1 otherwise; on none of the true heat effects did the lag
/// candidate leave less than 0.97 of the baseline.
pub const TRANSIENT_SHARE: f64 = 0.25;

/// `|g1 + g2| / (|g1| + |g2|)` of a candidate's response gains (the
/// parameters named `gain1_*` and `gain2_*`), or `None` without two
/// gains or with both zero.
pub fn steady_share(s: &Scored) -> Option<f64> {
    let gain = |prefix: &str| {
        s.params
            .iter()
            .find(|(k, _)| k.starts_with(prefix))
            .and_then(|(_, v)| Param::as_f64(v))
    };
    let (g1, g2) = (gain("gain1_")?, gain("gain2_")?);
    let size = g1.abs() + g2.abs();
    (size > 0.0).then(|| (g1 + g2).abs() / size)
}

/// The verdict of a temperature look whose winner `verdict` is a heat
/// effect that explains only transients ([`TRANSIENT_SHARE`]) while
/// `sensor_lag` passes the look's rule (`passes`): `sensor_lag`; else
/// `verdict` unchanged.
pub fn lag_not_heat(
    scored: &[Scored],
    verdict: String,
    temperature: bool,
    passes: impl Fn(&Scored) -> bool,
) -> String {
    let find = |name: &str| scored.iter().find(|s| s.name == name);
    let transient = temperature
        && HEAT_EFFECTS.contains(&verdict.as_str())
        && find(&verdict)
            .and_then(steady_share)
            .is_some_and(|share| share < TRANSIENT_SHARE);
    if transient && find("sensor_lag").is_some_and(passes) {
        "sensor_lag".into()
    } else {
        verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::candidates::test_scored;

    fn with_gains(name: &str, after: f64, g1: f64, g2: f64) -> Scored {
        let mut s = test_scored(name, after, 5.0, 0.001);
        s.params.insert("gain1_k_per_kw".into(), Param::Number(g1));
        s.params.insert("gain2_k_per_kw".into(), Param::Number(g2));
        s
    }

    #[test]
    fn the_steady_share_tells_a_rise_from_a_transient() {
        // Plant i's lagged ram probe: -0.061 and +0.077 K/kW, share 0.11.
        let lagish = with_gains("cutting", 1.0, -0.0614, 0.0771);
        assert!((steady_share(&lagish).unwrap() - 0.0157 / 0.1385).abs() < 1e-3);
        assert_eq!(
            steady_share(&with_gains("cutting", 1.0, 0.2, 0.1)),
            Some(1.0)
        );
        assert_eq!(steady_share(&with_gains("cutting", 1.0, 0.0, 0.0)), None);
        assert_eq!(steady_share(&test_scored("cutting", 1.0, 5.0, 0.001)), None);
    }

    #[test]
    fn a_transient_heat_fit_beside_a_passing_lag_is_a_lag() {
        let lag = test_scored("sensor_lag", 1.6, 5.0, 0.002);
        let passes = |s: &Scored| s.ratio_to_none <= 0.5;
        let transient = vec![with_gains("cutting", 1.0, -0.0614, 0.0771), lag.clone()];
        assert_eq!(
            lag_not_heat(&transient, "cutting".into(), true, passes),
            "sensor_lag"
        );
        // Not on a displacement, not when the lag does not pass, not when
        // the heat fit keeps a steady-state rise.
        assert_eq!(
            lag_not_heat(&transient, "cutting".into(), false, passes),
            "cutting"
        );
        let weak_lag = vec![
            with_gains("cutting", 1.0, -0.0614, 0.0771),
            test_scored("sensor_lag", 3.0, 5.0, 0.002),
        ];
        assert_eq!(
            lag_not_heat(&weak_lag, "cutting".into(), true, passes),
            "cutting"
        );
        let rise = vec![with_gains("cutting", 1.0, -0.02, 0.08), lag];
        assert_eq!(
            lag_not_heat(&rise, "cutting".into(), true, passes),
            "cutting"
        );
    }
}
