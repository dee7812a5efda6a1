//! The machine file: every parameter of the thermal twin, in TOML, with its
//! unit in its name (`c_j_per_k`, `g_w_per_k`, `tau_s`, ...).
//!
//! Unknown fields and syntax errors name the file, line and column, as
//! model specs do ([`crate::data::spec`]); a value out of range names the field.
//! [`Machine::default_machine`] is the built-in machine, parsed from the
//! commented TOML that `thermcomp simulate --print-machine` prints, so the
//! printed file and the built-in machine cannot disagree.

use crate::data::spec::{from_toml, line_col};
use anyhow::{anyhow, bail, Result};
use serde::Deserialize;
use std::path::Path;
use toml::Spanned;

/// The built-in machine, with a comment on where each number comes from.
pub const DEFAULT_MACHINE_TOML: &str = include_str!("default_machine.toml");

/// The lumped bodies of the spindle and its structure, in state order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Node {
    /// Front (fixed) bearing set with its local housing steel.
    FrontBearing,
    /// Rear (floating) bearing.
    RearBearing,
    /// Motor stator and rotor, lumped.
    Motor,
    /// Spindle shaft.
    Shaft,
    /// Spindle housing (cartridge).
    Housing,
    /// Headstock and column.
    Structure,
    /// Coolant in the jacket and the cooling sleeve.
    CoolantJacket,
}

/// Number of nodes (the state dimension).
pub const N_NODES: usize = 7;

impl Node {
    /// All nodes, in state order.
    pub const ALL: [Node; N_NODES] = [
        Node::FrontBearing,
        Node::RearBearing,
        Node::Motor,
        Node::Shaft,
        Node::Housing,
        Node::Structure,
        Node::CoolantJacket,
    ];

    /// The node's name in machine files.
    pub fn name(self) -> &'static str {
        match self {
            Node::FrontBearing => "front_bearing",
            Node::RearBearing => "rear_bearing",
            Node::Motor => "motor",
            Node::Shaft => "shaft",
            Node::Housing => "housing",
            Node::Structure => "structure",
            Node::CoolantJacket => "coolant_jacket",
        }
    }

    /// Index in the state vector.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The node called `name`, if any.
    pub fn from_name(name: &str) -> Option<Node> {
        Node::ALL.into_iter().find(|n| n.name() == name)
    }
}

/// Where a temperature sensor sits: a node or one of the two boundaries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Site {
    /// On a node.
    Node(Node),
    /// In the room air.
    Ambient,
    /// In the coolant supply line.
    Coolant,
}

impl Site {
    fn from_name(name: &str) -> Option<Site> {
        match name {
            "ambient" => Some(Site::Ambient),
            "coolant" => Some(Site::Coolant),
            other => Node::from_name(other).map(Site::Node),
        }
    }
}

/// Heat capacity and boundary conductances of one node.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeParams {
    /// Heat capacity, J/K.
    pub c_j_per_k: f64,
    /// Conductance to ambient air (convection), W/K.
    pub g_ambient_w_per_k: f64,
    /// Conductance to the coolant supply, W/K.
    pub g_coolant_w_per_k: f64,
}

/// The seven nodes' parameters, by name.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Nodes {
    /// See [`Node::FrontBearing`].
    pub front_bearing: NodeParams,
    /// See [`Node::RearBearing`].
    pub rear_bearing: NodeParams,
    /// See [`Node::Motor`].
    pub motor: NodeParams,
    /// See [`Node::Shaft`].
    pub shaft: NodeParams,
    /// See [`Node::Housing`].
    pub housing: NodeParams,
    /// See [`Node::Structure`].
    pub structure: NodeParams,
    /// See [`Node::CoolantJacket`].
    pub coolant_jacket: NodeParams,
}

