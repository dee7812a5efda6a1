//! The thermal twin (`thermcomp simulate`): discretisation against closed
//! forms and RK4, energy balance, the default machine's figures, each effect
//! changing what it should and nothing else, reproducibility, machine-file
//! errors and run-file profiles.

use host_tools::simulate::write_run;
use host_tools::twin::effects::{Coolant, Effect, EffectSet};
use host_tools::twin::integrate::{zoh, Discrete, Stepper};
use host_tools::twin::machine::{self, Machine, Node, DEFAULT_MACHINE_TOML, N_NODES};
use host_tools::twin::network::{self, Input, Network, State, U_AMBIENT, U_COOLANT};
use host_tools::twin::profile::{schedule, Profile, Schedule};
use host_tools::twin::sim::{self, SimOptions, Summary};
use nalgebra::DMatrix;

/// Every column of a run, kept in memory.
#[derive(Debug, Default, Clone, PartialEq)]
struct Cols {
    t_s: Vec<f64>,
    speed: Vec<f64>,
    power: Vec<f64>,
    ambient: Vec<f64>,
    coolant: Vec<f64>,
    temps: Vec<Vec<f64>>,
    probes: Vec<[f64; 5]>,
    dxyz: Vec<[f64; 3]>,
    nodes: Vec<State>,
    dz_true: Vec<f64>,
}

fn simulate(m: &Machine, s: &Schedule, effects: EffectSet, seed: u64) -> (Cols, Summary) {
    let mut c = Cols::default();
    let opts = SimOptions {
        effects,
        seed,
        sensors: None,
    };
    let summary = sim::run(m, s, &opts, |r| {
        c.t_s.push(r.t_s);
        c.speed.push(r.speed_rpm);
        c.power.push(r.power_kw);
        c.ambient.push(r.ambient_c);
        c.coolant.push(r.coolant_c);
        c.temps.push(r.temps_c.to_vec());
        c.probes.push(r.probes_um);
        c.dxyz.push([r.dx_um, r.dy_um, r.dz_um]);
        c.nodes.push(*r.nodes_c);
        c.dz_true.push(r.dz_true_um);
        Ok(())
    });
    (c, summary.unwrap_or_else(|e| panic!("simulate: {e:#}")))
}

