//! Running the zoo benchmark: every case written and diagnosed blind, in
//! parallel; the scores per plant and pooled, as a typed outcome.

use super::cases::{write_case, ZooCase, ZooPlan, DT_S};
use super::catalogue;
use super::plant::PlantFacts;
use crate::bench::gap::Scratch;
use crate::bench::outcome::{diagnose_case, run_parallel, Diagnosis, Outcome};
use crate::bench::summary::{confusion, summarise_diagnoses, Confusion, Summary};
use crate::diagnose::candidates::round;
use anyhow::Result;
use serde::Serialize;
use serde_json::Value;
use std::path::Path;
use std::time::Instant;

/// The score of one plant (or of all plants of a run pooled).
#[derive(Debug, Clone, Serialize)]
pub struct PlantScore {
    /// Plant id (`all` for the pool).
    pub plant: String,
    /// What the machine is.
    pub name: String,
    /// Cases.
    pub cases: usize,
    /// Share of cases whose verdict is the true cause, 0..1.
    pub accuracy: Option<f64>,
    /// `none` cases given an effect, over the `none` cases, 0..1.
    pub false_alarm_rate: Option<f64>,
    /// Effect cases given another effect, over the effect cases, 0..1.
    pub wrong_effect_rate: Option<f64>,
    /// Effect cases given `none`, over the effect cases, 0..1.
    pub miss_rate: Option<f64>,
    /// `none` cases given an effect.
    pub false_alarms: usize,
    /// `none` cases.
    pub none_cases: usize,
    /// Effect cases given another effect.
    pub wrong_effect: usize,
    /// Effect cases given `none`.
    pub misses: usize,
    /// Effect cases.
    pub effect_cases: usize,
    /// Median held-out shrink of the correctly identified effect cases, %.
    pub median_shrink_correct_pct: Option<f64>,
    /// Confusion matrix: rows by true cause, columns by verdict.
    pub confusion: Confusion,
    /// The summary the score was made from (tables, SVG).
    #[serde(skip)]
    pub summary: Summary,
}

/// One case and its diagnosis, as reported.
#[derive(Debug, Clone, Serialize)]
pub struct CaseReport {
    /// Case index.
    pub id: usize,
    /// Plant id.
    pub plant: String,
    /// True cause.
    pub effect: String,
    /// Profile.
    pub profile: &'static str,
    /// Seed.
    pub seed: u64,
    /// Effect magnitude.
    pub magnitude: f64,
    /// Whether the surroundings were logged.
    pub logged: bool,
    /// The diagnosis' figures.
    #[serde(flatten)]
    pub diagnosis: Value,
}

/// The settings a run used.
#[derive(Debug, Clone, Serialize)]
pub struct ZooConfigReport {
    /// Causes.
    pub effects: Vec<String>,
    /// Cases per cause and plant.
    pub cases_per_label: usize,
    /// Base seed.
    pub seed: u64,
    /// Mismatch half-width, %.
    pub mismatch_pct: f64,
    /// Run length, h.
    pub hours: f64,
    /// Sample time, s.
    pub dt_s: f64,
}

/// What `bench gap` (zoo) reports.
#[derive(Debug, Clone, Serialize)]
pub struct ZooSummary {
    /// Always `zoo`.
    pub benchmark: &'static str,
    /// The held-out plant.
    pub heldout_plant: String,
    /// Whether this run scored it (else it was left out).
    pub scored_heldout: bool,
    /// Score per plant.
    pub plants: Vec<PlantScore>,
    /// Every case of the run pooled.
    pub pooled: PlantScore,
    /// The structures of the plants run.
    pub plant_facts: Vec<PlantFacts>,
    /// Cases.
    pub cases: usize,
    /// Wall time, s.
    pub wall_s: f64,
    /// Worker threads.
    pub threads: usize,
    /// Settings.
    pub config: ZooConfigReport,
    /// Every case (with `--json` or `--out`).
    pub per_case: Vec<CaseReport>,
}

