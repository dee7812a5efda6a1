//! Calibration of the twin to a measured run (`simulate --calibrate`):
//! recovery of known factors from a twin run of a perturbed machine, the
//! calibrated machine file's round trip through `simulate --machine` and
//! `diagnose`, and bad inputs.

mod common;

use common::{fails_one_line, ok, ok_json, p};
use host_tools::simulate::write_run;
use host_tools::twin::calibrate::{self, CalibrateOptions, Measured};
use host_tools::twin::effects::EffectSet;
use host_tools::twin::expansion::ExpansionModel;
use host_tools::twin::machine::{self, Machine, Node, DEFAULT_MACHINE_TOML, N_NODES};
use host_tools::twin::network::{self, Input, Network, State};
use host_tools::twin::profile::{schedule, Profile};
use host_tools::twin::sim::SimOptions;
use std::path::{Path, PathBuf};

/// Known perturbation of the default machine.
const HEAT: f64 = 1.3;
const CAPACITY: f64 = 0.8;
const EXPANSION: f64 = 1.2;
/// Run length and step: 30 h at 60 s (1 801 rows) keeps a debug-build
/// calibration to seconds while covering ~15 spectrum levels and several
/// slow time constants (1.9 h).
const HOURS: f64 = 30.0;
const DT_S: f64 = 60.0;
/// The default machine's first nine sites: the tenth (column skin, 30 %
/// toward the air) is a place the calibration does not offer (a share
/// toward a boundary would make the heat unidentifiable, see
/// `calibrate::choose_places`).
const SENSORS: Option<usize> = Some(9);
/// Calibrate on the first 20 h, hold out the last 10 h.
const UNTIL_S: f64 = 72_000.0;

/// The default machine with heat x1.3, capacities x0.8, expansion x1.2.
fn perturbed() -> Machine {
    let mut m = Machine::default_machine();
    let h = &mut m.heat;
    h.front_bearing_w_at_ref *= HEAT;
    h.rear_bearing_w_at_ref *= HEAT;
    h.motor_idle_w *= HEAT;
    h.motor_iron_w_at_ref *= HEAT;
    for p in m.nodes.each_mut() {
        p.c_j_per_k *= CAPACITY;
    }
    let x = &mut m.expansion;
    x.shaft_alpha_um_per_m_k *= EXPANSION;
    x.housing_alpha_um_per_m_k *= EXPANSION;
    x.structure_alpha_um_per_m_k *= EXPANSION;
    x.yaw_front_rear_urad_per_k *= EXPANSION;
    x.yaw_housing_urad_per_k *= EXPANSION;
    x.pitch_front_rear_urad_per_k *= EXPANSION;
    x.pitch_structure_urad_per_k *= EXPANSION;
    m
}

/// A "real" run of the perturbed machine (spectrum profile, nominal
/// effects, sensor and probe noise on).
fn real_run(dir: &Path) -> PathBuf {
    let m = perturbed();
    let s = schedule(&Profile::Spectrum, m.max_rpm, Some(HOURS), DT_S, 3)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let path = dir.join("real.csv");
    let opts = SimOptions {
        effects: EffectSet::parse("").unwrap_or_else(|e| panic!("{e:#}")),
        seed: 3,
        sensors: SENSORS,
    };
    write_run(&m, &s, &opts, &path).unwrap_or_else(|e| panic!("{e:#}"));
    path
}

/// Equilibrium node rises of `m` at `rpm` from rest.
fn equilibrium_rises(m: &Machine, rpm: f64) -> State {
    let net = Network::new(m);
    let q = network::speed_heat_w(&m.heat, rpm);
    let mut u = Input::zeros();
    for (i, qi) in q.iter().enumerate() {
        u[i] = *qi;
    }
    net.steady_state(&u)
}

/// The expansion factor the calibration found for `dz_um`: its fitted gains
/// against the default machine's own `dz` per rise, both applied to the
/// calibrated twin's equilibrium rises at 9 000 rpm (the direction of
/// excitation the data show; single gains of correlated nodes are not
/// identifiable, their effect along that direction is).
fn expansion_factor(cal: &Machine) -> f64 {
    let rises = equilibrium_rises(cal, 9000.0);
    let dz = cal
        .outputs
        .iter()
        .find(|o| o.name == "dz_um")
        .unwrap_or_else(|| panic!("no dz_um output"));
    let fitted: f64 = (0..N_NODES).map(|i| dz.um_per_k[i] * rises[i]).sum();
    let d = Machine::default_machine();
    let x = ExpansionModel::new(&d.expansion, &d.probes, State::zeros());
    let tip = x
        .tool_tip(&x.probe_changes(&x.drift(&rises)), d.tool_mm)
        .unwrap_or_else(|e| panic!("{e:?}"));
    fitted / tip.z_um
}

