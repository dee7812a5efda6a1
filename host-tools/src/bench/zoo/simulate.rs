//! One run of a zoo plant: the network driven by speed and cutting power
//! through its heat laws, with the run's air and coolant ([`Setup`]), then
//! read by the sensors and the displacement axes.
//!
//! Row k reports the state at `t_k`; the inputs of row k are held until
//! `t_(k+1)`. The run starts from the equilibrium at rest with the first
//! row's air and coolant; the displacements are measured from there. A
//! cycling chiller is advanced sub-step by sub-step with the heat the nodes
//! give to the coolant, so its period follows the machine's load.

use super::effects::{Lag, Setup};
use super::integrate::{substeps, Rk4};
use super::noise::Gauss;
use super::plant::Plant;
use super::sensors::{add_noise, lagged};
use super::table::RunTable;
use anyhow::{bail, Result};

/// What drives a run.
#[derive(Debug, Clone, Copy)]
pub struct Drive<'a> {
    /// Time, s.
    pub t_s: &'a [f64],
    /// Spindle speed, rpm.
    pub speed_rpm: &'a [f64],
    /// Cutting power the heat laws see, kW.
    pub cut_kw: &'a [f64],
}

/// The state on every row.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Node temperatures per row, deg C.
    pub x: Vec<Vec<f64>>,
    /// Air per row, deg C.
    pub ambient_c: Vec<f64>,
    /// Coolant supply per row, deg C.
    pub coolant_c: Vec<f64>,
}

/// Heat into each node at `rpm`, `cut_kw` and state `x`, W.
fn heat_w(plant: &Plant, setup: &Setup, rpm: f64, cut_kw: f64, x: &[f64], q: &mut [f64]) {
    q.fill(0.0);
    plant.laws.add_heat_w(rpm, cut_kw, x, q);
    setup.extra.add_heat_w(rpm, cut_kw, q);
}

/// Runs `plant` over `drive` with `setup` (whose chiller, if any, advances).
pub fn simulate(plant: &Plant, drive: &Drive, setup: &mut Setup) -> Result<Trace> {
    let n = drive.t_s.len();
    if n < 2 || drive.speed_rpm.len() != n || drive.cut_kw.len() != n {
        bail!("a zoo run needs >= 2 rows and one speed and cutting power per row");
    }
    let net = &plant.net;
    let rate = net.max_rate_per_s();
    let t0 = drive.t_s[0];
    let mut x = net.steady_state(
        &vec![0.0; net.len()],
        setup.ambient.at(0.0),
        setup.coolant.temp_c(),
    )?;
    let mut trace = Trace {
        x: Vec::with_capacity(n),
        ambient_c: Vec::with_capacity(n),
        coolant_c: Vec::with_capacity(n),
    };
    let mut rk = Rk4::new(net.len());
    let mut q = vec![0.0; net.len()];
    for k in 0..n {
        let t = drive.t_s[k] - t0;
        trace.x.push(x.clone());
        trace.ambient_c.push(setup.ambient.at(t));
        trace.coolant_c.push(setup.coolant.temp_c());
        let Some(&t_next) = drive.t_s.get(k + 1) else {
            break;
        };
        let dt = t_next - drive.t_s[k];
        let m = substeps(dt, rate);
        let h = dt / m as f64;
        let (rpm, cut) = (drive.speed_rpm[k], drive.cut_kw[k]);
        for j in 0..m {
            let tc = setup.coolant.temp_c();
            let mut f = |ts: f64, xs: &[f64], dx: &mut [f64]| {
                heat_w(plant, setup, rpm, cut, xs, &mut q);
                net.net_heat_w(xs, &q, setup.ambient.at(ts), tc, dx);
                for (d, nd) in dx.iter_mut().zip(&net.nodes) {
                    *d /= nd.c_j_per_k;
                }
            };
            rk.step(&mut f, t + j as f64 * h, &mut x, h);
            let load = net.coolant_load_w(&x, tc);
            setup.coolant.advance(h, load);
        }
    }
    Ok(trace)
}

/// The logged inputs of a run.
#[derive(Debug, Clone, Copy)]
pub struct Logged<'a> {
    /// Time, s.
    pub t_s: &'a [f64],
    /// Spindle speed, rpm.
    pub speed_rpm: &'a [f64],
    /// Spindle power as logged, kW.
    pub power_kw: &'a [f64],
}

