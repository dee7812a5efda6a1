//! The zoo's blind cases: per plant and cause, `cases_per_label` cases,
//! each a "real" run (the plant with every parameter off by up to the
//! mismatch, the cause's effect at a magnitude drawn log-uniform in 0.5..2,
//! noise and drift) and a "sim" run (the plant's nominal model driven by
//! the real run's logged speed and power: same columns, no effect, no
//! noise). Every third case does not log its surroundings: the real and
//! sim files both lose `ambient_c`, `coolant_c` and the air sensor.

use super::catalogue::{self, IDS};
use super::effects::{Effect, Setup};
use super::inputs::{self, ProfileKind, Schedule};
use super::mismatch::mismatched;
use super::noise::{stream_seed, Gauss};
use super::plant::Plant;
use super::simulate::{readings, simulate, Drive, Logged};
use super::table::RunTable;
use crate::bench::cases::LABELS;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Sample time of the zoo's runs, s.
pub const DT_S: f64 = 60.0;
/// One case in this many does not log ambient, coolant and the air sensor.
pub const UNLOGGED_EVERY: usize = 3;
/// Seed stream of the measurement noise.
const NOISE_STREAM: u64 = 51;
/// Seed stream of a case's magnitude.
const CASE_STREAM: u64 = 61;

/// Settings of a zoo benchmark as given on the command line.
#[derive(Debug, Clone, PartialEq)]
pub struct ZooParams {
    /// Plants to run (`None`: every plant but the held-out one).
    pub plants: Option<Vec<String>>,
    /// The plant kept out of development.
    pub heldout: String,
    /// Run only the held-out plant.
    pub score_heldout: bool,
    /// True causes to include.
    pub labels: Vec<String>,
    /// Cases per cause and plant.
    pub cases_per_label: usize,
    /// Base seed.
    pub seed: u64,
    /// Half-width of the uniform parameter mismatch, %.
    pub mismatch_pct: f64,
    /// Length of each run, h.
    pub hours: f64,
}

/// One zoo case.
#[derive(Debug, Clone, PartialEq)]
pub struct ZooCase {
    /// Index in the plan.
    pub id: usize,
    /// Plant id.
    pub plant: String,
    /// True cause (a name of [`LABELS`]).
    pub effect: String,
    /// Profile of the run.
    pub profile: ProfileKind,
    /// Seed of everything random in the case.
    pub seed: u64,
    /// Multiple of the plant's effect sizes (0 for `none`).
    pub magnitude: f64,
    /// Whether ambient, coolant and the air sensor are logged.
    pub logged: bool,
    /// Half-width of the parameter mismatch, %.
    pub mismatch_pct: f64,
    /// Length of the run, h.
    pub hours: f64,
}

/// Checked settings and the cases they make.
#[derive(Debug, Clone, PartialEq)]
pub struct ZooPlan {
    /// Plants run, in order.
    pub plants: Vec<String>,
    /// The held-out plant.
    pub heldout: String,
    /// Whether this run scores the held-out plant.
    pub scored_heldout: bool,
    /// The settings.
    pub params: ZooParams,
    /// Every case.
    pub cases: Vec<ZooCase>,
}

impl ZooParams {
    /// Checks the settings and lays out the cases.
    pub fn check(&self) -> Result<ZooPlan> {
        if !IDS.contains(&self.heldout.as_str()) {
            bail!(
                "--heldout-plant: unknown plant \"{}\" (one of {})",
                self.heldout,
                IDS.join(", ")
            );
        }
        let plants = self.plant_list()?;
        if let Some(l) = self.labels.iter().find(|l| !LABELS.contains(&l.as_str())) {
            bail!(
                "--effects: unknown effect \"{l}\" (one of {})",
                LABELS.join(", ")
            );
        }
        if !(1..=200).contains(&self.cases_per_label) {
            bail!(
                "--cases-per-label must be in 1..=200 (got {})",
                self.cases_per_label
            );
        }
        if !(self.mismatch_pct.is_finite() && (0.0..=30.0).contains(&self.mismatch_pct)) {
            bail!(
                "--mismatch-pct must be in 0..30 (got {})",
                self.mismatch_pct
            );
        }
        // The diagnosis fits the first half and scores the second; below
        // 12 h a half holds too little of a day or a warm-up.
        if !(self.hours.is_finite() && (12.0..=240.0).contains(&self.hours)) {
            bail!("--hours must be in 12..240 (got {})", self.hours);
        }
        Ok(ZooPlan {
            cases: cases(self, &plants),
            heldout: self.heldout.clone(),
            scored_heldout: self.score_heldout,
            plants,
            params: self.clone(),
        })
    }