fn rel_err(got: f64, want: f64) -> f64 {
    (got / want - 1.0).abs()
}

#[test]
fn recovers_known_factors_and_predicts_the_held_out_part() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let real = real_run(dir.path());
    let data = Measured::read(&real, Some(UNTIL_S)).unwrap_or_else(|e| panic!("{e:#}"));
    let base = Machine::default_machine();
    let cal = calibrate::calibrate(&base, &data, &CalibrateOptions::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let v = calibrate::values(&cal.theta);
    let (heat, exponent, capacity, g_amb) = (v[0], v[1], v[2], v[3]);
    let expansion = expansion_factor(&cal.machine);
    eprintln!(
        "recovered heat {heat:.4} exponent {exponent:.4} capacity {capacity:.4} g_ambient {g_amb:.4} expansion {expansion:.4}; {} iterations, {:?}, {:.1} s",
        cal.iterations, cal.reason, cal.elapsed_s
    );
    // The data come from the model class itself, so only the noise (0.02 K
    // on each of 10 sensors, 0.1 um on the probes, ~1 200 rows) limits the
    // estimate: the heat factor sets the temperature rises (sensor gain is
    // 1), a few 0.1 % on rises of ~10 K; 2 % leaves room for the
    // correlation with the ambient conductance, which shares the
    // equilibrium level.
    assert!(rel_err(heat, HEAT) < 0.02, "heat {heat}");
    // Capacity sets the time constants, seen in ~15 speed changes; 2 %.
    assert!(rel_err(capacity, CAPACITY) < 0.02, "capacity {capacity}");
    // The truth is 1 (unperturbed); 10 %: the ambient conductance carries
    // 7 % of the heat at equilibrium, so it is the least identified.
    assert!(rel_err(g_amb, 1.0) < 0.10, "g_ambient {g_amb}");
    // The default exponent 1.6 is the truth: 0.05 (it is seen through four
    // speed levels only).
    assert!((exponent - 1.6).abs() < 0.05, "exponent {exponent}");
    // dz is fitted on the calibrated rises, so its error is the heat's
    // plus the probe noise: 3 %.
    assert!(
        rel_err(expansion, EXPANSION) < 0.03,
        "expansion {expansion}"
    );
    assert!(cal.reason != "iteration limit", "{}", cal.reason);
    // Sensors found at their true places: T1 front bearing, T3 motor, T5
    // structure.
    let names = &cal.machine.sensors.names;
    let site = |n: &str| {
        let i = names.iter().position(|x| x == n).unwrap_or(usize::MAX);
        cal.machine.sensors.sites[i]
    };
    for (name, node) in [
        ("T1", Node::FrontBearing),
        ("T3", Node::Motor),
        ("T5", Node::Structure),
    ] {
        let s = site(name);
        let at = |p| s.node == machine::Site::Node(p) && (s.share < 0.05 || s.toward == s.node);
        let at_b = s.toward == machine::Site::Node(node) && s.share > 0.95;
        assert!(at(node) || at_b, "{name}: {s:?}");
    }
    // Held-out fit of dz: the twin is the truth up to the factors, so the
    // held-out error is near the probe noise (0.1 um per probe, ~0.15 um
    // on dz); 0.5 um leaves room for a 1 % factor error on ~40 um.
    let dz = cal
        .channels
        .iter()
        .find(|c| c.name == "dz_um")
        .unwrap_or_else(|| panic!("no dz_um fit"));
    let rest = dz.rest.unwrap_or_else(|| panic!("no held-out part"));
    eprintln!("dz_um: calibration {:?}, rest {rest:?}", dz.calibration);
    assert!(rest.rmse < 0.5, "{rest:?}");
    assert!(rest.fit_pct > 95.0, "{rest:?}");
}

