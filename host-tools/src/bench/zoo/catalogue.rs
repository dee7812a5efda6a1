//! The plants of the zoo. Each is a different machine: node count and
//! topology, heat laws (speed exponents 1 to 2, a preloaded bearing, gear
//! churning, belts, one or two motors, a motor outside the network), where
//! the sensors sit and how fast they follow, which displacements it has,
//! its coolant circuit and its noise.
//!
//! | id | machine | nodes |
//! |---|---|---|
//! | a | vertical-spindle column with built-in motor | 5 |
//! | b | horizontal machining centre, separate motor, front/rear bearings, jacket | 8 |
//! | c | compact lathe headstock, gearbox, motor outside | 3 |
//! | d | gantry with a spindle motor and a feed motor | 6 |
//! | e | grinding wheelhead, hydrodynamic bearings, belt drive | 4 |
//! | f | turning centre, hollow-shaft motor spindle, Z ball screw, thermosiphon bed | 7 |
//! | g | 5-axis trunnion machining centre: motor spindle in a ram, direct-drive trunnion table | 9 |
//! | h | travelling-column boring mill: quill, gearbox, motor on a flange, long chain to the foundation | 11 |
//! | i | double-column vertical turning lathe: hydrostatic rotary table, ring-gear drive, portal with a crossrail and a ram (a mesh with four loops) | 10 |
//! | j | Swiss-type sliding-head lathe: sliding headstock with a motor spindle, guide bushing, sub-spindle, chilled cutting oil as a hub of the work zone (five loops) | 12 |
//!
//! Plant `j` is the default held-out plant ([`DEFAULT_HELDOUT`]); `d`, `f`,
//! `g`, `h` and then `i` were held out until each was scored once, and are
//! development plants since.

use super::boundary::{AmbientSwing, ChillerSpec};
use super::laws::{Friction, HeatLaws, Motor};
use super::network::{Link, Network, Node, Site};
use super::plant::{Axis, EffectSizes, Plant, PlantNoise};
use super::sensors::{ChannelNoise, Sensor};
use anyhow::{bail, Result};

/// Ids of every plant.
pub const IDS: [&str; 10] = ["a", "b", "c", "d", "e", "f", "g", "h", "i", "j"];
/// The plant kept out of development and tuning.
pub const DEFAULT_HELDOUT: &str = "j";

/// The plant `id`.
pub fn plant(id: &str) -> Result<Plant> {
    let p = match id {
        "a" => vertical_column(),
        "b" => horizontal_centre(),
        "c" => lathe_headstock(),
        "d" => gantry(),
        "e" => grinder(),
        "f" => turning_centre(),
        "g" => trunnion_centre(),
        "h" => boring_mill(),
        "i" => vertical_lathe(),
        "j" => sliding_head_lathe(),
        other => bail!("unknown plant \"{other}\" (one of {})", IDS.join(", ")),
    };
    p.check()?;
    Ok(p)
}

fn node(
    name: &'static str,
    c_j_per_k: f64,
    g_ambient_w_per_k: f64,
    g_coolant_w_per_k: f64,
) -> Node {
    Node {
        name,
        c_j_per_k,
        g_ambient_w_per_k,
        g_coolant_w_per_k,
    }
}

fn links(l: &[(usize, usize, f64)]) -> Vec<Link> {
    l.iter()
        .map(|&(a, b, g_w_per_k)| Link { a, b, g_w_per_k })
        .collect()
}

fn friction(node: usize, w_at_ref: f64, exponent: f64) -> Friction {
    Friction {
        node,
        w_at_ref,
        exponent,
        preload_per_k: 0.0,
        outer: None,
    }
}

/// A motor: node, share, idle, iron at ref, iron exponent, low-speed loss, knee, load loss.
#[allow(clippy::too_many_arguments)]
fn motor(
    node: usize,
    share: f64,
    idle_w: f64,
    iron_w_at_ref: f64,
    iron_exponent: f64,
    low_speed_w: f64,
    knee_rpm: f64,
    load_w_per_kw: f64,
) -> Motor {
    Motor {
        node,
        share,
        idle_w,
        iron_w_at_ref,
        iron_exponent,
        low_speed_w,
        knee_rpm,
        load_w_per_kw,
    }
}

/// A workshop's air: day swing `amp` K, warmest at 15:00, the run starting
/// at 06:00, drift `drift` K/h, weather 0.3 K over ~3 h.
fn workshop(amp: f64, drift: f64) -> AmbientSwing {
    AmbientSwing {
        day_amplitude_c: amp,
        warmest_clock_h: 15.0,
        start_clock_h: 6.0,
        drift_c_per_h: drift,
        weather_c: 0.3,
        weather_tau_s: 3.0 * 3600.0,
    }
}

fn chiller(
    setpoint_c: f64,
    band_c: f64,
    tank_j_per_k: f64,
    capacity_w: f64,
    base_load_w: f64,
) -> ChillerSpec {
    ChillerSpec {
        setpoint_c,
        band_c,
        tank_j_per_k,
        capacity_w,
        base_load_w,
    }
}

/// PT100-class sensors and probes: white noise, a drift over ~8 h (K) and
/// ~6 h (um).
fn noise(temp_c: f64, disp_um: f64) -> PlantNoise {
    PlantNoise {
        temp: ChannelNoise {
            white: temp_c,
            drift: 1.5 * temp_c,
            drift_tau_s: 8.0 * 3600.0,
        },
        disp: ChannelNoise {
            white: disp_um,
            drift: 2.0 * disp_um,
            drift_tau_s: 6.0 * 3600.0,
        },
        power_kw: 0.03,
        boundary_c: 0.02,
    }
}

