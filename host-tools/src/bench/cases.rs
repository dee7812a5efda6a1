//! The cases of the blind gap benchmark and the two run files of each.
//!
//! A case is one "real" run (the twin with one effect of CONTRACT.md
//! section 3 switched on at a scaled magnitude, or none, on a machine whose
//! parameters are all a few % off the nominal ones) and one "sim" run (the
//! nominal twin driven by the real run's own speed, power and tool columns,
//! with other noise), as a user would produce them with `thermcomp simulate
//! --profile file:REAL.csv`. The mismatch makes sure sim never equals real
//! even without an effect, so the `none` cases measure false alarms.

use crate::simulate::write_run;
use crate::twin::effects::{Effect, EffectSet};
use crate::twin::machine::{Machine, Node};
use crate::twin::profile::{self, Profile};
use crate::twin::rng::{Rng, Stream};
use crate::twin::sim::SimOptions;
use anyhow::{anyhow, bail, Context, Result};
use std::path::{Path, PathBuf};

/// Sample time of the benchmark's runs, s: the twin's thermal time
/// constants are >= 25 min (docs/twin.md), so 60 s loses nothing the
/// diagnosis uses and keeps a 48 h run at 2 881 rows.
pub const DT_S: f64 = 60.0;

/// The labels of the true causes, `none` last (the confusion matrix order).
pub const LABELS: [&str; 6] = [
    "ambient",
    "coolant",
    "cutting",
    "motor_loss",
    "sensor_lag",
    "none",
];

/// A speed profile and its length.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileSpec {
    /// The twin's profile (`steps`, `spectrum`, `cooldown`).
    pub profile: Profile,
    /// Length of the run, h.
    pub hours: f64,
}

impl ProfileSpec {
    /// Parses `NAME:HOURS` (e.g. `spectrum:48`).
    pub fn parse(s: &str) -> Result<Self> {
        let (name, hours) = s
            .split_once(':')
            .ok_or_else(|| anyhow!("--profiles: \"{s}\" is not NAME:HOURS (e.g. spectrum:48)"))?;
        let profile = match name.trim() {
            "steps" => Profile::Steps,
            "spectrum" => Profile::Spectrum,
            "cooldown" => Profile::Cooldown,
            other => bail!("--profiles: unknown profile \"{other}\" (steps, spectrum, cooldown)"),
        };
        let hours: f64 = hours
            .trim()
            .parse()
            .map_err(|_| anyhow!("--profiles: \"{hours}\" in \"{s}\" is not a number of hours"))?;
        // The diagnosis needs >= 20 fit rows and 10 held-out rows at 60 s;
        // 4 h is far above that and below any useful thermal test anyway.
        if !(hours.is_finite() && (4.0..=240.0).contains(&hours)) {
            bail!("--profiles: {hours} h in \"{s}\" is outside 4..240 h");
        }
        Ok(ProfileSpec { profile, hours })
    }

    /// `NAME:HOURS` as parsed.
    pub fn label(&self) -> String {
        format!("{}:{}", self.profile.label(), self.hours)
    }
}

/// What the benchmark covers.
#[derive(Debug, Clone)]
pub struct GapConfig {
    /// True causes to include (names of [`LABELS`]).
    pub effects: Vec<String>,
    /// Speed profiles.
    pub profiles: Vec<ProfileSpec>,
    /// Effect magnitudes, multiples of the machine file's effect parameters.
    pub magnitudes: Vec<f64>,
    /// Seeds (independent cases) per combination.
    pub seeds: usize,
    /// Half-width of the uniform parameter mismatch, %.
    pub mismatch_pct: f64,
    /// Base seed; every case's seed is derived from it and the case index.
    pub seed: u64,
}

/// One blind case.
#[derive(Debug, Clone)]
pub struct Case {
    /// Index in the full list.
    pub id: usize,
    /// True cause (a name of [`LABELS`]).
    pub effect: String,
    /// Profile of the run.
    pub profile: ProfileSpec,
    /// Seed of everything random in this case (noise, spectrum, doors, mismatch).
    pub seed: u64,
    /// Multiple of the machine's effect parameters (0 for `none`).
    pub magnitude: f64,
    /// Whether the real file keeps its `ambient_c` and `coolant_c` columns.
    pub logged: bool,
    /// Half-width of the uniform parameter mismatch, %.
    pub mismatch_pct: f64,
}

/// SplitMix64's finaliser: a well-mixed seed per case index, so cases with
/// neighbouring indices share no noise, spectrum or mismatch.
fn mix(seed: u64, i: u64) -> u64 {
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(i.wrapping_add(1).wrapping_mul(0xBF58_476D_1CE4_E5B9));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) % 1_000_000_007
}