#[test]
fn calibrated_machine_round_trips_through_simulate_and_diagnose() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let real = real_run(dir.path());
    // A short calibration is enough here: this test is about the files.
    let short = dir.path().join("short.csv");
    let text = std::fs::read_to_string(&real).unwrap_or_default();
    let lines: Vec<&str> = text.lines().take(601).collect();
    std::fs::write(&short, lines.join("\n") + "\n").unwrap_or_else(|e| panic!("{e}"));
    let cal = dir.path().join("cal.toml");
    let sim1 = dir.path().join("sim1.csv");
    let v = ok_json(&[
        "simulate",
        "--calibrate",
        p(&short),
        "--save-machine",
        p(&cal),
        "--out",
        p(&sim1),
        "--json",
    ]);
    for key in ["channels", "params", "iterations", "converged", "seconds"] {
        assert!(v.get(key).is_some(), "{key} missing: {v}");
    }
    assert!(v["channels"]["dz_um"]["calibration"]["fit_pct"].is_number());
    assert_eq!(v["params"]["heat_factor"]["unit"], "x");
    // The saved file loads, and simulating with it gives the same run.
    let m = Machine::load(&cal).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(m.outputs.len(), 3);
    let sim2 = dir.path().join("sim2.csv");
    let profile = format!("file:{}", p(&short));
    ok(&[
        "simulate",
        "--machine",
        p(&cal),
        "--profile",
        &profile,
        "--out",
        p(&sim2),
    ]);
    let (a, b) = (
        std::fs::read_to_string(&sim1).unwrap_or_default(),
        std::fs::read_to_string(&sim2).unwrap_or_default(),
    );
    assert!(!a.is_empty() && a == b, "the two runs differ");
    // Same column names as the real run, each once.
    let header = a.lines().next().unwrap_or_default();
    let cols: Vec<&str> = header.split(',').collect();
    for c in ["T1", "T9", "dx_um", "dy_um", "dz_um"] {
        assert_eq!(
            cols.iter().filter(|x| **x == c).count(),
            1,
            "{c} in {header}"
        );
    }
    // diagnose compares the mapped columns directly.
    let d = ok_json(&["diagnose", "--sim", p(&sim2), "--real", p(&short), "--json"]);
    assert!(
        d["gap"]["dz_um"]["rms"].as_f64().unwrap_or(f64::NAN) < 1.0,
        "{d}"
    );
}

#[test]
fn diagnose_compares_any_um_column_both_files_share() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (sim, real) = (dir.path().join("s.csv"), dir.path().join("r.csv"));
    let mut s = String::from("t_s,speed_rpm,ch3_um,T1,S1\n");
    let mut r = String::from("t_s,speed_rpm,ch3_um,T1,other_um_x\n");
    for k in 0..40 {
        s.push_str(&format!("{},1000,{},20,0\n", k * 60, -0.1 * k as f64));
        r.push_str(&format!("{},1000,{},20,1\n", k * 60, -0.12 * k as f64));
    }
    std::fs::write(&sim, s).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(&real, r).unwrap_or_else(|e| panic!("{e}"));
    let al = host_tools::diagnose::align::read(&sim, &real).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(al.channels.names(), ["ch3_um", "T1"]);
    assert!(al.channels.is_displacement(0));
    assert!((al.channels.load(0).resid[10] + 0.2).abs() < 1e-12);
}

