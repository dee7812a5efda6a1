//! One run of the twin: a schedule (speed over time) through the network,
//! the effects, the sensors and the expansion model, row by row.
//!
//! Row k reports the state at `t_k`; the inputs of row k (speed, load,
//! ambient, coolant) are then held until `t_(k+1)` (zero-order hold). The
//! run starts from the equilibrium of the spindle at rest with the first
//! row's ambient and coolant, which is also the expansion's reference (the
//! "cold sample"), so `dx, dy, dz` start at zero up to probe noise.

use super::effects::{self, Ambient, Coolant, Effect, EffectSet};
use super::expansion::ExpansionModel;
use super::integrate::Stepper;
use super::machine::{Machine, Node, SensorSite, N_NODES};
use super::network::{self, Input, Network, State, U_AMBIENT, U_COOLANT};
use super::profile::Schedule;
use super::rng::{Rng, Stream};
use super::sensors::SensorBank;
use anyhow::{anyhow, bail, Result};
use model_core::geometry::{ProbeReadings, ToolTipDrift};

/// Options of a run besides machine and schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimOptions {
    /// Effects switched on.
    pub effects: EffectSet,
    /// Seed of every random stream.
    pub seed: u64,
    /// Number of temperature sensors (the machine's first N sites); `None`
    /// for all.
    pub sensors: Option<usize>,
}

/// One output row.
#[derive(Debug, Clone)]
pub struct Row<'a> {
    /// Row index.
    pub index: usize,
    /// Time, s.
    pub t_s: f64,
    /// Spindle speed, rpm.
    pub speed_rpm: f64,
    /// Spindle effective power, kW.
    pub power_kw: f64,
    /// Ambient air as its sensor reads it (with sensor noise), deg C.
    pub ambient_c: f64,
    /// Coolant supply as its sensor reads it (with sensor noise), deg C.
    pub coolant_c: f64,
    /// Tool length, mm.
    pub tool_mm: f64,
    /// Sensor readings T1..Tn, deg C.
    pub temps_c: &'a [f64],
    /// Raw probe readings S1..S5, um.
    pub probes_um: [f64; 5],
    /// Tool-tip displacement from the probe readings, um.
    pub dx_um: f64,
    /// See `dx_um`.
    pub dy_um: f64,
    /// See `dx_um`.
    pub dz_um: f64,
    /// True node temperatures, deg C (not written to the run file).
    pub nodes_c: &'a State,
    /// Noise-free dz, um.
    pub dz_true_um: f64,
    /// Heat generated in the nodes, W.
    pub heat_w: [f64; N_NODES],
}

/// How far a constant-speed segment got towards its equilibrium.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Equilibrium {
    /// Speed of the segment, rpm.
    pub speed_rpm: f64,
    /// Start of the segment, s.
    pub from_t_s: f64,
    /// Equilibrium dz at that speed, um (noise-free).
    pub dz_um: f64,
    /// Time from the segment's start to 63 % of the dz change, s.
    pub t63_s: Option<f64>,
    /// Same for 95 %.
    pub t95_s: Option<f64>,
}

/// Figures of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Rows written.
    pub rows: usize,
    /// Largest |dz_um| written, um.
    pub max_abs_dz_um: f64,
    /// Largest |dx_um| written, um.
    pub max_abs_dx_um: f64,
    /// Largest |dy_um| written, um.
    pub max_abs_dy_um: f64,
    /// Largest node temperature rise above the initial state, K, and the node.
    pub max_rise_c: (f64, Node),
    /// Slowest time constant of the network, s.
    pub slowest_time_constant_s: f64,
    /// The first constant-speed segment's approach to equilibrium (only for
    /// runs without `cutting`, whose load cycles have no single equilibrium).
    pub equilibrium: Option<Equilibrium>,
}