/// Noise-free temperature readings T1..Tn: each sensor's site through its
/// time constant (a lagging sensor's through the lag, with some air).
pub fn temperatures(plant: &Plant, t_s: &[f64], trace: &Trace, lag: Option<&Lag>) -> Vec<Vec<f64>> {
    plant
        .sensors
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let poor = lag.filter(|l| l.sensors.contains(&i));
            let air = poor.map_or(0.0, |l| l.air_share);
            let site: Vec<f64> = (0..t_s.len())
                .map(|k| {
                    let (ta, tc) = (trace.ambient_c[k], trace.coolant_c[k]);
                    (1.0 - air) * s.site_c(&trace.x[k], ta, tc) + air * ta
                })
                .collect();
            lagged(t_s, &site, poor.map_or(s.tau_s, |l| l.tau_s))
        })
        .collect()
}

/// Noise-free displacements: each axis's combination of node rises.
pub fn displacements(plant: &Plant, trace: &Trace) -> Vec<Vec<f64>> {
    let x0 = &trace.x[0];
    plant
        .axes
        .iter()
        .map(|a| {
            trace
                .x
                .iter()
                .map(|x| {
                    a.um_per_k
                        .iter()
                        .zip(x.iter().zip(x0))
                        .map(|(c, (xi, x0i))| c * (xi - x0i))
                        .sum()
                })
                .collect()
        })
        .collect()
}

/// The run file of a trace: inputs, boundaries, T1..Tn, displacements;
/// with `noise` (the real machine) every measured channel gets its noise
/// and drift.
pub fn readings(
    plant: &Plant,
    logged: &Logged,
    trace: &Trace,
    lag: Option<&Lag>,
    noise: Option<&mut Gauss>,
) -> RunTable {
    let t_s = logged.t_s;
    let dt = if t_s.len() > 1 { t_s[1] - t_s[0] } else { 1.0 };
    let mut ambient = trace.ambient_c.clone();
    let mut coolant = trace.coolant_c.clone();
    let mut temps = temperatures(plant, t_s, trace, lag);
    let mut disps = displacements(plant, trace);
    if let Some(g) = noise {
        let nz = &plant.noise;
        for v in ambient.iter_mut().chain(coolant.iter_mut()) {
            *v += nz.boundary_c * g.normal();
        }
        temps.iter_mut().for_each(|c| add_noise(c, dt, &nz.temp, g));
        disps.iter_mut().for_each(|c| add_noise(c, dt, &nz.disp, g));
    }
    let mut table = RunTable::default();
    table.push("t_s", t_s.to_vec(), 1);
    table.push("speed_rpm", logged.speed_rpm.to_vec(), 1);
    table.push("power_kw", logged.power_kw.to_vec(), 3);
    table.push("ambient_c", ambient, 3);
    table.push("coolant_c", coolant, 3);
    for (i, c) in temps.into_iter().enumerate() {
        table.push(&format!("T{}", i + 1), c, 4);
    }
    for (a, c) in plant.axes.iter().zip(disps) {
        table.push(a.name, c, 4);
    }
    table
}

#[cfg(test)]
mod tests {
    use super::super::network::two_nodes;
    use super::super::plant::Plant;
    use super::super::{catalogue, laws::Friction};
    use super::*;

    /// Plant `a` rebuilt on the two-node network with one friction law.
    fn two_node_plant() -> Plant {
        let mut p = catalogue::plant("a").unwrap();
        p.net = two_nodes();
        p.laws.friction = vec![Friction {
            node: 0,
            w_at_ref: 100.0,
            exponent: 1.0,
            preload_per_k: 0.0,
            outer: None,
        }];
        p.laws.motors.clear();
        p.laws.cutting.clear();
        p.sensors.truncate(1);
        p.axes.truncate(1);
        p.axes[0].um_per_k = vec![1.0, 0.0];
        p
    }

    fn run(p: &Plant, hours: f64, rpm: f64) -> Trace {
        let t: Vec<f64> = (0..=(hours * 60.0) as usize)
            .map(|k| 60.0 * k as f64)
            .collect();
        let (speed, cut) = (vec![rpm; t.len()], vec![0.0; t.len()]);
        let drive = Drive {
            t_s: &t,
            speed_rpm: &speed,
            cut_kw: &cut,
        };
        simulate(p, &drive, &mut Setup::nominal(p)).unwrap()
    }

    #[test]
    fn two_nodes_settle_on_the_closed_form_steady_state() {
        // 100 W at the reference speed into the core, 4 W/K to the shell,
        // 10 W/K to the air at 21 C: closed form shell 21 + 100/10,
        // core 21 + 100/4 + 100/10. The slowest time constant is ~1.7 h;
        // after 80 h (47 of them) the transient is e^-47 ~ 4e-21 K, and RK4's
        // fixed point is the exact steady state: within 1e-6 K.
        let p = two_node_plant();
        let tr = run(&p, 80.0, p.laws.ref_rpm);
        let x = &tr.x[tr.x.len() - 1];
        assert!((x[1] - 31.0).abs() < 1e-6, "{x:?}");
        assert!((x[0] - 56.0).abs() < 1e-6, "{x:?}");
        // Energy balance: what the air takes is what the laws put in.
        let to_air = 10.0 * (x[1] - 21.0);
        assert!((to_air - 100.0).abs() < 1e-5, "{to_air}");
    }

