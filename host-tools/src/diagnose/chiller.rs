//! A chiller's cycle in a coolant log: the band of periods a chiller
//! cycles in ([`CHILLER_BAND_S`]), and whether a logged supply carries such
//! a cycle ([`CoolantCycle`]: its fast content over its white noise). Both
//! the alignment (does the twin's own supply cycle?) and the gates (does
//! the real one?) ask it, so it sits below both.

use crate::data::runfile::{resample_linear, RunFile};
use crate::num::lsq;

/// Periods of chiller cycling tracked on temperature channels, s: 5 min
/// (2.5 samples at 60 s) .. 2 h (the slow end of the `mid` band).
pub const CHILLER_BAND_S: (f64, f64) = (300.0, 7200.0);
/// A logged coolant cycles when the rms of its fast part (the log minus
/// its centred mean over [`SLOW_WINDOW_S`]) exceeds this many times its
/// white noise.
pub const COOLANT_CYCLE_SNR: f64 = 3.0;
/// ... and this many kelvin (a supply regulated to +-0.05 K does not
/// cycle, whatever its logger's resolution).
pub const MIN_COOLANT_CYCLE_K: f64 = 0.03;
/// Window of the centred mean that takes out slow moves of the supply (a
/// chiller following the room over the day), s: the slow end of the
/// chiller band [`CHILLER_BAND_S`]. A 12 h swing keeps 5 % of its
/// amplitude; a 45 min cycle keeps all of it.
pub const SLOW_WINDOW_S: f64 = CHILLER_BAND_S.1;
/// The logged coolant's fast content.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoolantCycle {
    /// Rms of the log minus its centred [`SLOW_WINDOW_S`] mean, K.
    pub band_rms_k: f64,
    /// That over the log's white noise.
    pub snr: f64,
}

impl CoolantCycle {
    /// Whether the log carries a chiller cycle.
    pub fn cycles(&self) -> bool {
        self.snr >= COOLANT_CYCLE_SNR && self.band_rms_k >= MIN_COOLANT_CYCLE_K
    }
}

/// Centred mean of `x` over `t +- half_s` at every row (prefix sums; the
/// window's ends move forward with the row, so the work is linear in the
/// rows: `t` is increasing).
fn centred_mean(t: &[f64], x: &[f64], half_s: f64) -> Vec<f64> {
    let mut cum = Vec::with_capacity(x.len() + 1);
    cum.push(0.0);
    for v in x {
        cum.push(cum[cum.len() - 1] + v);
    }
    let (mut a, mut b) = (0, 0);
    t.iter()
        .map(|&tk| {
            // The first rows at or after tk - half_s, and after tk + half_s.
            while a < t.len() && t[a] < tk - half_s {
                a += 1;
            }
            while b < t.len() && t[b] <= tk + half_s {
                b += 1;
            }
            (cum[b] - cum[a]) / (b - a).max(1) as f64
        })
        .collect()
}

/// Whether the simulated run's own `coolant_c` (on the real run's time
/// base) cycles: a twin that models its chiller leaves nothing of it.
pub fn sim_coolant_cycles(sim: &RunFile, t: &[f64]) -> bool {
    let Some(col) = sim.column("coolant_c") else {
        return false;
    };
    let c: Option<Vec<f64>> = resample_linear(&sim.t_s, col, t).into_iter().collect();
    c.and_then(|c| cycle_of(t, &c)).is_some_and(|c| c.cycles())
}

/// The fast content of `c` on times `t`: its rms after the centred
/// [`SLOW_WINDOW_S`] mean is taken off, away from the ends (half a window
/// each); `None` when fewer than 8 rows lie between the ends.
pub fn cycle_of(t: &[f64], c: &[f64]) -> Option<CoolantCycle> {
    let half = 0.5 * SLOW_WINDOW_S;
    let a = t.partition_point(|&x| x < t[0] + half);
    let b = t.partition_point(|&x| x <= t[t.len() - 1] - half);
    if b < a + 8 {
        return None;
    }
    let m = centred_mean(t, c, half);
    let fast: Vec<f64> = (a..b).map(|k| c[k] - m[k]).collect();
    let band_rms_k = lsq::rms(&fast);
    Some(CoolantCycle {
        band_rms_k,
        snr: band_rms_k / lsq::white_sigma(c).max(1e-12),
    })
}