/// The machine's first `opts.sensors` sensor sites (all of them by default).
fn sensor_sites<'m>(machine: &'m Machine, opts: &SimOptions) -> Result<&'m [SensorSite]> {
    let all = &machine.sensors.sites;
    match opts.sensors {
        None => Ok(&all[..]),
        Some(k) if k >= 1 && k <= all.len() => Ok(&all[..k]),
        Some(k) => bail!(
            "--sensors {k}: the machine has {} sensor sites (1..={})",
            all.len(),
            all.len()
        ),
    }
}

/// Ambient air and coolant supply over a run from `t0` lasting
/// `duration_s`: varying with their effects on, constant otherwise.
fn boundaries(
    machine: &Machine,
    opts: &SimOptions,
    t0: f64,
    duration_s: f64,
) -> (Ambient, Coolant) {
    let fx = opts.effects;
    let ambient = if fx.has(Effect::Ambient) {
        Ambient::varying(
            machine.boundary.ambient_c,
            &machine.effects.ambient,
            duration_s,
            opts.seed,
        )
    } else {
        Ambient::constant(machine.boundary.ambient_c)
    };
    let coolant = if fx.has(Effect::Coolant) {
        Coolant::cycling(&machine.effects.coolant, t0)
    } else {
        Coolant::constant(machine.boundary.coolant_c)
    };
    (ambient, coolant)
}

/// Heat generated in each node at `rpm` with a cutting load of `cut_kw`, W
/// (motor loss and cutting heat only with their effects on).
fn node_heat_w(machine: &Machine, fx: EffectSet, rpm: f64, cut_kw: f64) -> [f64; N_NODES] {
    let mut q = network::speed_heat_w(&machine.heat, rpm);
    if fx.has(Effect::MotorLoss) {
        q[Node::Motor.index()] += effects::motor_extra_w(&machine.effects.motor_loss, rpm);
    }
    if fx.has(Effect::Cutting) {
        let c = effects::cutting_heat_w(&machine.effects.cutting, cut_kw);
        for (qi, ci) in q.iter_mut().zip(c) {
            *qi += ci;
        }
    }
    q
}

/// The network's input vector: node heats `q`, ambient `ta`, coolant `tc`.
fn network_input(q: &[f64; N_NODES], ta: f64, tc: f64) -> Input {
    let mut u = Input::zeros();
    for (i, qi) in q.iter().enumerate() {
        u[i] = *qi;
    }
    u[U_AMBIENT] = ta;
    u[U_COOLANT] = tc;
    u
}

/// The cutting load of row `k` at `rpm`, kW: what a measured power exceeds
/// air cutting by, or the effect's load cycle (0 without cutting).
fn cutting_kw(machine: &Machine, schedule: &Schedule, fx: EffectSet, k: usize, rpm: f64) -> f64 {
    if !fx.has(Effect::Cutting) {
        return 0.0;
    }
    match &schedule.power_kw {
        // A measured power: the load is what exceeds air cutting.
        Some(p) => {
            let air_kw = network::speed_heat_w(&machine.heat, rpm)
                .iter()
                .sum::<f64>()
                / 1000.0;
            (p[k] - air_kw).max(0.0)
        }
        None => effects::cutting_load_kw(
            &machine.effects.cutting,
            schedule.t_s[k] - schedule.t_s[0],
            rpm,
        ),
    }
}

/// Spindle effective power of row `k`, kW: the schedule's, or the spindle
/// nodes' heat `q` plus the cutting load.
fn power_kw(schedule: &Schedule, k: usize, q: &[f64; N_NODES], cut_kw: f64) -> f64 {
    match &schedule.power_kw {
        Some(p) => p[k],
        None => {
            let spindle_w = q[Node::FrontBearing.index()]
                + q[Node::RearBearing.index()]
                + q[Node::Motor.index()];
            spindle_w / 1000.0 + cut_kw
        }
    }
}

