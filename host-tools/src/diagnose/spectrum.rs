//! Where the residual's energy sits in frequency: a periodogram (own radix-2
//! FFT) of the residual resampled onto a uniform grid, summed over three
//! bands of period: slow drift (> 2 h, with the mean), mid (10 min - 2 h:
//! chiller-like cycling) and fast (< 10 min).

use crate::data::runfile::resample_linear;

/// Periods above this are slow drift, s.
pub const SLOW_ABOVE_S: f64 = 7200.0;
/// Periods below this are fast, s.
pub const FAST_BELOW_S: f64 = 600.0;
/// The uniform grid has at most this many points (2^12): 48 h at 42 s.
const MAX_POINTS: usize = 4096;

/// Energy shares of one channel's residual.
#[derive(Debug, Clone, PartialEq)]
pub struct Bands {
    /// Share of periods > 2 h (and the mean), %.
    pub slow_pct: f64,
    /// Share of 10 min .. 2 h, %.
    pub mid_pct: f64,
    /// Share of periods < 10 min (up to the grid's Nyquist period), %.
    pub fast_pct: f64,
    /// Grid step used, s.
    pub grid_dt_s: f64,
}

/// Periodogram of `x` on `t_s`: `(period_s, power)` for bins 1..N/2 plus
/// the mean's power as period infinity, on a uniform grid of step
/// `max(median dt, span / 4096)`, zero-padded to a power of two.
pub fn periodogram(t_s: &[f64], x: &[f64]) -> (Vec<(f64, f64)>, f64) {
    let n = t_s.len();
    if n < 4 {
        return (Vec::new(), 0.0);
    }
    let span = t_s[n - 1] - t_s[0];
    let dt = grid_step_s(t_s);
    let m = ((span / dt).floor() as usize + 1).min(MAX_POINTS);
    let grid: Vec<f64> = (0..m).map(|k| t_s[0] + k as f64 * dt).collect();
    let xs: Vec<f64> = resample_linear(t_s, x.iter().map(|&v| Some(v)), &grid)
        .into_iter()
        .map(|v| v.unwrap_or(0.0))
        .collect();
    let size = m.next_power_of_two();
    let mut re = xs.clone();
    re.resize(size, 0.0);
    let mut im = vec![0.0; size];
    fft(&mut re, &mut im);
    let power = |k: usize| re[k] * re[k] + im[k] * im[k];
    let bins = (1..=size / 2)
        .map(|k| {
            // Both mirror bins but the Nyquist one.
            let p = if k == size / 2 {
                power(k)
            } else {
                2.0 * power(k)
            };
            (size as f64 * dt / k as f64, p)
        })
        .collect();
    (bins, power(0))
}

/// Step of the uniform grid for `t_s`: `max(median dt, span / 4095)` (0
/// for fewer than two samples).
fn grid_step_s(t_s: &[f64]) -> f64 {
    let span = t_s.last().copied().unwrap_or(0.0) - t_s.first().copied().unwrap_or(0.0);
    let mut dts: Vec<f64> = t_s.windows(2).map(|w| w[1] - w[0]).collect();
    let k = dts.len() / 2;
    let median = if dts.is_empty() {
        0.0
    } else {
        crate::num::stats::kth_smallest(&mut dts, k)
    };
    median.max(span / (MAX_POINTS - 1) as f64)
}

/// Energy shares of `x` (typically a residual) in the three bands.
pub fn bands(t_s: &[f64], x: &[f64]) -> Bands {
    let (bins, dc) = periodogram(t_s, x);
    let (mut slow, mut mid, mut fast) = (dc, 0.0, 0.0);
    for (period, p) in bins {
        if period > SLOW_ABOVE_S {
            slow += p;
        } else if period >= FAST_BELOW_S {
            mid += p;
        } else {
            fast += p;
        }
    }
    let total = (slow + mid + fast).max(f64::MIN_POSITIVE);
    let grid_dt_s = grid_step_s(t_s);
    Bands {
        slow_pct: 100.0 * slow / total,
        mid_pct: 100.0 * mid / total,
        fast_pct: 100.0 * fast / total,
        grid_dt_s,
    }
}

/// The period with the most power between `lo_s` and `hi_s`, refined by a
/// parabola through the peak bin and its neighbours (in frequency), s.
pub fn peak_period_s(t_s: &[f64], x: &[f64], lo_s: f64, hi_s: f64) -> Option<f64> {
    let (bins, _) = periodogram(t_s, x);
    let (i, _) = bins
        .iter()
        .enumerate()
        .filter(|(_, (p, _))| *p >= lo_s && *p <= hi_s)
        .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))?;
    let k = i + 1; // bin index
    let f = |j: usize| 1.0 / bins[j - 1].0; // frequency of bin j
    if i == 0 || i + 1 >= bins.len() {
        return Some(bins[i].0);
    }
    let (a, b, c) = (bins[i - 1].1, bins[i].1, bins[i + 1].1);
    let den = a - 2.0 * b + c;
    let shift = if den.abs() > 0.0 {
        0.5 * (a - c) / den
    } else {
        0.0
    };
    let df = f(k + 1) - f(k);
    Some(1.0 / (f(k) + shift.clamp(-0.5, 0.5) * df))
}

/// In-place iterative radix-2 FFT; `re.len()` must be a power of two.
fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = -std::f64::consts::TAU / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (s, c) = (ang * k as f64).sin_cos();
                let (a, b) = (start + k, start + k + len / 2);
                let tr = re[b] * c - im[b] * s;
                let ti = re[b] * s + im[b] * c;
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fft_agrees_with_a_direct_dft() {
        let x: Vec<f64> = (0..16).map(|k| ((k * k) % 7) as f64 - 3.0).collect();
        let (mut re, mut im) = (x.clone(), vec![0.0; 16]);
        fft(&mut re, &mut im);
        for k in 0..16 {
            let (mut r, mut i) = (0.0, 0.0);
            for (n, v) in x.iter().enumerate() {
                let a = -std::f64::consts::TAU * (k * n) as f64 / 16.0;
                r += v * a.cos();
                i += v * a.sin();
            }
            assert!((re[k] - r).abs() < 1e-9 && (im[k] - i).abs() < 1e-9, "{k}");
        }
    }

    #[test]
    fn a_30_min_sine_lands_in_the_mid_band_and_its_period_is_found() {
        let t: Vec<f64> = (0..2881).map(|k| 60.0 * k as f64).collect();
        let x: Vec<f64> = t
            .iter()
            .map(|t| (std::f64::consts::TAU * t / 1800.0).sin())
            .collect();
        let b = bands(&t, &x);
        assert!(b.mid_pct > 95.0, "{b:?}");
        let p = peak_period_s(&t, &x, 600.0, 7200.0).unwrap_or(0.0);
        assert!((p / 1800.0 - 1.0).abs() < 0.01, "{p}");
        let slow: Vec<f64> = t.iter().map(|t| 1.0 + t / 86_400.0).collect();
        assert!(bands(&t, &slow).slow_pct > 99.0);
    }
}