    /// The plants to run: only the held-out one when scoring it, else the
    /// given ones (never the held-out one) or every other plant.
    fn plant_list(&self) -> Result<Vec<String>> {
        if self.score_heldout {
            return Ok(vec![self.heldout.clone()]);
        }
        let plants: Vec<String> = match &self.plants {
            Some(p) => p.clone(),
            None => IDS
                .iter()
                .filter(|id| **id != self.heldout)
                .map(|s| s.to_string())
                .collect(),
        };
        for (i, p) in plants.iter().enumerate() {
            if !IDS.contains(&p.as_str()) {
                bail!(
                    "--plants: unknown plant \"{p}\" (one of {})",
                    IDS.join(", ")
                );
            }
            if *p == self.heldout {
                bail!("--plants: plant {p} is held out of development; score it once with --score-heldout");
            }
            if plants[..i].contains(p) {
                bail!("--plants: plant {p} is listed twice");
            }
        }
        Ok(plants)
    }
}

/// The seed of case `k` of cause `label` on `plant`: independent of which
/// other plants and causes run.
fn case_seed(seed: u64, plant: &str, k: usize, label: &str) -> u64 {
    let code = plant.bytes().chain(label.bytes()).fold(k as u64, |h, b| {
        h.wrapping_mul(0x100_0000_01B3).wrapping_add(u64::from(b))
    });
    stream_seed(seed, code) % 1_000_000_007
}

/// Every case: per plant, `cases_per_label` rounds of every cause. Round
/// `k` is unlogged when `k % 3 == 2` and takes the profile
/// `(k + k / 3) % 3`, so profiles and logging cross.
fn cases(p: &ZooParams, plants: &[String]) -> Vec<ZooCase> {
    let mut out = Vec::new();
    for plant in plants {
        for k in 0..p.cases_per_label {
            for label in &p.labels {
                let seed = case_seed(p.seed, plant, k, label);
                let magnitude = if label == "none" {
                    0.0
                } else {
                    2f64.powf(2.0 * Gauss::new(seed, CASE_STREAM).uniform() - 1.0)
                };
                out.push(ZooCase {
                    id: out.len(),
                    plant: plant.clone(),
                    effect: label.clone(),
                    profile: ProfileKind::ALL[(k + k / 3) % 3],
                    seed,
                    magnitude,
                    logged: k % UNLOGGED_EVERY != UNLOGGED_EVERY - 1,
                    mismatch_pct: p.mismatch_pct,
                    hours: p.hours,
                });
            }
        }
    }
    out
}

/// The two runs of a case, in memory.
#[derive(Debug, Clone)]
pub struct CaseRuns {
    /// The nominal model's run.
    pub sim: RunTable,
    /// The real machine's run.
    pub real: RunTable,
    /// The real machine's coolant supply (before logging noise), deg C.
    pub real_coolant_c: Vec<f64>,
}