/// The ambient and coolant sensors' readings of the boundary temperatures
/// `ta` and `tc`: the same noise as the machine's own sensors, from a stream
/// of their own. Without it the written columns would repeat one value for
/// hours at a constant room, which the hub calls a stuck sensor (no real
/// RTD's code holds still that long).
fn boundary_readings(ta: f64, tc: f64, noise_c: f64, rng: &mut Rng) -> [f64; 2] {
    [ta + noise_c * rng.normal(), tc + noise_c * rng.normal()]
}

/// The probe readings `clean` plus independent noise of `noise_um` each.
fn noisy_probes(clean: &ProbeReadings, noise_um: f64, rng: &mut Rng) -> [f64; 5] {
    let mut noisy = [
        clean.s1_um,
        clean.s2_um,
        clean.s3_um,
        clean.s4_um,
        clean.s5_um,
    ];
    for s in &mut noisy {
        *s += noise_um * rng.normal();
    }
    noisy
}

/// A geometry error of the row at `t`.
fn geometry(e: model_core::geometry::GeometryError, t: f64) -> anyhow::Error {
    anyhow!("geometry at t_s = {t}: {e}")
}

impl Summary {
    /// The figures before the first row.
    fn empty(slowest_time_constant_s: f64) -> Self {
        Summary {
            rows: 0,
            max_abs_dz_um: 0.0,
            max_abs_dx_um: 0.0,
            max_abs_dy_um: 0.0,
            max_rise_c: (0.0, Node::FrontBearing),
            slowest_time_constant_s,
            equilibrium: None,
        }
    }

    /// Takes in one row's tool tip and node temperatures `x` (rises over `x0`).
    fn record(&mut self, tip: &ToolTipDrift, x: &State, x0: &State) {
        self.max_abs_dz_um = self.max_abs_dz_um.max(tip.z_um.abs());
        self.max_abs_dx_um = self.max_abs_dx_um.max(tip.x_um.abs());
        self.max_abs_dy_um = self.max_abs_dy_um.max(tip.y_um.abs());
        for node in Node::ALL {
            let rise = x[node.index()] - x0[node.index()];
            if rise > self.max_rise_c.0 {
                self.max_rise_c = (rise, node);
            }
        }
    }
}

/// The first constant-speed segment's approach to its equilibrium: the
/// segment starts at row `k0` with input `u0`; `dz_true` is the run's
/// noise-free dz.
fn first_equilibrium(
    machine: &Machine,
    schedule: &Schedule,
    (net, expansion): (&Network, &ExpansionModel),
    (k0, u0): (usize, Input),
    dz_true: &[f64],
) -> Result<Equilibrium> {
    let n = schedule.t_s.len();
    let speed = schedule.speed_rpm[k0];
    let end = (k0..n)
        .find(|&k| schedule.speed_rpm[k] != speed)
        .unwrap_or(n);
    let tool_mm = schedule.tool_mm.as_ref().map_or(machine.tool_mm, |v| v[k0]);
    let xs = net.steady_state(&u0);
    let target = expansion
        .tool_tip(&expansion.probe_changes(&expansion.drift(&xs)), tool_mm)
        .map_err(|e| geometry(e, schedule.t_s[k0]))?
        .z_um;
    let start = dz_true[k0];
    let span = target - start;
    let reach = |f: f64| -> Option<f64> {
        if span.abs() < 1e-9 {
            return None;
        }
        (k0..end)
            .find(|&k| (dz_true[k] - start) / span >= f)
            .map(|k| schedule.t_s[k] - schedule.t_s[k0])
    };
    Ok(Equilibrium {
        speed_rpm: speed,
        from_t_s: schedule.t_s[k0],
        dz_um: target,
        t63_s: reach(1.0 - (-1f64).exp()),
        t95_s: reach(0.95),
    })
}

