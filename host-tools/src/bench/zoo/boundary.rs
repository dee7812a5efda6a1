//! The boundaries of a plant: the room air and the coolant supply.
//!
//! - **Ambient**: constant for the nominal model; with the `ambient` effect a
//!   day cycle (warmest in the afternoon), a slow drift and the weather (a
//!   slow Ornstein-Uhlenbeck wander).
//! - **Coolant**: constant for the nominal model (a perfectly regulated
//!   supply); with the `coolant` effect an on/off chiller with hysteresis
//!   whose tank takes the heat the machine gives to the coolant. The tank
//!   warms at `(Q_load + Q_base) / C` while the compressor is off and cools
//!   at `(P - Q_load - Q_base) / C` while it runs, so the period
//!
//! ```text
//! period = band C / (Q_load + Q_base) + band C / (P - Q_load - Q_base)
//! ```
//!
//!   drifts with the machine's load: long at rest, short at full speed.

use super::noise::Gauss;

/// Seed stream of the weather.
const WEATHER_STREAM: u64 = 11;
/// Grid of the precomputed weather, s.
const WEATHER_DT_S: f64 = 300.0;

/// How the room air moves with the `ambient` effect.
#[derive(Debug, Clone, PartialEq)]
pub struct AmbientSwing {
    /// Half the day-night swing, K.
    pub day_amplitude_c: f64,
    /// Clock hour of the warmest air, h.
    pub warmest_clock_h: f64,
    /// Clock hour at the start of the run, h.
    pub start_clock_h: f64,
    /// Linear drift, K/h.
    pub drift_c_per_h: f64,
    /// Standard deviation of the weather wander, K.
    pub weather_c: f64,
    /// Correlation time of the weather wander, s.
    pub weather_tau_s: f64,
}

/// The room air over a run.
#[derive(Debug, Clone, PartialEq)]
pub struct Ambient {
    base_c: f64,
    swing: Option<AmbientSwing>,
    weather: Vec<f64>,
}

impl Ambient {
    /// Constant air at `base_c`.
    pub fn constant(base_c: f64) -> Self {
        Ambient {
            base_c,
            swing: None,
            weather: Vec::new(),
        }
    }

    /// Air moving as `swing` says over `duration_s`, weather from `seed`.
    pub fn varying(base_c: f64, swing: AmbientSwing, duration_s: f64, seed: u64) -> Self {
        let n = (duration_s / WEATHER_DT_S).ceil() as usize + 2;
        let weather = Gauss::new(seed, WEATHER_STREAM).wander(
            n,
            WEATHER_DT_S,
            swing.weather_tau_s,
            swing.weather_c,
        );
        Ambient {
            base_c,
            swing: Some(swing),
            weather,
        }
    }

    /// Air temperature `t_s` after the start of the run, deg C.
    pub fn at(&self, t_s: f64) -> f64 {
        let Some(s) = &self.swing else {
            return self.base_c;
        };
        let clock_h = s.start_clock_h + t_s / 3600.0;
        let day = (std::f64::consts::TAU * (clock_h - s.warmest_clock_h) / 24.0).cos();
        let u = (t_s.max(0.0) / WEATHER_DT_S).min((self.weather.len() - 1) as f64);
        let i = (u.floor() as usize).min(self.weather.len() - 2);
        let f = u - i as f64;
        let weather = (1.0 - f) * self.weather[i] + f * self.weather[i + 1];
        self.base_c + s.day_amplitude_c * day + s.drift_c_per_h * t_s / 3600.0 + weather
    }
}

/// An on/off chiller with hysteresis.
#[derive(Debug, Clone, PartialEq)]
pub struct ChillerSpec {
    /// Middle of the band, deg C.
    pub setpoint_c: f64,
    /// Width of the hysteresis band, K.
    pub band_c: f64,
    /// Heat capacity of the tank, J/K.
    pub tank_j_per_k: f64,
    /// Cooling power of the running compressor, W.
    pub capacity_w: f64,
    /// Heat from pumps and pipes, always there, W.
    pub base_load_w: f64,
}

impl ChillerSpec {
    /// Period of the cycle at a constant machine load `load_w`, s
    /// (infinite when the chiller cannot keep up or never warms).
    pub fn period_s(&self, load_w: f64) -> f64 {
        let q = load_w + self.base_load_w;
        if q <= 0.0 || q >= self.capacity_w {
            return f64::INFINITY;
        }
        let c = self.band_c * self.tank_j_per_k;
        c / q + c / (self.capacity_w - q)
    }
}

/// The chiller's state.
#[derive(Debug, Clone, PartialEq)]
pub struct Chiller {
    spec: ChillerSpec,
    temp_c: f64,
    cooling: bool,
    /// Times the compressor started, s.
    starts: Vec<f64>,
    t_s: f64,
}