#[test]
fn bad_inputs_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let cal = dir.path().join("cal.toml");
    let write = |name: &str, text: &str| {
        let f = dir.path().join(name);
        std::fs::write(&f, text).unwrap_or_else(|e| panic!("{e}"));
        f
    };
    let calibrate = |f: &Path, extra: &[&str]| {
        let mut args = vec!["simulate", "--calibrate", p(f), "--save-machine", p(&cal)];
        args.extend_from_slice(extra);
        fails_one_line(&args)
    };
    let e = calibrate(&dir.path().join("missing.csv"), &[]);
    assert!(e.contains("missing.csv"), "{e}");
    let mut rows = String::from("t_s,speed_rpm,dz_um,T1\n");
    for k in 0..80 {
        rows.push_str(&format!("{},1000,{},20\n", k * 60, -0.1 * k as f64));
    }
    let bad = write("bad.csv", &rows.replacen("1000,-0.2,", "1000,abc,", 1));
    let e = calibrate(&bad, &[]);
    assert!(e.contains("bad.csv:4:3"), "{e}");
    let good = write("good.csv", &rows);
    let e = calibrate(&good, &["--calibrate-until-s", "600"]);
    assert!(e.contains("at least 30"), "{e}");
    // Nothing before it: said so (it blamed a spindle that does turn).
    let e = calibrate(&good, &["--calibrate-until-s", "-5"]);
    assert!(e.contains("no row before --calibrate-until-s -5"), "{e}");
    let empty = write("empty.csv", "t_s,speed_rpm,dz_um\n");
    let e = calibrate(&empty, &[]);
    assert!(e.contains("no data rows"), "{e}");
    let e = calibrate(&good, &["--hours", "1"]);
    assert!(e.contains("do not apply"), "{e}");
    let none = write("none.csv", &rows.replace("dz_um,T1", "a,b"));
    let e = calibrate(&none, &[]);
    assert!(e.contains("no displacement"), "{e}");
    // A spindle that never turns: nothing to calibrate the heat to (this
    // used to panic in nalgebra's SVD of an empty matrix).
    let still = write("still.csv", &rows.replace(",1000,", ",0,"));
    let e = calibrate(&still, &[]);
    assert_eq!(
        e,
        format!(
            "error: {}: speed_rpm is 0 on every row before --calibrate-until-s 2370: nothing \
             heats the twin there, so nothing can be calibrated\n",
            p(&still)
        )
    );
    // --calibrate without --save-machine is a usage error (clap: several
    // lines), but never a panic, and nothing is written.
    let out = common::run(&["simulate", "--calibrate", p(&good)]);
    assert!(!out.status.success());
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
    // So is a speed profile or sample time: the run file sets both.
    for extra in [["--profile", "spectrum"], ["--dt-s", "10"]] {
        let mut args = vec![
            "simulate",
            "--calibrate",
            p(&good),
            "--save-machine",
            p(&cal),
        ];
        args.extend_from_slice(&extra);
        let out = common::run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains("cannot be used with"),
            "{err}"
        );
        assert!(!cal.exists(), "nothing written");
    }
    // Machine files: bad output node, duplicate column names.
    let text = format!(
        "{DEFAULT_MACHINE_TOML}\n[[output]]\nname = \"ch1_um\"\num_per_k = {{ shaftt = 1.0 }}\n"
    );
    let e = machine::parse("m.toml", &text)
        .err()
        .map(|e| format!("{e:#}"));
    assert!(
        e.as_deref()
            .is_some_and(|e| e.starts_with("m.toml:") && e.contains("shaftt")),
        "{e:?}"
    );
    let text = DEFAULT_MACHINE_TOML.replacen(
        "node = \"front_bearing\"\n",
        "node = \"front_bearing\"\nname = \"T2\"\n",
        1,
    );
    let e = machine::parse("m.toml", &text)
        .err()
        .map(|e| format!("{e:#}"));
    assert!(
        e.as_deref().is_some_and(|e| e.contains("given twice")),
        "{e:?}"
    );
}

/// `--calibrate-until-s` past the last row holds nothing out: the table
/// says so and shows "-" where the rest's figures would be (it printed NaN),
/// and a parameter that ends on a bound is marked as the bound's answer
/// (this run's flat T1 and straight-line dz pin few of them), in the text
/// as in the JSON's `at_bound`.
#[test]
fn nothing_held_out_and_parameters_on_a_bound_are_said() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let mut rows = String::from("t_s,speed_rpm,dz_um,T1\n");
    for k in 0..80 {
        rows.push_str(&format!("{},1000,{},20\n", k * 60, -0.1 * k as f64));
    }
    let run = common::write(dir.path(), "run.csv", &rows);
    let cal = dir.path().join("cal.toml");
    let args = [
        "simulate",
        "--calibrate",
        &run,
        "--save-machine",
        p(&cal),
        "--calibrate-until-s",
        "1e9",
    ];
    let (_, err) = ok(&args);
    assert!(!err.contains("NaN"), "{err}");
    assert!(err.contains("nothing held out"), "{err}");
    let mut json_args = args.to_vec();
    json_args.push("--json");
    let v = ok_json(&json_args);
    let params = v["params"].as_object().unwrap();
    let on_bound: Vec<&String> = params
        .iter()
        .filter(|(_, x)| x["at_bound"] == true)
        .map(|(k, _)| k)
        .collect();
    let marked = err.matches("bound: the run did not pin it").count();
    assert_eq!(marked, on_bound.len(), "{on_bound:?}\n{err}");
    // Three here (bearing_exponent, capacity_factor, g_ambient_factor).
    assert!(marked >= 1, "{err}");
    for name in on_bound {
        let line = err.lines().find(|l| l.contains(name.as_str())).unwrap();
        assert!(line.contains("bound: the run did not pin it"), "{line}");
    }
}