/// Every case of `cfg`, the true cause varying fastest (so a strided
/// subset still covers every cause). A `none` case has magnitude 0 and is
/// repeated once per magnitude, so each cause gets the same number of cases.
pub fn cases(cfg: &GapConfig) -> Result<Vec<Case>> {
    for e in &cfg.effects {
        if !LABELS.contains(&e.as_str()) {
            bail!(
                "--effects: unknown effect \"{e}\" (one of {})",
                LABELS.join(", ")
            );
        }
    }
    if cfg.effects.is_empty() || cfg.profiles.is_empty() || cfg.magnitudes.is_empty() {
        bail!("the benchmark needs at least one effect, profile and magnitude");
    }
    if let Some(m) = cfg
        .magnitudes
        .iter()
        .find(|m| !(m.is_finite() && **m > 0.0 && **m <= 10.0))
    {
        bail!("--magnitudes: {m} is outside (0, 10]");
    }
    if !(cfg.mismatch_pct.is_finite() && (0.0..=20.0).contains(&cfg.mismatch_pct)) {
        bail!("--mismatch-pct must be in 0..20 (got {})", cfg.mismatch_pct);
    }
    let mut out = Vec::new();
    for _ in 0..cfg.seeds {
        for &mag in &cfg.magnitudes {
            for logged in [true, false] {
                for prof in &cfg.profiles {
                    for e in &cfg.effects {
                        let id = out.len();
                        out.push(Case {
                            id,
                            effect: e.clone(),
                            profile: prof.clone(),
                            seed: mix(cfg.seed, id as u64),
                            magnitude: if e == "none" { 0.0 } else { mag },
                            logged,
                            mismatch_pct: cfg.mismatch_pct,
                        });
                    }
                }
            }
        }
    }
    Ok(out)
}

/// About `n` cases of `all`: the same number per true cause (the first
/// causes get one more when `n` does not divide), spread evenly over each
/// cause's cases so profiles, magnitudes and logging stay mixed.
pub fn strided(all: Vec<Case>, n: usize) -> Vec<Case> {
    if n == 0 || n >= all.len() {
        return all;
    }
    let labels: Vec<&str> = LABELS
        .iter()
        .copied()
        .filter(|l| all.iter().any(|c| c.effect == *l))
        .collect();
    let mut keep = vec![false; all.len()];
    for (j, l) in labels.iter().enumerate() {
        let idx: Vec<usize> = (0..all.len()).filter(|&i| all[i].effect == *l).collect();
        let want = (n / labels.len() + usize::from(j < n % labels.len())).min(idx.len());
        for k in 0..want {
            keep[idx[k * idx.len() / want]] = true;
        }
    }
    all.into_iter()
        .zip(keep)
        .filter_map(|(c, k)| k.then_some(c))
        .collect()
}

/// The machine of the "real" run: every listed parameter multiplied by
/// `1 + u`, `u` uniform in +-`pct` %, drawn from the case's seed. These are
/// the parameters a twin is least sure of: heat capacities, bearing and
/// motor losses, the convection to the room, the main structural link and
/// the structure's expansion coefficient.
pub fn mismatched(base: &Machine, seed: u64, pct: f64) -> Machine {
    let mut m = base.clone();
    // Stream `Doors` of a seed the twin never gets (seed + a large odd
    // constant), so the mismatch does not replay any noise of the runs.
    let mut rng = Rng::new(seed ^ 0x5DEE_CE66_D1CE_4E5B, Stream::Doors);
    let mut f = || 1.0 + pct / 100.0 * (2.0 * rng.uniform() - 1.0);
    m.nodes.structure.c_j_per_k *= f();
    m.nodes.housing.c_j_per_k *= f();
    m.nodes.motor.c_j_per_k *= f();
    m.nodes.structure.g_ambient_w_per_k *= f();
    m.heat.front_bearing_w_at_ref *= f();
    m.heat.rear_bearing_w_at_ref *= f();
    m.heat.motor_iron_w_at_ref *= f();
    m.expansion.structure_alpha_um_per_m_k *= f();
    let g = f();
    for l in &mut m.links {
        let pair = (l.a, l.b);
        if pair == (Node::Housing, Node::Structure) || pair == (Node::Structure, Node::Housing) {
            l.g_w_per_k *= g;
        }
    }
    m
}

/// `m` with the parameters of `effect` scaled by `k`: the ambient swing,
/// drift and door drop; the chiller's band and rates (so the period stays
/// the machine's); the cutting load; the low-speed loss; the sensor lag.
pub fn scaled_effect(mut m: Machine, effect: Effect, k: f64) -> Machine {
    let e = &mut m.effects;
    match effect {
        Effect::Ambient => {
            e.ambient.day_amplitude_c *= k;
            e.ambient.drift_c_per_h *= k;
            e.ambient.door_drop_c *= k;
        }
        Effect::Coolant => {
            let mid = 0.5 * (e.coolant.low_c + e.coolant.high_c);
            let half = 0.5 * (e.coolant.high_c - e.coolant.low_c) * k;
            e.coolant.low_c = mid - half;
            e.coolant.high_c = mid + half;
            e.coolant.warm_c_per_min *= k;
            e.coolant.cool_c_per_min *= k;
        }
        Effect::Cutting => e.cutting.load_kw *= k,
        Effect::MotorLoss => e.motor_loss.extra_w_at_zero_rpm *= k,
        Effect::SensorLag => e.sensor_lag.tau_s *= k,
    }
    m
}