impl Nodes {
    /// Every node's parameters, in [`Node`] order (to scale them together).
    pub fn each_mut(&mut self) -> [&mut NodeParams; N_NODES] {
        [
            &mut self.front_bearing,
            &mut self.rear_bearing,
            &mut self.motor,
            &mut self.shaft,
            &mut self.housing,
            &mut self.structure,
            &mut self.coolant_jacket,
        ]
    }

    /// Parameters of `node`.
    pub fn get(&self, node: Node) -> &NodeParams {
        match node {
            Node::FrontBearing => &self.front_bearing,
            Node::RearBearing => &self.rear_bearing,
            Node::Motor => &self.motor,
            Node::Shaft => &self.shaft,
            Node::Housing => &self.housing,
            Node::Structure => &self.structure,
            Node::CoolantJacket => &self.coolant_jacket,
        }
    }
}

/// A conductance between two nodes, as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct LinkSpec {
    a: Spanned<String>,
    b: Spanned<String>,
    g_w_per_k: f64,
}

/// A conductance between two nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// One end.
    pub a: Node,
    /// The other end.
    pub b: Node,
    /// Conductance, W/K.
    pub g_w_per_k: f64,
}

/// Nominal boundary temperatures.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Boundary {
    /// Ambient air, deg C (constant in the nominal twin).
    pub ambient_c: f64,
    /// Coolant supply, deg C (constant in the nominal twin).
    pub coolant_c: f64,
}

/// Heat sources from spindle speed (air cutting).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Heat {
    /// Speed at which the `*_at_ref` losses are given, rpm.
    pub bearing_ref_rpm: f64,
    /// Front bearing friction at the reference speed, W.
    pub front_bearing_w_at_ref: f64,
    /// Rear bearing friction at the reference speed, W.
    pub rear_bearing_w_at_ref: f64,
    /// Exponent b of the friction power law Q = a n^b.
    pub bearing_exponent: f64,
    /// Motor losses whenever the spindle turns (magnetising current), W.
    pub motor_idle_w: f64,
    /// Motor iron losses at the reference speed, W.
    pub motor_iron_w_at_ref: f64,
    /// Exponent of the iron losses' speed law.
    pub motor_iron_exponent: f64,
}

/// Thermal expansion to tool-tip displacement.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expansion {
    /// Shaft expansion coefficient, um/(m K).
    pub shaft_alpha_um_per_m_k: f64,
    /// Shaft length that pushes the nose, mm.
    pub shaft_length_mm: f64,
    /// Housing expansion coefficient, um/(m K).
    pub housing_alpha_um_per_m_k: f64,
    /// Housing length that pushes the nose, mm.
    pub housing_length_mm: f64,
    /// Structure expansion coefficient, um/(m K).
    pub structure_alpha_um_per_m_k: f64,
    /// Structure length that pushes the nose, mm.
    pub structure_length_mm: f64,
    /// Yaw (XZ tilt) per kelvin of front-minus-rear bearing rise, urad/K.
    pub yaw_front_rear_urad_per_k: f64,
    /// Yaw per kelvin of housing rise, urad/K.
    pub yaw_housing_urad_per_k: f64,
    /// Pitch (YZ tilt) per kelvin of front-minus-rear bearing rise, urad/K.
    pub pitch_front_rear_urad_per_k: f64,
    /// Pitch per kelvin of structure rise, urad/K.
    pub pitch_structure_urad_per_k: f64,
}

/// The five-point probe set-up.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Probes {
    /// Axial distance between near and far radial probes, mm.
    pub spacing_mm: f64,
    /// Deflection centre above the spindle nose, mm.
    pub l_defl_mm: f64,
    /// Probe noise, one sigma, um.
    pub noise_um: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SiteSpec {
    node: Spanned<String>,
    toward: Option<Spanned<String>>,
    share: Option<f64>,
    name: Option<Spanned<String>>,
    offset_c: Option<f64>,
}

/// A displacement output as written: `[[output]] name = "ch3_um"`,
/// `um_per_k = { shaft = -1.4, structure = -9.0 }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputSpec {
    name: Spanned<String>,
    um_per_k: toml::Table,
}