fn sched(p: Profile, hours: f64, dt_s: f64) -> Schedule {
    schedule(&p, 12000.0, Some(hours), dt_s, 1).unwrap_or_else(|e| panic!("{e:#}"))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

#[test]
fn zoh_matches_the_two_node_closed_form() {
    // Two equal nodes C, each with g to ground, joined by G; heat into node 1.
    // Modes: sum (lambda1 = -g/C) and difference (lambda2 = -(g + 2G)/C).
    let (c, g, gg, dt) = (2000.0, 4.0, 15.0, 13.0);
    let a = DMatrix::from_row_slice(2, 2, &[-(g + gg) / c, gg / c, gg / c, -(g + gg) / c]);
    let b = DMatrix::from_row_slice(2, 1, &[1.0 / c, 0.0]);
    let (phi, gamma) = zoh(&a, &b, dt);
    let (l1, l2) = (-g / c, -(g + 2.0 * gg) / c);
    let (e1, e2) = ((l1 * dt).exp(), (l2 * dt).exp());
    let (i1, i2) = ((l1 * dt).exp_m1() / l1, (l2 * dt).exp_m1() / l2);
    let phi_x = [0.5 * (e1 + e2), 0.5 * (e1 - e2)];
    let gamma_x = [0.5 / c * (i1 + i2), 0.5 / c * (i1 - i2)];
    for (got, want) in [
        (phi[(0, 0)], phi_x[0]),
        (phi[(1, 1)], phi_x[0]),
        (phi[(0, 1)], phi_x[1]),
        (phi[(1, 0)], phi_x[1]),
        (gamma[(0, 0)], gamma_x[0]),
        (gamma[(1, 0)], gamma_x[1]),
    ] {
        assert!(rel(got, want) <= 1e-12, "{got} vs {want}");
    }
}

#[test]
fn exact_steps_match_a_fine_rk4_of_the_full_network() {
    // One hour of the default network: 10 000 rpm for 30 min, then 4000 rpm
    // with ambient 1 K up and coolant 0.5 K down. Exact steps of 60 s against
    // RK4 at 0.25 s (the fastest mode is ~15 s, so RK4's error is ~1e-10 K).
    let m = Machine::default_machine();
    let net = Network::new(&m);
    let input = |rpm: f64, ta: f64, tc: f64| {
        let mut u = Input::zeros();
        for (i, q) in network::speed_heat_w(&m.heat, rpm).iter().enumerate() {
            u[i] = *q;
        }
        u[U_AMBIENT] = ta;
        u[U_COOLANT] = tc;
        u
    };
    let phases = [
        (1800.0, input(10000.0, 20.0, 20.0)),
        (1800.0, input(4000.0, 21.0, 19.5)),
    ];
    let x0 = State::repeat(20.0);
    let d = Discrete::new(&net, 60.0);
    let mut exact = x0;
    let mut rk = x0;
    let h = 0.25;
    for (dur, u) in &phases {
        for _ in 0..(dur / 60.0) as usize {
            exact = d.step(&exact, u);
        }
        for _ in 0..(dur / h) as usize {
            let k1 = net.derivative(&rk, u);
            let k2 = net.derivative(&(rk + k1 * (h / 2.0)), u);
            let k3 = net.derivative(&(rk + k2 * (h / 2.0)), u);
            let k4 = net.derivative(&(rk + k3 * h), u);
            rk += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
        }
    }
    let err = (exact - rk).amax();
    assert!(err < 1e-6, "max |exact - rk4| = {err} K");
    assert!((exact - x0).amax() > 1.0, "the run should have heated up");
}

#[test]
fn stepper_rediscretises_only_when_dt_changes() {
    let net = Network::new(&Machine::default_machine());
    let mut s = Stepper::new(net.clone());
    let u = Input::zeros();
    let mut x = State::repeat(25.0);
    for _ in 0..100 {
        x = s.step(&x, &u, 1.0);
    }
    assert_eq!(s.cached(), 1);
    x = s.step(&x, &u, 2.5);
    let y = s.step(&x, &u, 1.0);
    assert_eq!(s.cached(), 2);
    // Same as a fresh discretisation.
    assert_eq!(y, Discrete::new(&net, 1.0).step(&x, &u));
}

#[test]
fn steady_state_heat_in_equals_heat_out() {
    let m = Machine::default_machine();
    let net = Network::new(&m);
    for (rpm, ta, tc) in [
        (2000.0, 20.0, 20.0),
        (10000.0, 22.5, 18.0),
        (12000.0, 17.0, 21.0),
    ] {
        let mut u = Input::zeros();
        for (i, q) in network::speed_heat_w(&m.heat, rpm).iter().enumerate() {
            u[i] = *q;
        }
        u[U_AMBIENT] = ta;
        u[U_COOLANT] = tc;
        let x = net.steady_state(&u);
        let (generated, out) = net.heat_balance(&x, &u);
        assert!(
            rel(out, generated) < 1e-9,
            "{rpm}: in {generated} W, out {out} W"
        );
        // And it is an equilibrium of the dynamics: |dT/dt| tiny relative to
        // the heating rate at the cold start.
        let cold_rate = net.derivative(&State::repeat(ta), &u).amax();
        assert!(net.derivative(&x, &u).amax() < 1e-9 * cold_rate);
    }
}

#[test]
fn default_machine_reaches_equilibrium_in_4_to_7_hours() {
    let m = Machine::default_machine();
    let (c, s) = simulate(
        &m,
        &sched(Profile::Constant(10000.0), 24.0, 10.0),
        EffectSet::none(),
        1,
    );
    let eq = s
        .equilibrium
        .clone()
        .unwrap_or_else(|| panic!("no equilibrium in {s:?}"));
    let t95_dz_h = eq.t95_s.unwrap_or(f64::NAN) / 3600.0;
    assert!((4.0..=7.0).contains(&t95_dz_h), "dz t95 {t95_dz_h} h");
    // Every node within 5 % of its own equilibrium rise.
    let net = Network::new(&m);
    let mut u = Input::zeros();
    for (i, q) in network::speed_heat_w(&m.heat, 10000.0).iter().enumerate() {
        u[i] = *q;
    }
    u[U_AMBIENT] = 20.0;
    u[U_COOLANT] = 20.0;
    let xs = net.steady_state(&u);
    let mut slowest_h: f64 = 0.0;
    for i in 0..N_NODES {
        let rise = xs[i] - 20.0;
        let last_out = c
            .nodes
            .iter()
            .rposition(|x| (x[i] - xs[i]).abs() > 0.05 * rise);
        slowest_h = slowest_h.max(last_out.map_or(0.0, |k| c.t_s[k + 1]) / 3600.0);
    }
    assert!(
        (4.0..=7.0).contains(&slowest_h),
        "all nodes t95 {slowest_h} h"
    );
    // Magnitudes: dz tens of um (towards the workpiece: negative), rises of a
    // few to ~12 K, dx/dy a few um.
    assert!((-60.0..=-20.0).contains(&eq.dz_um), "dz {}", eq.dz_um);
    assert!(
        (3.0..=12.5).contains(&s.max_rise_c.0),
        "rise {:?}",
        s.max_rise_c
    );
    assert!(s.max_abs_dx_um > 0.5 && s.max_abs_dx_um < 10.0, "{s:?}");
    assert!(s.max_abs_dy_um > 0.5 && s.max_abs_dy_um < 10.0, "{s:?}");
    // The slowest mode: 1-3 h (t95 of a first-order lag is 3 tau).
    assert!((3600.0..10800.0).contains(&s.slowest_time_constant_s));
}

/// Runs the nominal twin and the twin with one effect on, same seed.
fn nominal_and(e: Effect, p: Profile) -> (Cols, Cols) {
    let m = Machine::default_machine();
    let s = sched(p, 24.0, 10.0);
    let (a, _) = simulate(&m, &s, EffectSet::none(), 9);
    let (b, _) = simulate(&m, &s, EffectSet::none().with(e), 9);
    (a, b)
}

fn differs(a: &[f64], b: &[f64]) -> bool {
    a.iter().zip(b).any(|(x, y)| (x - y).abs() > 1e-6)
}

fn temp(c: &Cols, i: usize) -> Vec<f64> {
    c.temps.iter().map(|t| t[i]).collect()
}

#[test]
fn ambient_moves_ambient_and_temperatures_only() {
    let (a, b) = nominal_and(Effect::Ambient, Profile::Steps);
    assert_eq!(
        (&a.t_s, &a.speed, &a.power, &a.coolant),
        (&b.t_s, &b.speed, &b.power, &b.coolant)
    );
    let span = |v: &[f64]| {
        v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
    };
    // The nominal room is constant; its sensor reads it with noise only
    // (0.02 K one sigma: a span of a few sigma over a day's samples).
    let noise = Machine::default_machine().sensors.noise_c;
    assert!(span(&a.ambient) < 12.0 * noise, "{}", span(&a.ambient));
    // +/-1.5 K day/night plus drift and doors: a span of 2-5 K over a day.
    assert!(
        (2.0..5.0).contains(&span(&b.ambient)),
        "{}",
        span(&b.ambient)
    );
    assert!(differs(&temp(&a, 4), &temp(&b, 4)), "structure sensor");
    assert!(differs(&a.dz_true, &b.dz_true));
}

#[test]
fn coolant_oscillates_with_the_period_its_hysteresis_implies() {
    let (a, b) = nominal_and(Effect::Coolant, Profile::Steps);
    assert_eq!(
        (&a.speed, &a.power, &a.ambient),
        (&b.speed, &b.power, &b.ambient)
    );
    let p = Machine::default_machine().effects.coolant;
    // Upward crossings of the upper quarter after a visit to the lower
    // one: the supply's sensor noise (0.02 K) cannot count a crossing twice
    // across a band of half the hysteresis.
    let (lo, hi) = (
        p.low_c + 0.25 * (p.high_c - p.low_c),
        p.high_c - 0.25 * (p.high_c - p.low_c),
    );
    let mut armed = false;
    let mut ups = Vec::new();
    for (k, &c) in b.coolant.iter().enumerate() {
        if c < lo {
            armed = true;
        } else if armed && c >= hi {
            armed = false;
            ups.push(b.t_s[k]);
        }
    }
    assert!(ups.len() > 10, "{ups:?}");
    let period = (ups[ups.len() - 1] - ups[0]) / (ups.len() - 1) as f64;
    let want = Coolant::period_s(&p);
    assert!(rel(period, want) < 0.10, "period {period} s vs {want} s");
    assert!((20.0 * 60.0..=40.0 * 60.0).contains(&want));
    assert!(differs(&temp(&a, 5), &temp(&b, 5)), "coolant return sensor");
}

#[test]
fn cutting_adds_power_and_heat_only() {
    let (a, b) = nominal_and(Effect::Cutting, Profile::Steps);
    assert_eq!(
        (&a.speed, &a.ambient, &a.coolant),
        (&b.speed, &b.ambient, &b.coolant)
    );
    // Load only while the spindle turns.
    for k in 0..a.speed.len() {
        let extra = b.power[k] - a.power[k];
        if a.speed[k] == 0.0 {
            assert!(extra.abs() < 1e-12);
        } else {
            assert!(extra >= 0.0);
        }
    }
    assert!(differs(&a.power, &b.power));
    let k = a.dz_true.len() * 3 / 4;
    assert!(
        b.dz_true[k] < a.dz_true[k],
        "more heat, more growth towards -Z"
    );
}

#[test]
fn motor_loss_acts_below_the_knee_only() {
    let (a, b) = nominal_and(Effect::MotorLoss, Profile::Steps);
    let knee = Machine::default_machine().effects.motor_loss.knee_rpm;
    assert_eq!(
        (&a.speed, &a.ambient, &a.coolant),
        (&b.speed, &b.ambient, &b.coolant)
    );
    for k in 0..a.speed.len() {
        let extra = b.power[k] - a.power[k];
        if a.speed[k] > 0.0 && a.speed[k] < knee {
            assert!(extra > 0.0);
        } else {
            assert!(extra.abs() < 1e-12, "{} rpm: {extra}", a.speed[k]);
        }
    }
    assert!(differs(&temp(&a, 2), &temp(&b, 2)), "motor sensor");
}

#[test]
fn sensor_lag_delays_the_part_sensors_only() {
    let (a, b) = nominal_and(Effect::SensorLag, Profile::Steps);
    // Displacements, probes, boundaries and boundary sensors untouched.
    assert_eq!(
        (&a.probes, &a.dxyz, &a.nodes),
        (&b.probes, &b.dxyz, &b.nodes)
    );
    assert_eq!((temp(&a, 6), temp(&a, 7)), (temp(&b, 6), temp(&b, 7)));
    // During the warm-up the lagged motor sensor reads low; after the stop
    // (last quarter) it reads high. Noise cancels in the difference (same seed).
    let (t1a, t1b) = (temp(&a, 2), temp(&b, 2));
    let n = t1a.len();
    let early = n / 10 + 30; // 5 min after the second speed step (2.4 h)
    assert!(
        t1b[early] < t1a[early] - 0.05,
        "{} {}",
        t1b[early],
        t1a[early]
    );
    let after_stop = n * 3 / 4 + 30; // 5 min after the stop
    assert!(t1b[after_stop] > t1a[after_stop] + 0.05);
}

#[test]
fn same_seed_same_file_other_seed_other_file() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let m = Machine::default_machine();
    let s = schedule(&Profile::Spectrum, m.max_rpm, Some(6.0), 5.0, 4)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let opts = |seed| SimOptions {
        effects: EffectSet::parse("ambient,coolant,cutting").unwrap_or_default(),
        seed,
        sensors: Some(6),
    };
    let mut bytes = Vec::new();
    for (name, seed) in [("a.csv", 4), ("b.csv", 4), ("c.csv", 5)] {
        let p = dir.path().join(name);
        write_run(&m, &s, &opts(seed), &p).unwrap_or_else(|e| panic!("{e:#}"));
        bytes.push(std::fs::read(&p).unwrap_or_default());
    }
    assert!(!bytes[0].is_empty());
    assert_eq!(bytes[0], bytes[1]);
    assert_ne!(bytes[0], bytes[2]);
    let text = String::from_utf8_lossy(&bytes[0]);
    assert_eq!(
        text.lines().next(),
        Some("t_s,speed_rpm,power_kw,ambient_c,coolant_c,tool_mm,T1,T2,T3,T4,T5,T6,S1,S2,S3,S4,S5,dx_um,dy_um,dz_um")
    );
}