/// Generates and diagnoses one case in `work/zoo-ID`.
pub fn run_case(case: ZooCase, work: &Path, keep: bool) -> Result<Outcome<ZooCase>> {
    let dir = work.join(format!("zoo-{:04}", case.id));
    let truth = case.effect.clone();
    diagnose_case(case, &truth, &dir, keep, write_case)
}

/// Runs every case in parallel with a progress bar; outcomes in case order.
pub fn run_all(cases: Vec<ZooCase>, work: &Path, keep: bool) -> Result<Vec<Outcome<ZooCase>>> {
    run_parallel(cases, "bench gap (zoo)", |c| run_case(c, work, keep))
}

/// A fraction 0..1 of a percentage, rounded; `None` when undefined.
fn frac(pct: f64) -> Option<f64> {
    pct.is_finite().then(|| round(pct / 100.0))
}

/// The score of `outs` under the name `plant`.
pub fn score(plant: &str, name: &str, outs: &[&Outcome<ZooCase>]) -> PlantScore {
    let d: Vec<&Diagnosis> = outs.iter().map(|o| &o.diag).collect();
    let s = summarise_diagnoses(&d);
    PlantScore {
        plant: plant.to_string(),
        name: name.to_string(),
        cases: s.cases,
        accuracy: frac(s.accuracy_pct),
        false_alarm_rate: frac(s.false_alarm_rate_pct()),
        wrong_effect_rate: frac(s.wrong_effect_rate_pct()),
        miss_rate: frac(s.miss_rate_pct()),
        false_alarms: s.false_alarms.0,
        none_cases: s.false_alarms.1,
        wrong_effect: s.wrong_effect,
        misses: s.misses,
        effect_cases: s.effect_cases,
        median_shrink_correct_pct: s
            .median_shrink_correct_pct
            .is_finite()
            .then(|| round(s.median_shrink_correct_pct)),
        confusion: confusion(&s),
        summary: s,
    }
}

/// One case as reported.
fn case_report(o: &Outcome<ZooCase>) -> CaseReport {
    let c = &o.case;
    CaseReport {
        id: c.id,
        plant: c.plant.clone(),
        effect: c.effect.clone(),
        profile: c.profile.label(),
        seed: c.seed,
        magnitude: round(c.magnitude),
        logged: c.logged,
        diagnosis: o.diag.to_json(),
    }
}

/// The summary of a run of `plan`.
pub fn summarise_zoo(plan: &ZooPlan, outs: &[Outcome<ZooCase>], wall_s: f64) -> Result<ZooSummary> {
    let mut plants = Vec::new();
    let mut facts = Vec::new();
    for id in &plan.plants {
        let p = catalogue::plant(id)?;
        let mine: Vec<&Outcome<ZooCase>> = outs.iter().filter(|o| &o.case.plant == id).collect();
        plants.push(score(id, p.name, &mine));
        facts.push(p.facts());
    }
    let all: Vec<&Outcome<ZooCase>> = outs.iter().collect();
    let pp = &plan.params;
    Ok(ZooSummary {
        benchmark: "zoo",
        heldout_plant: plan.heldout.clone(),
        scored_heldout: plan.scored_heldout,
        pooled: score("all", "every plant of this run", &all),
        plants,
        plant_facts: facts,
        cases: outs.len(),
        wall_s: round(wall_s),
        threads: rayon::current_num_threads(),
        config: ZooConfigReport {
            effects: pp.labels.clone(),
            cases_per_label: pp.cases_per_label,
            seed: pp.seed,
            mismatch_pct: pp.mismatch_pct,
            hours: pp.hours,
            dt_s: DT_S,
        },
        per_case: outs.iter().map(case_report).collect(),
    })
}

/// The zoo benchmark of `plan`: every case written and diagnosed blind in
/// `scratch`; the outcomes and their summary.
pub fn bench_zoo(plan: &ZooPlan, scratch: &Scratch) -> Result<(ZooSummary, Vec<Outcome<ZooCase>>)> {
    let started = Instant::now();
    let outs = scratch.run(|work| run_all(plan.cases.clone(), work, scratch.keep_runs))?;
    let summary = summarise_zoo(plan, &outs, started.elapsed().as_secs_f64())?;
    Ok((summary, outs))
}