/// An extra displacement column of the run file: a fixed linear combination
/// of node temperature rises (what `simulate --calibrate` fits to a real
/// machine's displacement channels, whose sensor places are unknown).
#[derive(Debug, Clone, PartialEq)]
pub struct DisplacementOutput {
    /// Column name, ending in `_um`.
    pub name: String,
    /// um per kelvin of each node's rise above the run's initial state, in
    /// state order.
    pub um_per_k: [f64; N_NODES],
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorsSpec {
    noise_c: f64,
    site: Vec<SiteSpec>,
}

/// A temperature sensor's place: `(1 - share) * T(node) + share * T(toward)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSite {
    /// Where it sits.
    pub node: Site,
    /// The second place it is between (same as `node` when it is on one).
    pub toward: Site,
    /// Weight of `toward`, 0..=1.
    pub share: f64,
    /// Constant added to the reading, K (a calibrated sensor's offset from
    /// the site temperature; 0 in the built-in machine).
    pub offset_c: f64,
}

/// Temperature sensors.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensors {
    /// Noise, one sigma, K.
    pub noise_c: f64,
    /// Sites of T1, T2, ...
    pub sites: Vec<SensorSite>,
    /// Column name of each site (`name = ...`, default `T1`, `T2`, ...).
    pub names: Vec<String>,
}

/// `ambient` effect parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmbientParams {
    /// Day/night amplitude, K.
    pub day_amplitude_c: f64,
    /// Clock hour of the warmest moment, h.
    pub warmest_clock_h: f64,
    /// Clock hour at t = 0, h.
    pub start_clock_h: f64,
    /// Slow drift, K/h.
    pub drift_c_per_h: f64,
    /// Expected door openings per day (Poisson, seeded).
    pub doors_per_day: f64,
    /// Ambient drop while the door is open, K.
    pub door_drop_c: f64,
    /// How long the door stays open, s.
    pub door_open_s: f64,
}

/// `coolant` effect parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoolantParams {
    /// The chiller starts cooling at `high_c` and stops at `low_c`, deg C.
    pub low_c: f64,
    /// See `low_c`.
    pub high_c: f64,
    /// Tank warming rate with the chiller off, K/min.
    pub warm_c_per_min: f64,
    /// Tank cooling rate with the chiller on, K/min.
    pub cool_c_per_min: f64,
}

/// `cutting` effect parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CuttingParams {
    /// Cutting power during a cut, kW.
    pub load_kw: f64,
    /// Machining cycle length, s.
    pub cycle_s: f64,
    /// Cutting share of each cycle, 0..=1.
    pub duty: f64,
    /// Share of cutting power entering the shaft through the tool.
    pub to_shaft_share: f64,
    /// Share of cutting power reaching the structure (chips, fluid).
    pub to_structure_share: f64,
    /// Motor efficiency under load (load losses = P (1/eta - 1)).
    pub motor_efficiency: f64,
}

/// `motor_loss` effect parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorLossParams {
    /// Extra motor losses as the speed tends to zero, W.
    pub extra_w_at_zero_rpm: f64,
    /// Speed above which there are no extra losses, rpm.
    pub knee_rpm: f64,
}

/// `sensor_lag` effect parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorLagParams {
    /// First-order time constant of the sensors on parts, s.
    pub tau_s: f64,
}

/// Parameters of each effect (CONTRACT.md section 3).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectParams {
    /// `ambient`.
    pub ambient: AmbientParams,
    /// `coolant`.
    pub coolant: CoolantParams,
    /// `cutting`.
    pub cutting: CuttingParams,
    /// `motor_loss`.
    pub motor_loss: MotorLossParams,
    /// `sensor_lag`.
    pub sensor_lag: SensorLagParams,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct MachineSpec {
    name: String,
    max_rpm: f64,
    tool_mm: f64,
    boundary: Boundary,
    nodes: Nodes,
    link: Vec<LinkSpec>,
    heat: Heat,
    expansion: Expansion,
    probes: Probes,
    sensors: SensorsSpec,
    effects: EffectParams,
    output: Option<Vec<OutputSpec>>,
}