#[test]
fn unknown_machine_field_names_file_line_and_column() {
    let text = DEFAULT_MACHINE_TOML.replacen(
        "c_j_per_k = 8000.0",
        "c_j_per_k = 8000.0\nmass_kg = 17.0",
        1,
    );
    let line = text
        .lines()
        .position(|l| l.starts_with("mass_kg"))
        .map(|i| i + 1);
    let e = machine::parse("my.toml", &text)
        .err()
        .map(|e| format!("{e:#}"))
        .unwrap_or_default();
    assert_eq!(
        e.split(": ").next(),
        Some(format!("my.toml:{}:1", line.unwrap_or(0)).as_str()),
        "{e}"
    );
    assert!(e.contains("unknown field `mass_kg`"), "{e}");
    assert!(!e.contains('\n'));
}

#[test]
fn run_file_profile_reproduces_its_speed_and_power() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let m = Machine::default_machine();
    let src = dir.path().join("src.csv");
    // An irregular grid: 7 s and 13 s steps alternating.
    let mut csv = String::from("t_s,speed_rpm,power_kw,note\n");
    let mut t = 0.0;
    let mut speeds = Vec::new();
    for k in 0..2000 {
        let rpm = [0.0, 3000.0, 9000.0, 6000.0][(k / 300) % 4];
        speeds.push(rpm);
        csv.push_str(&format!("{t},{rpm},{},x\n", rpm / 1000.0));
        t += if k % 2 == 0 { 7.0 } else { 13.0 };
    }
    std::fs::write(&src, csv).unwrap_or_else(|e| panic!("{e}"));
    let s = schedule(&Profile::File(src.clone()), m.max_rpm, None, 1.0, 0)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let (c, _) = simulate(&m, &s, EffectSet::none(), 0);
    assert_eq!(c.speed, speeds);
    assert_eq!(
        c.power
            .iter()
            .map(|p| p * 1000.0)
            .map(f64::round)
            .collect::<Vec<_>>(),
        speeds
    );
    assert_eq!(c.t_s.len(), 2000);
    assert_eq!(c.t_s[3], 27.0);
    // `--hours` cuts the file.
    let s = schedule(&Profile::File(src), m.max_rpm, Some(1.0), 1.0, 0)
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(*s.t_s.last().unwrap_or(&-1.0), 3600.0);
}