impl Chiller {
    /// A chiller at `phase` (0..1) of its warming ramp, at time 0.
    pub fn new(spec: ChillerSpec, phase: f64) -> Self {
        let low = spec.setpoint_c - 0.5 * spec.band_c;
        Chiller {
            temp_c: low + phase.clamp(0.0, 1.0) * spec.band_c,
            spec,
            cooling: false,
            starts: Vec::new(),
            t_s: 0.0,
        }
    }

    /// Supply temperature, deg C.
    pub fn temp_c(&self) -> f64 {
        self.temp_c
    }

    /// Times the compressor started, s.
    pub fn starts(&self) -> &[f64] {
        &self.starts
    }

    /// Advances by `dt_s` with the machine giving `load_w` to the coolant;
    /// switching instants inside the step are exact.
    pub fn advance(&mut self, dt_s: f64, load_w: f64) {
        let s = &self.spec;
        let (low, high) = (s.setpoint_c - 0.5 * s.band_c, s.setpoint_c + 0.5 * s.band_c);
        let mut left = dt_s.max(0.0);
        while left > 0.0 {
            let on = if self.cooling { s.capacity_w } else { 0.0 };
            let rate = (load_w + s.base_load_w - on) / s.tank_j_per_k;
            let to_switch = match (self.cooling, rate) {
                (true, r) if r < 0.0 => (self.temp_c - low).max(0.0) / -r,
                (false, r) if r > 0.0 => (high - self.temp_c).max(0.0) / r,
                _ => f64::INFINITY,
            };
            if to_switch > left {
                self.temp_c += rate * left;
                self.t_s += left;
                return;
            }
            self.temp_c = if self.cooling { low } else { high };
            self.t_s += to_switch;
            left -= to_switch;
            self.cooling = !self.cooling;
            if self.cooling {
                self.starts.push(self.t_s);
            }
        }
    }
}

/// The coolant supply over a run.
#[derive(Debug, Clone, PartialEq)]
pub enum Coolant {
    /// Perfectly regulated at this temperature, deg C.
    Constant(f64),
    /// A cycling chiller.
    Cycling(Chiller),
}

impl Coolant {
    /// Supply temperature now, deg C.
    pub fn temp_c(&self) -> f64 {
        match self {
            Coolant::Constant(c) => *c,
            Coolant::Cycling(ch) => ch.temp_c(),
        }
    }

    /// Advances by `dt_s` under the machine's coolant load `load_w`.
    pub fn advance(&mut self, dt_s: f64, load_w: f64) {
        if let Coolant::Cycling(ch) = self {
            ch.advance(dt_s, load_w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ChillerSpec {
        ChillerSpec {
            setpoint_c: 20.0,
            band_c: 1.0,
            tank_j_per_k: 500_000.0,
            capacity_w: 2000.0,
            base_load_w: 150.0,
        }
    }

    /// Mean time between compressor starts over 12 h at a constant load.
    fn measured_period_s(load_w: f64) -> f64 {
        let mut ch = Chiller::new(spec(), 0.3);
        for _ in 0..(12 * 3600 / 7) {
            ch.advance(7.0, load_w);
        }
        let s = ch.starts();
        (s[s.len() - 1] - s[0]) / (s.len() - 1) as f64
    }

    #[test]
    fn chiller_period_drifts_with_the_load() {
        // Analytic: 150 W -> 500000/300 + 500000/1700 = 1961 s;
        // 750 W -> 500000/900 + 500000/1100 = 1010 s. The simulated cycle
        // matches to 1e-6 (switching is exact inside a step), and the
        // period at full load is about half the one at rest.
        for load in [150.0, 750.0] {
            let (m, a) = (measured_period_s(load), spec().period_s(load));
            assert!((m - a).abs() < 1e-6 * a, "{load} W: {m} vs {a}");
        }
        let ratio = spec().period_s(750.0) / spec().period_s(150.0);
        assert!((0.4..0.6).contains(&ratio), "{ratio}");
        assert!(spec().period_s(1900.0).is_infinite());
    }

    #[test]
    fn ambient_day_cycle_peaks_at_the_warmest_hour() {
        let swing = AmbientSwing {
            day_amplitude_c: 1.5,
            warmest_clock_h: 15.0,
            start_clock_h: 6.0,
            drift_c_per_h: 0.0,
            weather_c: 0.0,
            weather_tau_s: 3600.0,
        };
        let a = Ambient::varying(21.0, swing, 48.0 * 3600.0, 1);
        assert!((a.at(9.0 * 3600.0) - 22.5).abs() < 1e-9);
        assert!((a.at(21.0 * 3600.0) - 19.5).abs() < 1e-9);
        assert_eq!(Ambient::constant(21.0).at(1e5), 21.0);
    }
}