/// A validated machine.
#[derive(Debug, Clone)]
pub struct Machine {
    /// Free-text name.
    pub name: String,
    /// Top speed, rpm.
    pub max_rpm: f64,
    /// Tool length, mm.
    pub tool_mm: f64,
    /// Nominal boundary temperatures.
    pub boundary: Boundary,
    /// Node parameters.
    pub nodes: Nodes,
    /// Conductances between nodes.
    pub links: Vec<Link>,
    /// Heat sources.
    pub heat: Heat,
    /// Expansion model.
    pub expansion: Expansion,
    /// Five-point probes.
    pub probes: Probes,
    /// Temperature sensors.
    pub sensors: Sensors,
    /// Effect parameters.
    pub effects: EffectParams,
    /// Extra displacement columns (`[[output]]`, written by a calibration).
    pub outputs: Vec<DisplacementOutput>,
}

impl Machine {
    /// The built-in machine ([`DEFAULT_MACHINE_TOML`]).
    pub fn default_machine() -> Machine {
        // The text is compiled in and a unit test parses it, so this cannot
        // fail at run time.
        #[allow(clippy::expect_used)]
        parse("<default machine>", DEFAULT_MACHINE_TOML).expect("the default machine is valid")
    }

    /// Reads and validates a machine file.
    pub fn load(path: &Path) -> Result<Machine> {
        let text = crate::data::fsio::read_text_capped(path)?;
        parse(&path.display().to_string(), &text)
    }
}

/// Parses and validates machine-file text; `file` names it in errors.
pub fn parse(file: &str, text: &str) -> Result<Machine> {
    let spec: MachineSpec = from_toml(file, text)?;
    let at = |s: &Spanned<String>| {
        let (l, c) = line_col(text, s.span().start);
        format!("{file}:{l}:{c}")
    };
    let node = |s: &Spanned<String>| -> Result<Node> {
        Node::from_name(s.get_ref()).ok_or_else(|| {
            anyhow!(
                "{}: unknown node \"{}\" (one of {})",
                at(s),
                s.get_ref(),
                Node::ALL.map(Node::name).join(", ")
            )
        })
    };
    let site = |s: &Spanned<String>| -> Result<Site> {
        Site::from_name(s.get_ref()).ok_or_else(|| {
            anyhow!(
                "{}: unknown sensor place \"{}\" (a node: {}; or ambient, coolant)",
                at(s),
                s.get_ref(),
                Node::ALL.map(Node::name).join(", ")
            )
        })
    };
    let mut links = Vec::with_capacity(spec.link.len());
    for l in &spec.link {
        let (a, b) = (node(&l.a)?, node(&l.b)?);
        if a == b {
            bail!("{}: a link joins \"{}\" to itself", at(&l.a), a.name());
        }
        if !(l.g_w_per_k.is_finite() && l.g_w_per_k >= 0.0) {
            bail!("{}: g_w_per_k must be finite and >= 0", at(&l.a));
        }
        links.push(Link {
            a,
            b,
            g_w_per_k: l.g_w_per_k,
        });
    }
    let mut sites = Vec::with_capacity(spec.sensors.site.len());
    let mut names = Vec::with_capacity(spec.sensors.site.len());
    for (i, s) in spec.sensors.site.iter().enumerate() {
        names.push(column_name(s.name.as_ref(), || format!("T{}", i + 1), &at)?);
        let offset_c = s.offset_c.unwrap_or(0.0);
        if !offset_c.is_finite() {
            bail!("{}: offset_c must be finite", at(&s.node));
        }
        let place = site(&s.node)?;
        let toward = match &s.toward {
            Some(t) => site(t)?,
            None => place,
        };
        let share = s.share.unwrap_or(0.0);
        if !(0.0..=1.0).contains(&share) {
            bail!("{}: share must be in 0..=1", at(&s.node));
        }
        sites.push(SensorSite {
            node: place,
            toward,
            share,
            offset_c,
        });
    }
    let mut outputs = Vec::new();
    for o in spec.output.iter().flatten() {
        outputs.push(output(o, &at)?);
    }
    unique_names(names.iter().chain(outputs.iter().map(|o| &o.name)))
        .map_err(|e| anyhow!("{file}: {e}"))?;
    let m = Machine {
        name: spec.name,
        max_rpm: spec.max_rpm,
        tool_mm: spec.tool_mm,
        boundary: spec.boundary,
        nodes: spec.nodes,
        links,
        heat: spec.heat,
        expansion: spec.expansion,
        probes: spec.probes,
        sensors: Sensors {
            noise_c: spec.sensors.noise_c,
            sites,
            names,
        },
        effects: spec.effects,
        outputs,
    };
    validate(&m).map_err(|e| {
        // Range errors start with the field's dotted path; point at it.
        let msg = e.to_string();
        let path = msg.split_whitespace().next().unwrap_or_default();
        match key_line_col(text, path) {
            Some((l, c)) => anyhow!("{file}:{l}:{c}: {msg}"),
            None => anyhow!("{file}: {msg}"),
        }
    })?;
    Ok(m)
}