fn vertical_column() -> Plant {
    Plant {
        id: "a",
        name: "vertical-spindle column, built-in motor",
        max_rpm: 12_000.0,
        cut_max_kw: 6.0,
        air_kw: [0.4, 0.9],
        ambient_c: 21.0,
        coolant_c: 20.0,
        net: Network {
            nodes: vec![
                node("spindle", 6000.0, 2.0, 8.0),
                node("motor", 10_000.0, 0.5, 70.0),
                node("headstock", 150_000.0, 12.0, 0.0),
                node("column", 900_000.0, 45.0, 0.0),
                node("base", 2.5e6, 60.0, 0.0),
            ],
            links: links(&[
                (0, 1, 12.0),
                (0, 2, 30.0),
                (1, 2, 18.0),
                (2, 3, 40.0),
                (3, 4, 80.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 10_000.0,
            friction: vec![friction(0, 320.0, 1.3)],
            motors: vec![motor(1, 1.0, 120.0, 450.0, 1.6, 150.0, 3000.0, 60.0)],
            cutting: vec![(0, 0.02), (4, 0.03)],
        },
        sensors: vec![
            Sensor::on(0, 30.0),
            Sensor::on(1, 20.0),
            Sensor::between(Site::Node(2), Site::Node(3), 0.3, 90.0),
            Sensor::on(3, 120.0),
            Sensor::on(4, 150.0),
            Sensor::air(60.0),
        ],
        axes: vec![
            Axis {
                name: "dy_um",
                um_per_k: vec![0.0, 0.0, 1.8, -1.0, 0.0],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![-1.4, 0.0, -2.5, 8.5, -3.0],
            },
        ],
        noise: noise(0.015, 0.15),
        effects: EffectSizes {
            ambient: workshop(1.5, 0.03),
            chiller: chiller(20.0, 1.0, 500_000.0, 1800.0, 200.0),
            cut_extra: vec![(0, 0.03), (3, 0.04)],
            motor_node: 1,
            motor_extra_w: 300.0,
            motor_extra_speed: 0.2,
            lag_sensors: vec![0, 2, 3],
            lag_tau_s: 900.0,
            lag_air_share: 0.05,
        },
    }
}

fn horizontal_centre() -> Plant {
    let mut front = friction(0, 260.0, 1.7);
    front.preload_per_k = 0.03;
    front.outer = Some(4);
    Plant {
        id: "b",
        name: "horizontal machining centre, separate motor",
        max_rpm: 15_000.0,
        cut_max_kw: 8.0,
        air_kw: [0.6, 1.2],
        ambient_c: 20.5,
        coolant_c: 19.5,
        net: Network {
            nodes: vec![
                node("front_bearing", 1800.0, 0.4, 0.0),
                node("rear_bearing", 1200.0, 0.8, 0.0),
                node("shaft", 7000.0, 2.5, 0.0),
                node("motor", 14_000.0, 25.0, 0.0),
                node("housing", 35_000.0, 4.0, 0.0),
                node("jacket", 9000.0, 0.0, 500.0),
                node("column", 1.2e6, 55.0, 0.0),
                node("bed", 3.0e6, 70.0, 0.0),
            ],
            links: links(&[
                (0, 2, 14.0),
                (0, 4, 28.0),
                (0, 5, 18.0),
                (1, 2, 9.0),
                (1, 4, 18.0),
                (2, 3, 4.0),
                (3, 4, 6.0),
                (4, 5, 40.0),
                (4, 6, 30.0),
                (6, 7, 90.0),
                (2, 4, 2.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 12_000.0,
            friction: vec![front, friction(1, 110.0, 1.7)],
            motors: vec![motor(3, 0.5, 200.0, 600.0, 1.4, 250.0, 3750.0, 70.0)],
            cutting: vec![(2, 0.025), (7, 0.04)],
        },
        sensors: vec![
            Sensor::on(0, 40.0),
            Sensor::on(1, 40.0),
            Sensor::on(3, 20.0),
            Sensor::between(Site::Node(4), Site::Node(6), 0.5, 100.0),
            Sensor::on(5, 15.0),
            Sensor::on(6, 150.0),
            Sensor::on(7, 200.0),
            Sensor::air(60.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.8, -0.8, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0],
            },
            Axis {
                name: "dy_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 1.5, 0.0, 10.0, -2.0],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![0.0, 0.0, -1.4, 0.0, -3.5, 0.0, -1.0, 0.0],
            },
        ],
        noise: noise(0.02, 0.2),
        effects: EffectSizes {
            ambient: workshop(1.2, 0.05),
            chiller: chiller(19.5, 1.0, 800_000.0, 2500.0, 300.0),
            cut_extra: vec![(2, 0.02), (6, 0.03)],
            motor_node: 3,
            motor_extra_w: 350.0,
            motor_extra_speed: 0.2,
            lag_sensors: vec![0, 1, 2, 3, 5],
            lag_tau_s: 1200.0,
            lag_air_share: 0.05,
        },
    }
}

fn lathe_headstock() -> Plant {
    Plant {
        id: "c",
        name: "compact lathe headstock, gearbox, motor outside",
        max_rpm: 4500.0,
        cut_max_kw: 6.0,
        air_kw: [0.5, 0.8],
        ambient_c: 22.0,
        coolant_c: 21.0,
        net: Network {
            nodes: vec![
                node("spindle", 25_000.0, 6.0, 0.0),
                node("headstock", 120_000.0, 20.0, 40.0),
                node("bed", 800_000.0, 35.0, 0.0),
            ],
            links: links(&[(0, 1, 45.0), (1, 2, 30.0)]),
        },
        laws: HeatLaws {
            ref_rpm: 3000.0,
            friction: vec![friction(0, 200.0, 1.0), friction(1, 120.0, 2.0)],
            motors: vec![motor(1, 0.3, 150.0, 300.0, 1.5, 300.0, 1350.0, 80.0)],
            cutting: vec![(0, 0.03), (2, 0.03)],
        },
        sensors: vec![
            Sensor::between(Site::Node(0), Site::Node(1), 0.2, 60.0),
            Sensor::on(1, 120.0),
            Sensor::air(60.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.0, 2.8, -0.6],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![2.2, 1.0, 0.0],
            },
        ],
        noise: noise(0.02, 0.2),
        effects: EffectSizes {
            ambient: workshop(2.0, 0.04),
            chiller: chiller(21.0, 0.8, 600_000.0, 1500.0, 150.0),
            cut_extra: vec![(0, 0.03), (2, 0.03)],
            motor_node: 1,
            motor_extra_w: 150.0,
            motor_extra_speed: 0.25,
            lag_sensors: vec![0, 1],
            lag_tau_s: 900.0,
            lag_air_share: 0.05,
        },
    }
}

fn gantry() -> Plant {
    Plant {
        id: "d",
        name: "gantry, spindle motor and feed motor",
        max_rpm: 24_000.0,
        cut_max_kw: 4.0,
        air_kw: [0.3, 1.0],
        ambient_c: 20.0,
        coolant_c: 20.0,
        net: Network {
            nodes: vec![
                node("spindle", 5000.0, 3.0, 6.0),
                node("spindle_motor", 8000.0, 0.5, 60.0),
                node("ram", 200_000.0, 14.0, 10.0),
                node("crossrail", 1.5e6, 40.0, 0.0),
                node("feed_motor", 6000.0, 8.0, 0.0),
                node("portal", 4.0e6, 90.0, 0.0),
            ],
            links: links(&[
                (0, 1, 10.0),
                (0, 2, 22.0),
                (1, 2, 15.0),
                (2, 3, 25.0),
                (4, 3, 8.0),
                (3, 5, 60.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 18_000.0,
            friction: vec![friction(0, 280.0, 1.5)],
            motors: vec![
                motor(1, 1.0, 100.0, 500.0, 1.7, 200.0, 4800.0, 50.0),
                motor(4, 1.0, 60.0, 0.0, 1.0, 0.0, 1.0, 40.0),
            ],
            cutting: vec![(0, 0.02), (5, 0.03)],
        },
        sensors: vec![
            Sensor::on(0, 30.0),
            Sensor::on(1, 20.0),
            Sensor::between(Site::Node(2), Site::Node(3), 0.3, 120.0),
            Sensor::on(3, 150.0),
            Sensor::on(4, 40.0),
            Sensor::on(5, 200.0),
            Sensor::air(60.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 1.2, 0.0],
            },
            Axis {
                name: "dy_um",
                um_per_k: vec![0.0, 0.0, 0.0, 4.0, 0.0, -1.0],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![-1.6, 0.0, -11.0, 2.0, 0.0, 0.0],
            },
        ],
        noise: noise(0.015, 0.2),
        effects: EffectSizes {
            ambient: workshop(1.5, 0.04),
            chiller: chiller(20.0, 1.0, 500_000.0, 2000.0, 200.0),
            cut_extra: vec![(0, 0.02), (2, 0.03)],
            motor_node: 1,
            motor_extra_w: 250.0,
            motor_extra_speed: 0.15,
            lag_sensors: vec![0, 2, 3, 4],
            lag_tau_s: 1200.0,
            lag_air_share: 0.05,
        },
    }
}

fn grinder() -> Plant {
    Plant {
        id: "e",
        name: "grinding wheelhead, hydrodynamic bearings, belt drive",
        max_rpm: 6000.0,
        cut_max_kw: 5.0,
        air_kw: [0.8, 1.5],
        ambient_c: 21.0,
        coolant_c: 20.0,
        net: Network {
            nodes: vec![
                node("spindle", 12_000.0, 2.0, 40.0),
                node("motor", 15_000.0, 30.0, 0.0),
                node("wheelhead", 250_000.0, 15.0, 0.0),
                node("base", 2.0e6, 60.0, 15.0),
            ],
            links: links(&[(0, 2, 35.0), (1, 2, 10.0), (2, 3, 45.0)]),
        },
        laws: HeatLaws {
            ref_rpm: 5000.0,
            friction: vec![friction(0, 500.0, 2.0), friction(1, 100.0, 1.0)],
            motors: vec![motor(1, 0.8, 150.0, 350.0, 1.3, 200.0, 1800.0, 60.0)],
            cutting: vec![(0, 0.01), (3, 0.06)],
        },
        sensors: vec![
            Sensor::between(Site::Node(0), Site::Coolant, 0.4, 15.0),
            Sensor::on(1, 30.0),
            Sensor::on(2, 90.0),
            Sensor::on(3, 180.0),
            Sensor::air(60.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.0, 0.0, -3.5, -3.0],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![1.8, 0.0, 1.2, 0.0],
            },
        ],
        noise: noise(0.02, 0.25),
        effects: EffectSizes {
            ambient: workshop(1.5, 0.03),
            chiller: chiller(20.0, 1.0, 600_000.0, 2500.0, 250.0),
            cut_extra: vec![(0, 0.01), (3, 0.05)],
            motor_node: 1,
            motor_extra_w: 250.0,
            motor_extra_speed: 0.25,
            lag_sensors: vec![0, 1, 2, 3],
            lag_tau_s: 900.0,
            lag_air_share: 0.05,
        },
    }
}

/// A slant-bed turning centre: a hollow-shaft motor spindle (the rotor sits
/// on the shaft between the bearings, so a share of the motor's losses heats
/// the shaft itself; the stator is jacket-cooled by the chiller), a Z ball
/// screw whose nut and bearings heat with the feed (in turning the feed is
/// set per revolution, so its friction follows the spindle speed to the
/// first power), and a bed cooled by a passive thermosiphon to a finned
/// radiator (a large conductance to the room).
fn turning_centre() -> Plant {
    Plant {
        id: "f",
        name: "turning centre, hollow-shaft motor spindle, Z ball screw, thermosiphon bed",
        max_rpm: 5000.0,
        cut_max_kw: 11.0,
        air_kw: [0.5, 1.4],
        ambient_c: 20.0,
        coolant_c: 19.0,
        net: Network {
            nodes: vec![
                node("front_bearing", 2500.0, 0.5, 0.0),
                node("rotor_shaft", 9000.0, 1.5, 0.0),
                node("stator", 14_000.0, 0.5, 80.0),
                node("rear_bearing", 1500.0, 0.6, 0.0),
                node("headstock", 160_000.0, 9.0, 6.0),
                node("ball_screw", 22_000.0, 5.0, 0.0),
                node("bed", 2.4e6, 160.0, 0.0),
            ],
            links: links(&[
                (0, 1, 14.0),
                (1, 3, 9.0),
                (1, 2, 5.0),
                (0, 4, 26.0),
                (3, 4, 15.0),
                (2, 4, 30.0),
                (4, 6, 45.0),
                (5, 6, 10.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 4000.0,
            friction: vec![
                friction(0, 220.0, 1.2),
                friction(3, 90.0, 1.8),
                friction(5, 60.0, 1.0),
            ],
            // One built-in motor: 70 % of its losses in the stator, 30 % in
            // the rotor on the hollow shaft.
            motors: vec![
                motor(2, 0.7, 200.0, 600.0, 1.5, 300.0, 1200.0, 50.0),
                motor(1, 0.3, 200.0, 600.0, 1.5, 300.0, 1200.0, 50.0),
            ],
            cutting: vec![(0, 0.015), (6, 0.05)],
        },
        sensors: vec![
            Sensor::on(0, 25.0),
            Sensor::between(Site::Node(2), Site::Coolant, 0.3, 8.0),
            Sensor::between(Site::Node(4), Site::Node(3), 0.35, 70.0),
            Sensor::on(5, 45.0),
            Sensor::on(6, 300.0),
            Sensor::air(90.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.0, 0.0, 0.4, 0.0, 2.6, 0.0, -0.9],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![0.8, 1.4, 0.0, 0.5, 0.9, -4.0, -0.8],
            },
        ],
        noise: noise(0.018, 0.22),
        effects: EffectSizes {
            ambient: workshop(1.8, 0.035),
            chiller: chiller(19.0, 0.9, 450_000.0, 2200.0, 250.0),
            cut_extra: vec![(0, 0.02), (6, 0.04)],
            motor_node: 2,
            motor_extra_w: 280.0,
            motor_extra_speed: 0.2,
            lag_sensors: vec![0, 2, 3, 4],
            lag_tau_s: 1000.0,
            lag_air_share: 0.05,
        },
    }
}

/// A 5-axis trunnion machining centre. The motor spindle sits in a ram:
/// front and rear bearing around the shaft, the rotor on the shaft (slip
/// losses that follow the load), the stator in a chiller jacket that also
/// cools the ram's guideway side; a rotary union and seals in the ram whose
/// drag grows nearly with the square of the speed; the front bearing's
/// preload grows with its ring difference to the ram. The ram hangs on a
/// column standing on the bed; apart from it a trunnion table on the bed,
/// driven by a water-cooled direct-drive torque motor that works while the
/// part is machined, takes the chips (two clusters of heat joined only
/// through the bed). A skin sensor on the column leans to the air; the bed
/// is read by a slow sensor deep in its casting.
fn trunnion_centre() -> Plant {
    let mut front = friction(0, 240.0, 1.35);
    front.preload_per_k = 0.02;
    front.outer = Some(4);
    Plant {
        id: "g",
        name: "5-axis trunnion machining centre, motor spindle in a ram, direct-drive table",
        max_rpm: 18_000.0,
        cut_max_kw: 7.0,
        air_kw: [0.5, 1.1],
        ambient_c: 20.5,
        coolant_c: 19.8,
        net: Network {
            nodes: vec![
                node("front_bearing", 2000.0, 0.3, 0.0),
                node("rear_bearing", 1400.0, 0.5, 0.0),
                node("shaft", 6500.0, 1.2, 0.0),
                node("stator", 11_000.0, 0.4, 70.0),
                node("ram", 70_000.0, 5.0, 10.0),
                node("column", 1.0e6, 40.0, 0.0),
                node("trunnion", 90_000.0, 6.0, 0.0),
                node("torque_motor", 7000.0, 1.0, 40.0),
                node("bed", 3.5e6, 80.0, 0.0),
            ],
            links: links(&[
                (0, 2, 12.0),
                (1, 2, 8.0),
                (2, 3, 4.0),
                (0, 4, 22.0),
                (1, 4, 14.0),
                (3, 4, 25.0),
                (4, 5, 30.0),
                (5, 8, 70.0),
                (6, 8, 20.0),
                (7, 6, 12.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 15_000.0,
            friction: vec![front, friction(1, 120.0, 1.6), friction(4, 80.0, 1.9)],
            motors: vec![
                // stator: iron, copper at idle, the low-speed inefficiency
                motor(3, 0.85, 150.0, 500.0, 1.5, 220.0, 4000.0, 30.0),
                // rotor on the shaft: slip losses with the load
                motor(2, 1.0, 20.0, 60.0, 2.0, 0.0, 1.0, 45.0),
                // the trunnion's torque motor: works with the cut
                motor(7, 1.0, 40.0, 0.0, 1.0, 0.0, 1.0, 70.0),
            ],
            cutting: vec![(0, 0.015), (6, 0.04)],
        },
        sensors: vec![
            Sensor::between(Site::Node(0), Site::Node(4), 0.3, 35.0),
            Sensor::between(Site::Node(3), Site::Coolant, 0.25, 10.0),
            Sensor::on(4, 75.0),
            Sensor::between(Site::Node(5), Site::Ambient, 0.15, 180.0),
            Sensor::on(6, 110.0),
            Sensor::on(7, 20.0),
            Sensor::on(8, 400.0),
            Sensor::air(50.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.2, 0.6, -0.7],
            },
            Axis {
                name: "dy_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 1.2, 7.5, 0.0, 0.0, -1.8],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![-0.5, 0.0, -0.8, 0.0, -1.6, 2.0, 2.8, 0.0, -0.5],
            },
        ],
        noise: noise(0.017, 0.18),
        effects: EffectSizes {
            ambient: workshop(1.6, -0.03),
            chiller: chiller(19.8, 0.9, 400_000.0, 2000.0, 220.0),
            cut_extra: vec![(4, 0.02), (8, 0.03)],
            motor_node: 2,
            motor_extra_w: 260.0,
            motor_extra_speed: 0.18,
            lag_sensors: vec![0, 2, 3, 4, 6],
            lag_tau_s: 1100.0,
            lag_air_share: 0.05,
        },
    }
}

/// A horizontal boring mill with a travelling column: heat flows along one
/// long chain, quill nose - boring quill - main spindle bearings - gearbox -
/// headstock - upper column - lower column - saddle - bed - foundation, with
/// the main motor as the only side branch (flanged onto the gearbox, fan
/// cooled: 55 % of its losses reach the casting). The gearbox's oil is cooled
/// by the chiller; its mesh losses follow the transmitted cutting power, its
/// churning nearly the square of the speed; a hydraulic power pack that
/// balances the headstock runs with the spindle and warms the lower column.
/// The slow machine (3 500 rpm) cuts hard (12 kW). Sensors: a fast
/// thin-film probe at the quill nose, an oil-sump sensor leaning to the
/// coolant, one on the motor flange, a pad between the spindle bearings and
/// the headstock, a column skin sensor leaning to the air, the saddle, a slow
/// probe deep in the bed, a fast air sensor.
fn boring_mill() -> Plant {
    Plant {
        id: "h",
        name: "travelling-column boring mill, quill and gearbox, long chain to the foundation",
        max_rpm: 3500.0,
        cut_max_kw: 12.0,
        air_kw: [0.6, 1.3],
        ambient_c: 20.5,
        coolant_c: 20.0,
        net: Network {
            nodes: vec![
                node("quill_nose", 1500.0, 0.3, 0.0),
                node("quill", 9000.0, 5.0, 0.0),
                node("spindle_bearings", 4000.0, 0.4, 0.0),
                node("gearbox", 30_000.0, 1.5, 45.0),
                node("headstock", 120_000.0, 6.0, 8.0),
                node("motor", 20_000.0, 18.0, 0.0),
                node("column_upper", 600_000.0, 20.0, 0.0),
                node("column_lower", 700_000.0, 20.0, 0.0),
                node("saddle", 250_000.0, 8.0, 0.0),
                node("bed", 2.5e6, 40.0, 0.0),
                node("foundation", 6.0e6, 150.0, 0.0),
            ],
            links: links(&[
                (0, 1, 18.0),
                (1, 2, 22.0),
                (2, 3, 20.0),
                (3, 4, 35.0),
                (5, 3, 6.0),
                (4, 6, 30.0),
                (6, 7, 60.0),
                (7, 8, 40.0),
                (8, 9, 35.0),
                (9, 10, 120.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 3000.0,
            friction: vec![
                friction(0, 90.0, 1.15),
                friction(2, 140.0, 1.55),
                friction(3, 260.0, 1.85),
            ],
            motors: vec![
                // the main motor on its flange: 55 % of its losses reach the gearbox side
                motor(5, 0.55, 180.0, 500.0, 1.4, 260.0, 900.0, 55.0),
                // gear mesh losses with the transmitted power
                motor(3, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 35.0),
                // the hydraulic power pack balancing the headstock
                motor(7, 1.0, 90.0, 0.0, 1.0, 0.0, 1.0, 0.0),
            ],
            cutting: vec![(0, 0.02), (9, 0.03)],
        },
        sensors: vec![
            Sensor::between(Site::Node(0), Site::Node(1), 0.25, 12.0),
            Sensor::between(Site::Node(3), Site::Coolant, 0.35, 6.0),
            Sensor::between(Site::Node(5), Site::Node(3), 0.4, 45.0),
            Sensor::between(Site::Node(2), Site::Node(4), 0.5, 160.0),
            Sensor::between(Site::Node(6), Site::Ambient, 0.2, 240.0),
            Sensor::on(8, 85.0),
            Sensor::on(9, 520.0),
            Sensor::air(25.0),
        ],
        axes: vec![
            Axis {
                name: "dy_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 5.0, 4.0, 0.0, -0.6, 0.0],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![0.5, 1.0, 0.4, 0.0, 1.8, 0.0, 0.0, 0.0, -0.8, 0.0, 0.0],
            },
        ],
        noise: noise(0.016, 0.2),
        effects: EffectSizes {
            ambient: workshop(1.3, 0.02),
            chiller: chiller(20.0, 0.85, 450_000.0, 1700.0, 180.0),
            cut_extra: vec![(1, 0.025), (8, 0.035)],
            motor_node: 5,
            motor_extra_w: 220.0,
            motor_extra_speed: 0.22,
            lag_sensors: vec![0, 2, 3, 5],
            lag_tau_s: 950.0,
            lag_air_share: 0.05,
        },
    }
}

/// A double-column vertical turning lathe. The work turns on a large
/// rotary table floating on hydrostatic pads: the pad oil's shear grows
/// nearly with the square of the speed, and the pump's heat and the shear
/// go into the oil, which the chiller cools. A ring gear under the table
/// drives it (churning and mesh losses with the transmitted power); the
/// main motor stands on the base at the left column's foot, beside the
/// ring-gear drive, and gives its losses (45 %, a fan takes the rest) to
/// all three. The base carries two columns joined on top by the crossrail,
/// on which the ram saddle moves; the tool sits at the lower end of a
/// vertical ram. The heat paths form a mesh with four independent loops
/// (table - pads - base - drive, motor - drive - base, motor - base - left
/// column, base - left column - crossrail - right column): heat reaches a
/// node by more than one way, and the motor warms the left column more
/// than the right. Radial error dx follows the table's (and the work's)
/// radial growth, the crossrail and the columns' difference (a tilt); the
/// tool-to-table gap dz the columns lifting the crossrail against the ram
/// and the table growing.
/// Sensors: a probe on the ram near the tool, the pad oil return leaning to
/// the coolant, the motor frame, a pad on the table's stationary ring, the
/// crossrail's skin leaning to the air, deep in the base, a slow air
/// sensor.
fn vertical_lathe() -> Plant {
    Plant {
        id: "i",
        name: "double-column vertical turning lathe, hydrostatic rotary table, crossrail and ram",
        max_rpm: 400.0,
        cut_max_kw: 18.0,
        air_kw: [1.5, 3.0],
        ambient_c: 19.5,
        coolant_c: 18.5,
        net: Network {
            nodes: vec![
                node("table", 300_000.0, 12.0, 0.0),
                node("pad_oil", 12_000.0, 0.5, 55.0),
                node("ring_gear_drive", 60_000.0, 2.0, 0.0),
                node("main_motor", 45_000.0, 20.0, 0.0),
                node("base", 3.5e6, 60.0, 0.0),
                node("column_left", 900_000.0, 12.0, 0.0),
                node("column_right", 900_000.0, 12.0, 0.0),
                node("crossrail", 700_000.0, 20.0, 0.0),
                node("ram_saddle", 120_000.0, 6.0, 4.0),
                node("ram", 80_000.0, 4.0, 0.0),
            ],
            links: links(&[
                (0, 1, 30.0),
                (1, 4, 25.0),
                (0, 2, 12.0),
                (2, 4, 20.0),
                (3, 2, 7.0),
                (3, 4, 6.0),
                (3, 5, 5.0),
                (4, 5, 45.0),
                (4, 6, 45.0),
                (5, 7, 18.0),
                (6, 7, 18.0),
                (7, 8, 16.0),
                (8, 9, 10.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 300.0,
            friction: vec![
                friction(1, 420.0, 1.95),
                friction(2, 160.0, 1.45),
                friction(0, 70.0, 1.25),
            ],
            motors: vec![
                // the main motor at the left column's foot: 45 % of its losses stay in the machine
                motor(3, 0.45, 250.0, 600.0, 1.3, 350.0, 90.0, 25.0),
                // the ring gear's mesh losses with the transmitted power
                motor(2, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 12.0),
                // the hydrostatic pump, running while the table turns
                motor(1, 1.0, 160.0, 0.0, 1.0, 0.0, 1.0, 0.0),
            ],
            cutting: vec![(9, 0.01), (0, 0.02)],
        },
        sensors: vec![
            Sensor::between(Site::Node(9), Site::Node(8), 0.3, 18.0),
            Sensor::between(Site::Node(1), Site::Coolant, 0.4, 5.0),
            Sensor::on(3, 35.0),
            Sensor::between(Site::Node(0), Site::Node(4), 0.45, 140.0),
            Sensor::between(Site::Node(7), Site::Ambient, 0.15, 150.0),
            Sensor::on(4, 360.0),
            Sensor::air(110.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![2.5, 0.0, 0.0, 0.0, 0.0, 2.5, -2.5, 3.0, 0.8, 0.0],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![-1.2, -0.3, 0.0, 0.0, -0.4, 3.0, 3.0, 0.8, 0.0, -3.2],
            },
        ],
        noise: noise(0.019, 0.24),
        effects: EffectSizes {
            ambient: workshop(1.7, -0.015),
            chiller: chiller(18.5, 0.95, 550_000.0, 2400.0, 260.0),
            cut_extra: vec![(9, 0.012), (4, 0.03)],
            motor_node: 3,
            motor_extra_w: 300.0,
            motor_extra_speed: 0.2,
            lag_sensors: vec![0, 2, 3, 4],
            lag_tau_s: 1050.0,
            lag_air_share: 0.05,
        },
    }
}

/// A Swiss-type sliding-head lathe (CNC automatic for bar work up to
/// ~20 mm). The bar is clamped in the main spindle, a motor spindle in a
/// headstock that slides along Z1 on guideways, driven by a ball screw;
/// the headstock feeds the bar through a rotary guide bushing in a column
/// in front of it, and the tools of a gang slide on that column cut right
/// at the bushing's face. A sub-spindle on its own slide takes the part
/// over and works its back end. Everything in the work zone is flooded
/// with neat cutting oil from a ~150 L tank whose plate exchanger is on
/// the chiller; the chiller also feeds the main motor's jacket. The
/// heat paths: a ring bearings - rotor - stator - headstock, the headstock
/// on two parallel supports (guideways, Z1 screw) to the bed; in the work
/// zone the cutting oil is a hub that touches the guide bushing, the tool
/// gang, the sub-spindle and the bed's chip trough, so the work-zone nodes,
/// which share no link among themselves, exchange heat through the oil,
/// the bushing column and the bed. The main spindle side reaches the work
/// zone only through the bed. Heat laws: the main bearings' oil-air
/// lubricated viscous friction (Palmgren, n^(5/3)), the guide bushing's
/// mixed friction of the bar sliding in its bore (nearly Coulomb, n^1.1),
/// the grease-lubricated sub-spindle bearings (n^1.4); the main and
/// sub-spindle motors; the Z1 axis, whose screw and servo losses follow
/// the feed force, i.e. the cutting load only; the high-pressure oil pump
/// into the oil. Axes: dx the diameter the gang tool cuts at the bushing,
/// dz the part length (the headstock's collet against the bushing face),
/// dz2 the sub-spindle's Z2 pick-off and back-working length.
/// Sensors: the main spindle's nose housing near the front bearings, the
/// stator winding, the Z1 nut, the guide bushing housing wetted by the
/// oil, the oil tank's return leaning to the cooler's outlet, the
/// sub-spindle housing, the bushing column's skin, deep in the bed, the
/// air.
fn sliding_head_lathe() -> Plant {
    Plant {
        id: "j",
        name: "Swiss-type sliding-head lathe, guide bushing, sub-spindle, chilled cutting oil",
        max_rpm: 10_000.0,
        cut_max_kw: 3.0,
        air_kw: [0.25, 0.45],
        ambient_c: 22.5,
        coolant_c: 22.0,
        net: Network {
            nodes: vec![
                node("main_bearings", 1600.0, 0.3, 0.0),
                node("main_rotor", 4500.0, 0.8, 0.0),
                // the main motor's jacket on the chiller
                node("main_stator", 7000.0, 0.6, 30.0),
                node("headstock", 70_000.0, 7.0, 0.0),
                node("z1_screw", 9000.0, 2.5, 0.0),
                node("guide_bushing", 5000.0, 0.6, 0.0),
                node("bushing_column", 110_000.0, 6.0, 0.0),
                node("tool_gang", 35_000.0, 3.0, 0.0),
                // ~150 L of neat oil (1.74 kJ/(L K)); its plate exchanger on the chiller
                node("cutting_oil", 260_000.0, 4.0, 70.0),
                node("sub_spindle", 6000.0, 1.5, 0.0),
                node("sub_slide", 45_000.0, 4.0, 0.0),
                // ~2 t of cast iron and steel: bed and stand
                node("bed", 900_000.0, 35.0, 0.0),
            ],
            links: links(&[
                (0, 1, 9.0),
                (1, 2, 4.0),
                (0, 3, 18.0),
                (2, 3, 22.0),
                (3, 4, 5.0),
                (3, 11, 12.0),
                (4, 11, 7.0),
                (5, 6, 14.0),
                (6, 11, 35.0),
                (7, 6, 16.0),
                (5, 8, 10.0),
                (7, 8, 9.0),
                (9, 8, 6.0),
                (8, 11, 15.0),
                (9, 10, 12.0),
                (10, 11, 18.0),
            ]),
        },
        laws: HeatLaws {
            ref_rpm: 8000.0,
            friction: vec![
                friction(0, 140.0, 1.65),
                friction(5, 55.0, 1.1),
                friction(9, 30.0, 1.4),
            ],
            motors: vec![
                // the main built-in motor, in its jacket
                motor(2, 1.0, 90.0, 220.0, 1.45, 180.0, 2000.0, 0.0),
                // the sub-spindle's built-in motor, turning with the main spindle
                motor(9, 1.0, 30.0, 40.0, 1.2, 0.0, 1.0, 0.0),
                // the Z1 screw and servo: the feed force follows the cutting load only
                motor(4, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 20.0),
                // the high-pressure cutting-oil pump, running with the spindle
                motor(8, 1.0, 150.0, 0.0, 1.0, 0.0, 1.0, 0.0),
            ],
            cutting: vec![(8, 0.05), (5, 0.015)],
        },
        sensors: vec![
            Sensor::between(Site::Node(0), Site::Node(3), 0.3, 22.0),
            Sensor::on(2, 9.0),
            Sensor::between(Site::Node(4), Site::Node(3), 0.2, 55.0),
            Sensor::between(Site::Node(5), Site::Node(8), 0.3, 28.0),
            Sensor::between(Site::Node(8), Site::Coolant, 0.25, 14.0),
            Sensor::on(9, 65.0),
            Sensor::between(Site::Node(6), Site::Ambient, 0.1, 130.0),
            Sensor::on(11, 260.0),
            Sensor::air(40.0),
        ],
        axes: vec![
            Axis {
                name: "dx_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.8, 2.6, 3.2, 0.0, 0.0, 0.0, -0.8],
            },
            Axis {
                name: "dz_um",
                um_per_k: vec![0.3, 0.6, 0.0, 2.3, 3.8, 0.0, -0.5, 0.0, 0.0, 0.0, 0.0, -4.2],
            },
            Axis {
                name: "dz2_um",
                um_per_k: vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.5, 0.0, 0.0, 1.8, 2.4, -3.0],
            },
        ],
        noise: noise(0.014, 0.16),
        effects: EffectSizes {
            ambient: workshop(1.9, 0.025),
            chiller: chiller(22.0, 0.85, 400_000.0, 1800.0, 150.0),
            cut_extra: vec![(7, 0.025), (5, 0.02)],
            motor_node: 2,
            motor_extra_w: 200.0,
            motor_extra_speed: 0.17,
            lag_sensors: vec![0, 2, 3, 5],
            lag_tau_s: 1150.0,
            lag_air_share: 0.05,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_plant_is_valid_and_they_differ_in_structure() {
        let plants: Vec<Plant> = IDS.iter().map(|id| plant(id).unwrap()).collect();
        let sizes: Vec<usize> = plants.iter().map(|p| p.net.len()).collect();
        assert_eq!(sizes, [5, 8, 3, 6, 4, 7, 9, 11, 10, 12]);
        let exps: Vec<f64> = plants
            .iter()
            .flat_map(|p| p.laws.friction.iter().map(|f| f.exponent))
            .collect();
        assert!(exps.contains(&1.0) && exps.contains(&2.0), "{exps:?}");
        assert!(plant("z").is_err());
    }

    /// Steady heat of every law of `p` at `rpm` with no cutting (the
    /// friction laws of `f` have no preload feedback, so the state does
    /// not matter).
    fn heat_at(p: &Plant, rpm: f64) -> Vec<f64> {
        let mut q = vec![0.0; p.net.len()];
        p.laws.add_heat_w(rpm, 0.0, &vec![0.0; p.net.len()], &mut q);
        q
    }

    /// Hottest sensor rise, K, and largest displacement, um, of plant `p`
    /// at top speed in steady state, the network's slowest and fastest time
    /// constants, s; asserts the steady state's energy balance (the room
    /// and the coolant take exactly the heat the laws put in; LU solve:
    /// 1e-6 W relative).
    fn scale_of(p: &Plant) -> (f64, f64, f64, f64) {
        let (ta, tc) = (p.ambient_c, p.coolant_c);
        let x = p.net.steady_state(&heat_at(p, p.max_rpm), ta, tc).unwrap();
        let rises: Vec<f64> = p
            .sensors
            .iter()
            .map(|s| s.site_c(&x, ta, tc) - ta)
            .collect();
        let hottest = rises.iter().copied().fold(f64::MIN, f64::max);
        let rise0: Vec<f64> = x.iter().map(|v| v - ta).collect();
        let disp: Vec<f64> = p
            .axes
            .iter()
            .map(|a| {
                a.um_per_k
                    .iter()
                    .zip(&rise0)
                    .map(|(k, r)| k * r)
                    .sum::<f64>()
            })
            .collect();
        let largest = disp.iter().map(|d| d.abs()).fold(0.0, f64::max);
        let taus = p.net.time_constants_s();
        let q: f64 = heat_at(p, p.max_rpm).iter().sum();
        let out: f64 = p
            .net
            .nodes
            .iter()
            .zip(&x)
            .map(|(n, xi)| n.g_ambient_w_per_k * (xi - ta) + n.g_coolant_w_per_k * (xi - tc))
            .sum();
        assert!((out - q).abs() < 1e-6 * q, "in {q} W, out {out} W");
        (hottest, largest, taus[0], taus[taus.len() - 1])
    }

    /// Plant `id` on the zoo's common scale at top speed (hottest sensor
    /// 15-25 K, largest axis 30-60 um), its fastest time constant 20-200 s
    /// and its slowest in `slow_h` hours.
    fn assert_zoo_scale(id: &str, slow_h: std::ops::RangeInclusive<f64>) {
        let (hottest, largest, slow, fast) = scale_of(&plant(id).unwrap());
        assert!(
            (15.0..=25.0).contains(&hottest),
            "{id}: hottest sensor {hottest} K"
        );
        assert!(
            (30.0..=60.0).contains(&largest),
            "{id}: largest axis {largest} um"
        );
        assert!((20.0..=200.0).contains(&fast), "{id}: fastest {fast} s");
        assert!(slow_h.contains(&(slow / 3600.0)), "{id}: slowest {slow} s");
    }

    #[test]
    fn turning_centre_rises_and_time_constants_lie_in_their_documented_ranges() {
        // docs/gap-benchmark.md, plants table: at top speed the hottest
        // sensor rises 15-25 K and the largest displacement moves 30-60 um
        // (the zoo's common scale, so effects at magnitude 1 have the same
        // relative size on every plant). Network time constants: about a
        // minute (the bearings) to ~3.7 h, the bed; the thermosiphon makes
        // the bed faster than the 6-11 h of the other plants' foundations.
        assert_zoo_scale("f", 2.0..=6.0);
    }

    #[test]
    fn trunnion_centre_rises_and_time_constants_lie_in_their_documented_ranges() {
        // The zoo's common scale (15-25 K on the hottest sensor, 30-60 um
        // on the largest axis at top speed); time constants from the
        // bearings' ~1 min to the bed's casting, 6-14 h as the other
        // plants' foundations (f's thermosiphon bed aside).
        assert_zoo_scale("g", 6.0..=14.0);
    }

    #[test]
    fn trunnion_centre_has_two_clusters_joined_through_the_bed_only() {
        // The spindle side (bearings, shaft, stator, ram, column) and the
        // table side (trunnion, torque motor) share no link but the bed's:
        // heat put only into the torque motor reaches the ram only through
        // the bed, so the ram rises less than 5 % of the torque motor
        // (steady state, LU: exact to 1e-9 K).
        let p = plant("g").unwrap();
        let mut q = vec![0.0; p.net.len()];
        q[7] = 100.0;
        let x = p.net.steady_state(&q, 0.0, 0.0).unwrap();
        assert!(x[4] < 0.05 * x[7] && x[4] > 0.0, "{x:?}");
        let side = |i: usize| usize::from((6..=7).contains(&i));
        let crossing: Vec<_> = p
            .net
            .links
            .iter()
            .filter(|l| l.a != 8 && l.b != 8 && side(l.a) != side(l.b))
            .collect();
        assert!(crossing.is_empty(), "{crossing:?}");
        // Heat laws from n^1.35 to n^1.9, three motors, eight sensors (one
        // leaning to the coolant, one to the air).
        let exps: Vec<f64> = p.laws.friction.iter().map(|f| f.exponent).collect();
        assert_eq!(exps, [1.35, 1.6, 1.9]);
        assert_eq!((p.laws.motors.len(), p.sensors.len()), (3, 8));
    }

    #[test]
    fn turning_centre_ball_screw_heat_follows_the_spindle_speed() {
        // Feed per revolution: the Z screw's friction is linear in the
        // spindle speed (exponent 1), the front bearing's 1.2, the rear's
        // 1.8; doubling the speed multiplies each by 2^p (1e-12).
        let p = plant("f").unwrap();
        let x = vec![0.0; p.net.len()];
        for f in &p.laws.friction {
            let r = f.heat_w(4000.0, p.laws.ref_rpm, &x) / f.heat_w(2000.0, p.laws.ref_rpm, &x);
            assert!((r - 2f64.powf(f.exponent)).abs() < 1e-12, "{r}");
        }
        let exps: Vec<f64> = p.laws.friction.iter().map(|f| f.exponent).collect();
        assert_eq!(exps, [1.2, 1.8, 1.0]);
    }
    #[test]
    fn boring_mill_rises_and_time_constants_lie_in_their_documented_ranges() {
        // The zoo's common scale (15-25 K on the hottest sensor, 30-60 um
        // on the largest axis at top speed); time constants from the quill
        // nose's ~1 min to the foundation's, 6-14 h as the other plants'
        // foundations (f's thermosiphon bed aside).
        assert_zoo_scale("h", 6.0..=14.0);
    }

    #[test]
    fn boring_mill_is_one_long_chain_with_the_motor_as_its_only_branch() {
        // A tree (links = nodes - 1) whose nodes other than the motor (5)
        // form one path quill nose .. foundation: every one of them has at
        // most two neighbours on it, and only the gearbox (3) has the
        // motor as a third.
        let p = plant("h").unwrap();
        let n = p.net.len();
        assert_eq!(p.net.links.len(), n - 1);
        let degree = |i: usize| {
            p.net
                .links
                .iter()
                .filter(|l| (l.a == i || l.b == i) && l.a != 5 && l.b != 5)
                .count()
        };
        let ends: Vec<usize> = (0..n).filter(|&i| i != 5 && degree(i) == 1).collect();
        assert_eq!(ends, [0, 10]);
        assert!((0..n).filter(|&i| i != 5).all(|i| degree(i) <= 2));
        // Heat put into the quill nose falls monotonically along the chain
        // to the foundation (steady state, LU: exact to 1e-9 K).
        let mut q = vec![0.0; n];
        q[0] = 100.0;
        let x = p.net.steady_state(&q, 0.0, 0.0).unwrap();
        let chain = [0, 1, 2, 3, 4, 6, 7, 8, 9, 10];
        assert!(chain.windows(2).all(|w| x[w[0]] > x[w[1]]), "{x:?}");
        // Heat laws from n^1.15 to n^1.85, three motor laws (the flanged
        // motor, the gear mesh, the hydraulic pack), eight sensors.
        let exps: Vec<f64> = p.laws.friction.iter().map(|f| f.exponent).collect();
        assert_eq!(exps, [1.15, 1.55, 1.85]);
        assert_eq!((p.laws.motors.len(), p.sensors.len()), (3, 8));
    }

    #[test]
    fn vertical_lathe_rises_and_time_constants_lie_in_their_documented_ranges() {
        // The zoo's common scale (15-25 K on the hottest sensor, here the
        // motor frame at ~17.5 K; 30-60 um on the largest axis, here dx at
        // ~40 um, at top speed); time constants from the pad oil's ~2 min
        // to the base's casting, 6-14 h as the other plants' foundations.
        assert_zoo_scale("i", 6.0..=14.0);
    }

    #[test]
    fn vertical_lathe_is_a_mesh_with_loops_and_an_asymmetric_portal() {
        // Ten nodes, thirteen links, connected: 13 - 10 + 1 = 4
        // independent loops (every other plant is a chain, a tree or has
        // at most two loops).
        let p = plant("i").unwrap();
        let n = p.net.len();
        assert_eq!((n, p.net.links.len()), (10, 13));
        // Heat put only into the motor (3) reaches the left column (5)
        // directly and the right column (6) only through the base: the
        // left one runs warmer, the right one still warms, and the
        // crossrail between them lies between the two (steady state, LU:
        // exact to 1e-9 K, so strict inequalities are safe).
        let mut q = vec![0.0; n];
        q[3] = 100.0;
        let x = p.net.steady_state(&q, 0.0, 0.0).unwrap();
        assert!(x[5] > x[6] && x[6] > 0.0, "{x:?}");
        assert!(x[7] < x[5] && x[7] > 0.0, "{x:?}");
        // Cutting the base - left column link (4, 5) leaves the left column
        // heated through the motor and the crossrail: a loop, not a tree.
        let mut cut = p.net.clone();
        cut.links.retain(|l| !(l.a == 4 && l.b == 5));
        let y = cut.steady_state(&q, 0.0, 0.0).unwrap();
        assert!(y[5] > 0.0 && y[6] > 0.0, "{y:?}");
        // Heat laws from n^1.25 to n^1.95 (the pad oil's shear), three motor
        // laws (main motor, ring-gear mesh, hydrostatic pump), seven
        // sensors (one leaning to the coolant, one to the air).
        let exps: Vec<f64> = p.laws.friction.iter().map(|f| f.exponent).collect();
        assert_eq!(exps, [1.95, 1.45, 1.25]);
        assert_eq!((p.laws.motors.len(), p.sensors.len()), (3, 7));
    }

    #[test]
    fn sliding_head_lathe_rises_and_time_constants_lie_in_their_documented_ranges() {
        // The zoo's common scale (15-25 K on the hottest sensor, here the
        // main spindle's nose housing at ~17 K; 30-60 um on the largest
        // axis, here dz at ~45 um, at top speed); time constants from the
        // main bearings' ~1 min to the bed's ~4 h: a small machine (~2 t of
        // bed and stand), lighter than the 6-14 h foundations of the large
        // plants, so 3-6 h.
        assert_zoo_scale("j", 3.0..=6.0);
    }

    #[test]
    fn sliding_head_lathe_work_zone_meets_in_the_cutting_oil() {
        // Twelve nodes, sixteen links, connected: 16 - 12 + 1 = 5
        // independent loops.
        let p = plant("j").unwrap();
        let n = p.net.len();
        assert_eq!((n, p.net.links.len()), (12, 16));
        let linked = |a: usize, b: usize| {
            p.net
                .links
                .iter()
                .any(|l| (l.a, l.b) == (a, b) || (l.a, l.b) == (b, a))
        };
        let degree = |i: usize| p.net.links.iter().filter(|l| l.a == i || l.b == i).count();
        // The cutting oil (8) is a hub: the guide bushing (5), the tool
        // gang (7) and the sub-spindle (9) share no link among themselves,
        // each is linked to the oil, and the oil has four links, as many
        // as any node but the bed (the headstock has four too).
        let zone = [5, 7, 9];
        assert!(zone.iter().all(|&i| linked(i, 8)));
        assert!(zone.iter().all(|&i| zone.iter().all(|&j| !linked(i, j))));
        assert_eq!(degree(8), 4);
        assert!((0..n).filter(|&i| i != 11).all(|i| degree(i) <= degree(8)));
        // The main spindle side (bearings, rotor, stator, headstock, Z1
        // screw) reaches the rest only through the bed.
        let spindle = |i: usize| usize::from(i <= 4);
        let crossing: Vec<_> = p
            .net
            .links
            .iter()
            .filter(|l| l.a != 11 && l.b != 11 && spindle(l.a) != spindle(l.b))
            .collect();
        assert!(crossing.is_empty(), "{crossing:?}");
        // So heat put only into the sub-spindle warms the guide bushing at
        // the far end of the work zone (through the oil) more than the
        // headstock beside it (through the bed only): ~0.55 K against
        // ~0.28 K per 100 W (steady state, LU: exact to 1e-9 K, so a
        // strict inequality is safe).
        let mut q = vec![0.0; n];
        q[9] = 100.0;
        let x = p.net.steady_state(&q, 0.0, 0.0).unwrap();
        assert!(x[5] > x[3] && x[3] > 0.0, "{x:?}");
    }

    #[test]
    fn sliding_head_lathe_z1_losses_follow_the_load_and_the_chiller_takes_most_heat() {
        // The Z1 screw and servo (node 4) get heat from the feed force
        // only: none while air cutting at top speed, 20 W per kW of
        // cutting at any speed (exact arithmetic of the law, 1e-12 W).
        let p = plant("j").unwrap();
        let n = p.net.len();
        let x0 = vec![0.0; n];
        let z1 = |rpm: f64, cut: f64| {
            let mut q = vec![0.0; n];
            p.laws.add_heat_w(rpm, cut, &x0, &mut q);
            q[4]
        };
        assert_eq!(z1(p.max_rpm, 0.0), 0.0);
        for rpm in [1000.0, p.max_rpm] {
            assert!((z1(rpm, 3.0) - 60.0).abs() < 1e-12, "{}", z1(rpm, 3.0));
        }
        // At top speed the chiller (the main motor's jacket and the oil's
        // plate exchanger) takes about 65 % of the heat the laws put in:
        // most of it, not all (the room takes the rest). Steady state by
        // LU; the band 0.5-0.8 leaves room for retuning a conductance.
        let q = heat_at(&p, p.max_rpm);
        let (ta, tc) = (p.ambient_c, p.coolant_c);
        let x = p.net.steady_state(&q, ta, tc).unwrap();
        let share = p.net.coolant_load_w(&x, tc) / q.iter().sum::<f64>();
        assert!((0.5..=0.8).contains(&share), "{share}");
        // Heat laws n^1.65 (main bearings, oil-air), n^1.1 (the bar in the
        // guide bushing), n^1.4 (sub-spindle, grease); four motor laws (main
        // motor, sub-spindle motor, Z1 load only, oil pump); nine sensors
        // (one leaning to the coolant, one to the air); three axes.
        let exps: Vec<f64> = p.laws.friction.iter().map(|f| f.exponent).collect();
        assert_eq!(exps, [1.65, 1.1, 1.4]);
        assert_eq!((p.laws.motors.len(), p.sensors.len()), (4, 9));
        let axes: Vec<&str> = p.axes.iter().map(|a| a.name).collect();
        assert_eq!(axes, ["dx_um", "dz_um", "dz2_um"]);
    }
}