/// Runs the twin, giving each row to `sink`.
pub fn run(
    machine: &Machine,
    schedule: &Schedule,
    opts: &SimOptions,
    mut sink: impl FnMut(&Row) -> Result<()>,
) -> Result<Summary> {
    let n = schedule.t_s.len();
    if n == 0 {
        bail!("the schedule has no rows");
    }
    let sites = sensor_sites(machine, opts)?;
    let fx = opts.effects;
    let net = Network::new(machine);
    let t0 = schedule.t_s[0];
    let (ambient, mut coolant) = boundaries(machine, opts, t0, schedule.t_s[n - 1] - t0);
    let lag = fx
        .has(Effect::SensorLag)
        .then_some(machine.effects.sensor_lag.tau_s);
    let mut bank = SensorBank::new(sites, machine.sensors.noise_c, lag, opts.seed);
    let mut probe_rng = Rng::new(opts.seed, Stream::ProbeNoise);
    let mut boundary_rng = Rng::new(opts.seed, Stream::BoundaryNoise);

    // Initial equilibrium at rest.
    let (ta0, tc0) = (ambient.at(t0), coolant.advance_to(t0));
    let mut x = net.steady_state(&network_input(&[0.0; N_NODES], ta0, tc0));
    let x0 = x;
    let expansion = ExpansionModel::new(&machine.expansion, &machine.probes, x0);
    let mut stepper = Stepper::new(net.clone());

    let mut temps = Vec::with_capacity(sites.len());
    let mut dz_true = Vec::with_capacity(n);
    let mut first_u: Option<(usize, Input)> = None;
    let mut summary = Summary::empty(net.time_constants_s().first().copied().unwrap_or(0.0));
    for k in 0..n {
        let (t, rpm) = (schedule.t_s[k], schedule.speed_rpm[k]);
        let (ta, tc) = (ambient.at(t), coolant.advance_to(t));
        let [ta_read, tc_read] =
            boundary_readings(ta, tc, machine.sensors.noise_c, &mut boundary_rng);
        let tool_mm = schedule.tool_mm.as_ref().map_or(machine.tool_mm, |v| v[k]);
        let cut_kw = cutting_kw(machine, schedule, fx, k, rpm);
        let q = node_heat_w(machine, fx, rpm, cut_kw);
        let u = network_input(&q, ta, tc);
        if first_u.is_none() && rpm > 0.0 {
            first_u = Some((k, u));
        }

        let dt_prev = if k == 0 { 0.0 } else { t - schedule.t_s[k - 1] };
        bank.read(&x, ta, tc, dt_prev, &mut temps);
        let clean = expansion.probe_changes(&expansion.drift(&x));
        let noisy = noisy_probes(&clean, machine.probes.noise_um, &mut probe_rng);
        let [s1_um, s2_um, s3_um, s4_um, s5_um] = noisy;
        let readings = ProbeReadings {
            s1_um,
            s2_um,
            s3_um,
            s4_um,
            s5_um,
        };
        let tip = expansion
            .tool_tip(&readings, tool_mm)
            .map_err(|e| geometry(e, t))?;
        let tip_true = expansion
            .tool_tip(&clean, tool_mm)
            .map_err(|e| geometry(e, t))?;
        dz_true.push(tip_true.z_um);
        summary.record(&tip, &x, &x0);
        sink(&Row {
            index: k,
            t_s: t,
            speed_rpm: rpm,
            power_kw: power_kw(schedule, k, &q, cut_kw),
            ambient_c: ta_read,
            coolant_c: tc_read,
            tool_mm,
            temps_c: &temps,
            probes_um: noisy,
            dx_um: tip.x_um,
            dy_um: tip.y_um,
            dz_um: tip.z_um,
            nodes_c: &x,
            dz_true_um: tip_true.z_um,
            heat_w: q,
        })?;
        summary.rows += 1;
        if k + 1 < n {
            x = stepper.step(&x, &u, schedule.t_s[k + 1] - t);
        }
    }

    if let (Some(first), false) = (first_u, fx.has(Effect::Cutting)) {
        summary.equilibrium = Some(first_equilibrium(
            machine,
            schedule,
            (&net, &expansion),
            first,
            &dz_true,
        )?);
    }
    Ok(summary)
}