#[test]
fn every_node_is_reported_in_state_order() {
    assert_eq!(Node::ALL.len(), N_NODES);
    for (i, n) in Node::ALL.iter().enumerate() {
        assert_eq!(n.index(), i);
        assert_eq!(Node::from_name(n.name()), Some(*n));
    }
}

/// The twin's file is a run file the rest of `thermcomp` takes: simulate a
/// day on a speed spectrum, fit an MLR of dz on the first 12 h, score the
/// rest. The nominal twin's dz is a linear function of its node
/// temperatures and the sensors sit on those nodes, so a linear model must
/// explain nearly all of it: measured 99.3 % held-out reduction (seed 1);
/// 95 % leaves room for other seeds and sensor noise.
#[test]
fn simulate_writes_a_run_that_fit_and_eval_take() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("sim.csv");
    let blob = dir.path().join("m.bin");
    let run_s = run.to_str().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_thermcomp"))
        .args([
            "simulate",
            "--out",
            run_s,
            "--hours",
            "24",
            "--profile",
            "spectrum",
        ])
        .args(["--seed", "1", "--dt-s", "10", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(summary["rows"], 8641);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_thermcomp"))
        .args([
            "fit", "--data", run_s, "--target", "dz_um", "--model", "mlr",
        ])
        .args(["--holdout-from-s", "43200", "--json", "--out"])
        .arg(&blob)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let fit: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let red = fit["targets"]["dz_um"]["holdout"]["reduction_pct"]
        .as_f64()
        .unwrap();
    assert!(red > 95.0, "held-out reduction {red} %");
}