/// The effect of a label (`None` for `none`).
pub fn effect_of(label: &str) -> Option<Effect> {
    Effect::ALL.into_iter().find(|e| e.name() == label)
}

/// The real and sim run files of `case`, written into `dir`.
pub fn write_case(case: &Case, nominal: &Machine, dir: &Path) -> Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let real = dir.join("real.csv");
    let sim = dir.join("sim.csv");
    let mut machine = mismatched(nominal, case.seed, case.mismatch_pct);
    let mut effects = EffectSet::none();
    if let Some(e) = effect_of(&case.effect) {
        machine = scaled_effect(machine, e, case.magnitude);
        effects = effects.with(e);
    }
    let sched = profile::schedule(
        &case.profile.profile,
        machine.max_rpm,
        Some(case.profile.hours),
        DT_S,
        case.seed,
    )?;
    let opts = SimOptions {
        effects,
        seed: case.seed,
        sensors: None,
    };
    write_run(&machine, &sched, &opts, &real)?;
    if !case.logged {
        drop_columns(&real, &["ambient_c", "coolant_c"])?;
    }
    let driven = profile::schedule(
        &Profile::File(real.clone()),
        nominal.max_rpm,
        None,
        DT_S,
        case.seed,
    )?;
    let opts = SimOptions {
        effects: EffectSet::none(),
        seed: case.seed + 1000,
        sensors: None,
    };
    write_run(nominal, &driven, &opts, &sim)?;
    Ok((sim, real))
}

/// Rewrites the CSV at `path` without the named columns (a machine that
/// does not log its ambient and coolant temperatures). The file is the
/// twin's own output: plain comma-separated cells, no quoting.
fn drop_columns(path: &Path, names: &[&str]) -> Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| anyhow!("{}: empty file", path.display()))?
        .split(',')
        .collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| !names.contains(&header[i]))
        .collect();
    let mut out = String::with_capacity(text.len());
    for line in std::iter::once(header.join(",")).chain(lines.map(str::to_string)) {
        let cells: Vec<&str> = line.split(',').collect();
        let row: Vec<&str> = keep
            .iter()
            .map(|&i| cells.get(i).copied().unwrap_or(""))
            .collect();
        out.push_str(&row.join(","));
        out.push('\n');
    }
    crate::data::fsio::write_bytes_atomic(path, out.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatch_stays_within_its_band_and_differs_per_seed() {
        let m0 = Machine::default_machine();
        let a = mismatched(&m0, 1, 4.0);
        let b = mismatched(&m0, 2, 4.0);
        let ra = a.nodes.structure.c_j_per_k / m0.nodes.structure.c_j_per_k;
        let rb = b.nodes.structure.c_j_per_k / m0.nodes.structure.c_j_per_k;
        assert!((ra - 1.0).abs() <= 0.04 && (rb - 1.0).abs() <= 0.04);
        assert_ne!(ra, rb);
        let same = mismatched(&m0, 1, 0.0);
        assert_eq!(
            same.heat.front_bearing_w_at_ref,
            m0.heat.front_bearing_w_at_ref
        );
    }

    #[test]
    fn coolant_scaling_keeps_the_period() {
        use crate::twin::effects::Coolant;
        let m0 = Machine::default_machine();
        let m2 = scaled_effect(m0.clone(), Effect::Coolant, 2.0);
        let (p0, p2) = (
            Coolant::period_s(&m0.effects.coolant),
            Coolant::period_s(&m2.effects.coolant),
        );
        assert!((p0 - p2).abs() < 1e-9 * p0, "{p0} {p2}");
        let band = m2.effects.coolant.high_c - m2.effects.coolant.low_c;
        assert!(
            (band - 2.0 * (m0.effects.coolant.high_c - m0.effects.coolant.low_c)).abs() < 1e-12
        );
    }

    #[test]
    fn every_cause_gets_the_same_number_of_cases() {
        let cfg = GapConfig {
            effects: LABELS.iter().map(|s| s.to_string()).collect(),
            profiles: vec![ProfileSpec::parse("spectrum:24").expect("profile")],
            magnitudes: vec![0.5, 1.0],
            seeds: 2,
            mismatch_pct: 4.0,
            seed: 1,
        };
        let all = cases(&cfg).expect("cases");
        assert_eq!(all.len(), 6 * 2 * 2 * 2);
        for l in LABELS {
            assert_eq!(all.iter().filter(|c| c.effect == l).count(), 8, "{l}");
        }
        let sub = strided(all, 12);
        assert_eq!(sub.len(), 12);
        for l in LABELS {
            assert!(sub.iter().any(|c| c.effect == l), "{l}");
        }
    }
}