/// Spindle power as the drive logs it: air cutting plus cutting, with
/// noise; 0 at standstill.
fn logged_power(plant: &Plant, s: &Schedule, g: &mut Gauss) -> Vec<f64> {
    s.speed_rpm
        .iter()
        .zip(&s.cut_kw)
        .map(|(&n, &c)| {
            if n > 0.0 {
                (plant.air_power_kw(n) + c + plant.noise.power_kw * g.normal()).max(0.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// The cutting power the nominal model infers from the logged power.
fn inferred_cut_kw(plant: &Plant, speed_rpm: &[f64], power_kw: &[f64]) -> Vec<f64> {
    speed_rpm
        .iter()
        .zip(power_kw)
        .map(|(&n, &p)| {
            if n > 0.0 {
                (p - plant.air_power_kw(n)).max(0.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// Columns a machine that does not log its surroundings lacks.
pub fn unlogged_columns(plant: &Plant) -> Vec<String> {
    let mut v = vec!["ambient_c".to_string(), "coolant_c".to_string()];
    if let Some(i) = plant.sensors.iter().position(|s| s.is_air()) {
        v.push(format!("T{}", i + 1));
    }
    v
}

/// Both runs of `case`.
pub fn build_runs(case: &ZooCase) -> Result<CaseRuns> {
    let nominal = catalogue::plant(&case.plant)?;
    let (real_plant, _) = mismatched(&nominal, case.mismatch_pct, case.seed);
    let sched = inputs::schedule(
        case.profile,
        nominal.max_rpm,
        nominal.cut_max_kw,
        case.hours,
        DT_S,
        case.seed,
    )?;
    let mut g = Gauss::new(case.seed, NOISE_STREAM);
    let power = logged_power(&nominal, &sched, &mut g);
    let logged = Logged {
        t_s: &sched.t_s,
        speed_rpm: &sched.speed_rpm,
        power_kw: &power,
    };
    // Real: the true cutting power, the effect, noise.
    let effect = Effect::from_label(&case.effect)?;
    let duration_s = sched.t_s[sched.t_s.len() - 1] - sched.t_s[0];
    let mut setup = Setup::real(&real_plant, effect, case.magnitude, duration_s, case.seed);
    let drive = Drive {
        t_s: &sched.t_s,
        speed_rpm: &sched.speed_rpm,
        cut_kw: &sched.cut_kw,
    };
    let trace = simulate(&real_plant, &drive, &mut setup)?;
    let mut real = readings(
        &real_plant,
        &logged,
        &trace,
        setup.lag.as_ref(),
        Some(&mut g),
    );
    // Sim: the nominal model on what was logged.
    let cut = inferred_cut_kw(&nominal, &sched.speed_rpm, &power);
    let drive = Drive {
        cut_kw: &cut,
        ..drive
    };
    let sim_trace = simulate(&nominal, &drive, &mut Setup::nominal(&nominal))?;
    let mut sim = readings(&nominal, &logged, &sim_trace, None, None);
    if !case.logged {
        let drop = unlogged_columns(&nominal);
        real.drop_columns(&drop);
        sim.drop_columns(&drop);
    }
    Ok(CaseRuns {
        sim,
        real,
        real_coolant_c: trace.coolant_c,
    })
}

/// Writes the sim and real run files of `case` into `dir`.
pub fn write_case(case: &ZooCase, dir: &Path) -> Result<(PathBuf, PathBuf)> {
    let runs = build_runs(case).with_context(|| {
        format!(
            "zoo case {} (plant {}, {})",
            case.id, case.plant, case.effect
        )
    })?;
    let (sim, real) = (dir.join("sim.csv"), dir.join("real.csv"));
    runs.sim.write(&sim)?;
    runs.real.write(&real)?;
    Ok((sim, real))
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn params(plants: &[&str], heldout: &str, n: usize) -> ZooParams {
        ZooParams {
            plants: Some(plants.iter().map(|s| s.to_string()).collect()),
            heldout: heldout.to_string(),
            score_heldout: false,
            labels: LABELS.iter().map(|s| s.to_string()).collect(),
            cases_per_label: n,
            seed: 1,
            mismatch_pct: 10.0,
            hours: 24.0,
        }
    }

    #[test]
    fn the_plan_keeps_the_heldout_plant_out_unless_scoring_it() {
        let mut p = params(&["a", "b"], "d", 3);
        let plan = p.check().unwrap();
        assert_eq!(plan.cases.len(), 2 * 3 * 6);
        assert!(plan.cases.iter().all(|c| c.plant != "d"));
        // A third unlogged, every profile with both loggings over 9 rounds.
        assert_eq!(plan.cases.iter().filter(|c| !c.logged).count(), 2 * 6);
        p.plants = None;
        let dev = p.check().unwrap();
        assert_eq!(dev.plants, ["a", "b", "c", "e", "f", "g", "h", "i", "j"]);
        p.plants = Some(vec!["d".into()]);
        assert!(p
            .check()
            .unwrap_err()
            .to_string()
            .contains("--score-heldout"));
        p.score_heldout = true;
        assert_eq!(p.check().unwrap().plants, ["d"]);
        // A plant's cases do not depend on which other plants run.
        let only_b = params(&["b"], "d", 3).check().unwrap();
        let b_in_ab: Vec<u64> = plan
            .cases
            .iter()
            .filter(|c| c.plant == "b")
            .map(|c| c.seed)
            .collect();
        assert_eq!(
            only_b.cases.iter().map(|c| c.seed).collect::<Vec<_>>(),
            b_in_ab
        );
    }

    #[test]
    fn runs_are_deterministic_by_seed_and_share_their_columns() {
        let plan = params(&["c"], "d", 3).check().unwrap();
        let case = plan
            .cases
            .iter()
            .find(|c| c.effect == "ambient" && c.logged)
            .unwrap();
        let a = build_runs(case).unwrap();
        let b = build_runs(case).unwrap();
        assert_eq!(a.real, b.real);
        assert_eq!(a.sim, b.sim);
        assert_eq!(a.real.names(), a.sim.names());
        let mut other = case.clone();
        other.seed += 1;
        assert_ne!(build_runs(&other).unwrap().real, a.real);
        // The sim is the nominal model: its ambient is constant.
        let amb = a.sim.column("ambient_c").unwrap();
        assert!(amb.iter().all(|&v| v == amb[0]));
    }

    #[test]
    fn unlogged_cases_drop_ambient_coolant_and_the_air_sensor() {
        let plan = params(&["a"], "d", 3).check().unwrap();
        let case = plan
            .cases
            .iter()
            .find(|c| c.effect == "none" && !c.logged)
            .unwrap();
        let runs = build_runs(case).unwrap();
        for t in [&runs.real, &runs.sim] {
            let names = t.names();
            assert!(
                !names.contains(&"ambient_c") && !names.contains(&"coolant_c"),
                "{names:?}"
            );
            // Plant a: T1..T5 on the machine, T6 in the air.
            assert!(names.contains(&"T5") && !names.contains(&"T6"), "{names:?}");
            assert!(names.contains(&"dz_um") && names.contains(&"speed_rpm"));
        }
    }
}