    #[test]
    fn one_node_step_response_has_its_time_constant() {
        // A single node C = 36 000 J/K, g = 10 W/K: tau = 3600 s. After one
        // tau the rise is 1 - e^-1 of the final 10 K; RK4 with h lambda
        // <= 0.25 errs by < 1e-6 K here.
        let mut p = two_node_plant();
        p.net.nodes.truncate(1);
        p.net.links.clear();
        p.net.nodes[0].c_j_per_k = 36_000.0;
        p.net.nodes[0].g_ambient_w_per_k = 10.0;
        p.axes[0].um_per_k = vec![1.0];
        let tr = run(&p, 2.0, p.laws.ref_rpm);
        let rise = tr.x[60][0] - tr.x[0][0];
        assert!(
            (rise - 10.0 * (1.0 - (-1.0f64).exp())).abs() < 1e-6,
            "{rise}"
        );
        assert!((p.net.time_constants_s()[0] - 3600.0).abs() < 1e-9);
    }

    #[test]
    fn the_chiller_cycles_faster_when_the_machine_runs_hard() {
        // Plant a: tank 500 kJ/K, band 1 K, 1800 W compressor, 200 W base
        // load. At rest the machine gives the coolant only what the room
        // gives it (~10 W): period ~ 500k/210 + 500k/1590 = 2700 s. At top
        // speed the motor jacket takes ~500 W: ~ 500k/700 + 500k/1100 =
        // 1170 s. The measured ratio must show that drift (< 0.7).
        // Plant g: tank 400 kJ/K, band 0.9 K, 2000 W, 220 W base: at rest
        // ~ 360k/230 + 360k/1770 = 1770 s; at top speed the stator jacket
        // and the ram take ~850 W: ~ 360k/1070 + 360k/930 = 720 s.
        // Plant h: tank 450 kJ/K, band 0.85 K, 1700 W, 180 W base: at rest
        // ~ 380k/230 + 380k/1470 = 1910 s; at top speed the gearbox oil and
        // the headstock take ~400 W: ~ 380k/630 + 380k/1070 = 960 s.
        // Plant i: tank 550 kJ/K, band 0.95 K, 2400 W, 260 W base: at rest
        // the pad oil gives ~20 W: ~ 520k/280 + 520k/2120 = 2100 s; at top
        // speed the pad oil and the ram saddle take ~730 W: ~ 520k/990 +
        // 520k/1410 = 900 s.
        // Plant j: tank 400 kJ/K, band 0.85 K, 1800 W, 150 W base: at rest
        // the motor jacket and the cutting oil give ~12 W: ~ 340k/162 +
        // 340k/1638 = 2300 s; at top speed they take ~610 W: ~ 340k/760 +
        // 340k/1040 = 775 s.
        for id in ["a", "g", "h", "i", "j"] {
            chiller_period_drifts_on(id);
        }
    }

    fn chiller_period_drifts_on(id: &str) {
        use super::super::boundary::Coolant;
        use super::super::effects::Effect;
        let p = catalogue::plant(id).unwrap();
        let period = |rpm: f64| {
            let t: Vec<f64> = (0..=24 * 60).map(|k| 60.0 * k as f64).collect();
            let (speed, cut) = (vec![rpm; t.len()], vec![0.0; t.len()]);
            let drive = Drive {
                t_s: &t,
                speed_rpm: &speed,
                cut_kw: &cut,
            };
            let mut setup = Setup::real(&p, Some(Effect::Coolant), 1.0, 86_400.0, 1);
            simulate(&p, &drive, &mut setup).unwrap();
            let Coolant::Cycling(ch) = &setup.coolant else {
                panic!("no chiller")
            };
            let s: Vec<f64> = ch
                .starts()
                .iter()
                .copied()
                .filter(|&t| t > 43_200.0)
                .collect();
            (s[s.len() - 1] - s[0]) / (s.len() - 1) as f64
        };
        let (rest, full) = (period(0.0), period(p.max_rpm));
        assert!(
            full < 0.7 * rest,
            "{id}: rest {rest} s, full speed {full} s"
        );
        assert!(
            (1500.0..4000.0).contains(&rest) && (600.0..1800.0).contains(&full),
            "{id}: {rest} {full}"
        );
    }
}