/// Line and column (1-based) of the key `a.b.c` written as `c = ...` under
/// a `[a.b]` header (or `a = ...` at the top): where a range error's value
/// sits. `None` for any other layout (inline tables, dotted keys).
fn key_line_col(text: &str, path: &str) -> Option<(usize, usize)> {
    let (table, key) = path.rsplit_once('.').unwrap_or(("", path));
    let mut current = String::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if t.starts_with('[') {
            current = t
                .trim_end()
                .trim_matches(|c| c == '[' || c == ']')
                .trim()
                .to_string();
        } else if current == table {
            if let Some(rest) = t.strip_prefix(key) {
                if rest.trim_start().starts_with('=') {
                    let col = line.len() - t.len();
                    return Some((i + 1, col + 1));
                }
            }
        }
    }
    None
}

/// Columns a run file always has; a sensor or output may not take them.
const RESERVED_COLUMNS: [&str; 6] = [
    "t_s",
    "speed_rpm",
    "power_kw",
    "ambient_c",
    "coolant_c",
    "tool_mm",
];

/// A column name given in the file (checked), or the default.
fn column_name(
    given: Option<&Spanned<String>>,
    default: impl FnOnce() -> String,
    at: &dyn Fn(&Spanned<String>) -> String,
) -> Result<String> {
    let Some(n) = given else {
        return Ok(default());
    };
    let name = n.get_ref();
    let ok = !name.is_empty()
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.')
        && !RESERVED_COLUMNS.contains(&name.as_str());
    if !ok {
        bail!(
            "{}: column name \"{name}\" must be letters, digits, '_' or '.' and not one of {}",
            at(n),
            RESERVED_COLUMNS.join(", ")
        );
    }
    Ok(name.clone())
}

/// One `[[output]]`: a `*_um` name and known node names with finite gains.
fn output(o: &OutputSpec, at: &dyn Fn(&Spanned<String>) -> String) -> Result<DisplacementOutput> {
    let name = column_name(Some(&o.name), String::new, at)?;
    if !name.ends_with("_um") {
        bail!("{}: output name \"{name}\" must end in _um", at(&o.name));
    }
    let mut um_per_k = [0.0; N_NODES];
    for (k, v) in &o.um_per_k {
        let node = Node::from_name(k)
            .ok_or_else(|| anyhow!("{}: output \"{name}\": unknown node \"{k}\"", at(&o.name)))?;
        let v = v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                anyhow!(
                    "{}: output \"{name}\": um_per_k.{k} must be a finite number",
                    at(&o.name)
                )
            })?;
        um_per_k[node.index()] = v;
    }
    Ok(DisplacementOutput { name, um_per_k })
}

/// Sensor and output column names must not repeat, nor shadow the twin's
/// probe columns.
fn unique_names<'a>(names: impl Iterator<Item = &'a String>) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    for n in names {
        if ["S1", "S2", "S3", "S4", "S5"].contains(&n.as_str()) {
            bail!("column name \"{n}\" is taken by the probe readings");
        }
        if !seen.insert(n) {
            bail!("column name \"{n}\" is given twice");
        }
    }
    Ok(())
}

/// Lowest nominal ambient or coolant temperature a machine file may give, C.
pub const BOUNDARY_MIN_C: f64 = -50.0;
/// Highest nominal ambient or coolant temperature a machine file may give, C.
pub const BOUNDARY_MAX_C: f64 = 100.0;

/// `v` is finite and > 0, or an error naming the field `what`.
fn positive(v: f64, what: &str) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        bail!("{what} must be finite and > 0 (got {v})")
    }
}

/// `v` is finite and >= 0, or an error naming the field `what`.
fn non_negative(v: f64, what: &str) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        bail!("{what} must be finite and >= 0 (got {v})")
    }
}

/// `v` is finite, or an error naming the field `what`.
fn finite(v: f64, what: &str) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        bail!("{what} must be finite (got {v})")
    }
}

/// A nominal ambient or coolant temperature within
/// [`BOUNDARY_MIN_C`]..=[`BOUNDARY_MAX_C`]: air and coolant around a
/// machine tool, a shop floor in winter to a coolant at a boil. Beyond that
/// a value is a typo (-300 C is below absolute zero), and the twin would
/// model it without a word.
fn boundary_c(v: f64, what: &str) -> Result<()> {
    if v.is_finite() && (BOUNDARY_MIN_C..=BOUNDARY_MAX_C).contains(&v) {
        Ok(())
    } else {
        bail!("{what} must be in {BOUNDARY_MIN_C}..={BOUNDARY_MAX_C} C (got {v})")
    }
}

/// Each node's heat capacity and boundary conductances.
fn check_nodes(m: &Machine) -> Result<()> {
    for n in Node::ALL {
        let p = m.nodes.get(n);
        let name = n.name();
        positive(p.c_j_per_k, &format!("nodes.{name}.c_j_per_k"))?;
        non_negative(
            p.g_ambient_w_per_k,
            &format!("nodes.{name}.g_ambient_w_per_k"),
        )?;
        non_negative(
            p.g_coolant_w_per_k,
            &format!("nodes.{name}.g_coolant_w_per_k"),
        )?;
    }
    Ok(())
}

/// Every node has a path of positive conductances to a boundary, or its
/// temperature grows without bound and the network has no equilibrium.
fn check_grounded(m: &Machine) -> Result<()> {
    let mut grounded = [false; N_NODES];
    for n in Node::ALL {
        let p = m.nodes.get(n);
        grounded[n.index()] = p.g_ambient_w_per_k > 0.0 || p.g_coolant_w_per_k > 0.0;
    }
    loop {
        let mut changed = false;
        for l in m.links.iter().filter(|l| l.g_w_per_k > 0.0) {
            let (i, j) = (l.a.index(), l.b.index());
            if grounded[i] != grounded[j] {
                grounded[i] = true;
                grounded[j] = true;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    if let Some(n) = Node::ALL.into_iter().find(|n| !grounded[n.index()]) {
        bail!(
            "node \"{}\" has no path of conductances to ambient or coolant: it would heat without bound",
            n.name()
        );
    }
    Ok(())
}

/// The heat sources' reference values and exponents.
fn check_heat(m: &Machine) -> Result<()> {
    let h = &m.heat;
    positive(h.bearing_ref_rpm, "heat.bearing_ref_rpm")?;
    non_negative(h.front_bearing_w_at_ref, "heat.front_bearing_w_at_ref")?;
    non_negative(h.rear_bearing_w_at_ref, "heat.rear_bearing_w_at_ref")?;
    positive(h.bearing_exponent, "heat.bearing_exponent")?;
    non_negative(h.motor_idle_w, "heat.motor_idle_w")?;
    non_negative(h.motor_iron_w_at_ref, "heat.motor_iron_w_at_ref")?;
    positive(h.motor_iron_exponent, "heat.motor_iron_exponent")
}

/// The expansion coefficients (any sign) and lengths.
fn check_expansion(m: &Machine) -> Result<()> {
    let x = &m.expansion;
    for (v, what) in [
        (x.shaft_alpha_um_per_m_k, "expansion.shaft_alpha_um_per_m_k"),
        (
            x.housing_alpha_um_per_m_k,
            "expansion.housing_alpha_um_per_m_k",
        ),
        (
            x.structure_alpha_um_per_m_k,
            "expansion.structure_alpha_um_per_m_k",
        ),
        (
            x.yaw_front_rear_urad_per_k,
            "expansion.yaw_front_rear_urad_per_k",
        ),
        (x.yaw_housing_urad_per_k, "expansion.yaw_housing_urad_per_k"),
        (
            x.pitch_front_rear_urad_per_k,
            "expansion.pitch_front_rear_urad_per_k",
        ),
        (
            x.pitch_structure_urad_per_k,
            "expansion.pitch_structure_urad_per_k",
        ),
    ] {
        finite(v, what)?;
    }
    non_negative(x.shaft_length_mm, "expansion.shaft_length_mm")?;
    non_negative(x.housing_length_mm, "expansion.housing_length_mm")?;
    non_negative(x.structure_length_mm, "expansion.structure_length_mm")
}

/// The probes' geometry and noise, the sensors' noise, one sensor at least.
fn check_probes_and_sensors(m: &Machine) -> Result<()> {
    positive(m.probes.spacing_mm, "probes.spacing_mm")?;
    non_negative(m.probes.l_defl_mm, "probes.l_defl_mm")?;
    non_negative(m.probes.noise_um, "probes.noise_um")?;
    non_negative(m.sensors.noise_c, "sensors.noise_c")?;
    if m.sensors.sites.is_empty() {
        bail!("sensors.site: at least one sensor site is needed");
    }
    Ok(())
}

/// The ambient and coolant effects' parameters.
fn check_boundary_effects(e: &EffectParams) -> Result<()> {
    non_negative(e.ambient.day_amplitude_c, "effects.ambient.day_amplitude_c")?;
    finite(e.ambient.warmest_clock_h, "effects.ambient.warmest_clock_h")?;
    finite(e.ambient.start_clock_h, "effects.ambient.start_clock_h")?;
    finite(e.ambient.drift_c_per_h, "effects.ambient.drift_c_per_h")?;
    non_negative(e.ambient.doors_per_day, "effects.ambient.doors_per_day")?;
    finite(e.ambient.door_drop_c, "effects.ambient.door_drop_c")?;
    non_negative(e.ambient.door_open_s, "effects.ambient.door_open_s")?;
    finite(e.coolant.low_c, "effects.coolant.low_c")?;
    finite(e.coolant.high_c, "effects.coolant.high_c")?;
    if e.coolant.high_c <= e.coolant.low_c {
        bail!("effects.coolant: high_c must be above low_c");
    }
    positive(e.coolant.warm_c_per_min, "effects.coolant.warm_c_per_min")?;
    positive(e.coolant.cool_c_per_min, "effects.coolant.cool_c_per_min")
}

/// The cutting, motor-loss and sensor-lag effects' parameters.
fn check_load_effects(e: &EffectParams) -> Result<()> {
    non_negative(e.cutting.load_kw, "effects.cutting.load_kw")?;
    positive(e.cutting.cycle_s, "effects.cutting.cycle_s")?;
    for (v, what) in [
        (e.cutting.duty, "effects.cutting.duty"),
        (e.cutting.to_shaft_share, "effects.cutting.to_shaft_share"),
        (
            e.cutting.to_structure_share,
            "effects.cutting.to_structure_share",
        ),
    ] {
        if !(0.0..=1.0).contains(&v) {
            bail!("{what} must be in 0..=1 (got {v})");
        }
    }
    if !(e.cutting.motor_efficiency > 0.0 && e.cutting.motor_efficiency <= 1.0) {
        bail!("effects.cutting.motor_efficiency must be in (0, 1]");
    }
    non_negative(
        e.motor_loss.extra_w_at_zero_rpm,
        "effects.motor_loss.extra_w_at_zero_rpm",
    )?;
    positive(e.motor_loss.knee_rpm, "effects.motor_loss.knee_rpm")?;
    positive(e.sensor_lag.tau_s, "effects.sensor_lag.tau_s")
}

/// The fastest `max_rpm` a machine file may give, a bound well beyond
/// machine-tool spindles rather than a measured figure: 1e300 got as far
/// as a NaN in the probe geometry, with no word of the field.
pub const MAX_RPM_LIMIT: f64 = 1e6;

/// Range checks on the numbers, naming the field (the first error in
/// file order).
fn validate(m: &Machine) -> Result<()> {
    positive(m.max_rpm, "max_rpm")?;
    if m.max_rpm > MAX_RPM_LIMIT {
        bail!(
            "max_rpm must be at most {MAX_RPM_LIMIT} (got {:e}): no spindle turns faster",
            m.max_rpm
        );
    }
    let tools = crate::fivepoint::HUB_TOOL_MM;
    if !tools.contains(&m.tool_mm) {
        bail!(
            "tool_mm must be in 0 ..= {} mm, the hub's range (got {})",
            tools.end(),
            m.tool_mm
        );
    }
    boundary_c(m.boundary.ambient_c, "boundary.ambient_c")?;
    boundary_c(m.boundary.coolant_c, "boundary.coolant_c")?;
    check_nodes(m)?;
    check_grounded(m)?;
    check_heat(m)?;
    check_expansion(m)?;
    check_probes_and_sensors(m)?;
    check_boundary_effects(&m.effects)?;
    check_load_effects(&m.effects)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_machine_parses() {
        let m = parse("d.toml", DEFAULT_MACHINE_TOML);
        assert!(m.is_ok(), "{:?}", m.err());
        let m = Machine::default_machine();
        assert_eq!(m.links.len(), 11);
        assert_eq!(m.sensors.sites.len(), 10);
    }

    #[test]
    fn unknown_node_points_at_it() {
        let text = DEFAULT_MACHINE_TOML.replacen("b = \"shaft\"", "b = \"shaftt\"", 1);
        let e = format!(
            "{:#}",
            parse("m.toml", &text).err().map_or(anyhow!("ok"), |e| e)
        );
        assert!(
            e.starts_with("m.toml:") && e.contains("unknown node \"shaftt\""),
            "{e}"
        );
    }

    #[test]
    fn ungrounded_node_is_an_error() {
        let text =
            DEFAULT_MACHINE_TOML.replace("g_coolant_w_per_k = 600.0", "g_coolant_w_per_k = 0.0");
        // Still grounded through the housing and structure: fine.
        assert!(parse("m.toml", &text).is_ok());
        let text = text
            .replace("g_ambient_w_per_k = 50.0", "g_ambient_w_per_k = 0.0")
            .replace("g_ambient_w_per_k = 5.0", "g_ambient_w_per_k = 0.0")
            .replace("g_ambient_w_per_k = 3.0", "g_ambient_w_per_k = 0.0")
            .replace("g_ambient_w_per_k = 1.0", "g_ambient_w_per_k = 0.0")
            .replace("g_ambient_w_per_k = 0.5", "g_ambient_w_per_k = 0.0");
        let e = format!(
            "{:#}",
            parse("m.toml", &text).err().map_or(anyhow!("ok"), |e| e)
        );
        assert!(e.contains("no path of conductances"), "{e}");
    }
}
