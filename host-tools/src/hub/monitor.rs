//! Telemetry as one line of text or one JSON object per message.

use firmware::protocol::Telemetry;
use firmware::report::{HubState, StatusFlags};
use serde_json::{json, Value};

/// Names for the offsets and temperatures, from the model the hub runs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Names {
    /// Model outputs, in `offsets_um` order.
    pub outputs: Vec<String>,
    /// Model inputs, in `temps_c` order.
    pub inputs: Vec<String>,
}

/// `StatusFlags` bits and their names (bit positions: the wire format).
const FLAGS: [(u16, &str); 10] = [
    (StatusFlags::SENSOR_FAULT, "SENSOR_FAULT"),
    (StatusFlags::SPIKE_REJECTED, "SPIKE_REJECTED"),
    (StatusFlags::STALE, "STALE"),
    (StatusFlags::MODEL_FAULT, "MODEL_FAULT"),
    (StatusFlags::CLAMPED, "CLAMPED"),
    (StatusFlags::SLEW_LIMITED, "SLEW_LIMITED"),
    (StatusFlags::NO_MODEL, "NO_MODEL"),
    (StatusFlags::UPLOADING, "UPLOADING"),
    (StatusFlags::RECOVERING, "RECOVERING"),
    (StatusFlags::EXTRAPOLATING, "EXTRAPOLATING"),
];

/// The state's name (`NoModel`, `Running`, ...), or `state N` if unknown.
pub fn state_name(code: u8) -> String {
    HubState::from_code(code).map_or_else(|| format!("state {code}"), |s| format!("{s:?}"))
}

/// Names of the flags set (`bit N` for a bit this thermcomp does not know).
pub fn flag_names(flags: u16) -> Vec<String> {
    (0..16)
        .map(|i| 1u16 << i)
        .filter(|b| flags & b != 0)
        .map(|b| {
            FLAGS.iter().find(|(m, _)| *m == b).map_or_else(
                || format!("bit {}", b.trailing_zeros()),
                |(_, n)| n.to_string(),
            )
        })
        .collect()
}

fn offsets(t: &Telemetry) -> &[f32] {
    let n = usize::from(t.n_outputs).min(t.offsets_um.len());
    &t.offsets_um[..n]
}

fn faulty(t: &Telemetry) -> Vec<usize> {
    (0..32)
        .filter(|i| t.faulty_channels & (1 << i) != 0)
        .collect()
}

fn label(names: Option<&[String]>, i: usize, fallback: &str) -> String {
    names
        .and_then(|n| n.get(i))
        .cloned()
        .unwrap_or_else(|| format!("{fallback}{i}"))
}

/// One line of text: sequence, state, offsets, temperatures, flags.
pub fn text_line(t: &Telemetry, names: Option<&Names>) -> String {
    let outs = names.map(|n| n.outputs.as_slice());
    let ins = names.map(|n| n.inputs.as_slice());
    let mut line = format!("seq {} {}", t.seq, state_name(t.state));
    line.push_str(" | offsets_um");
    for (i, v) in offsets(t).iter().enumerate() {
        line.push_str(&format!(" {}={v:.3}", label(outs, i, "out")));
    }
    line.push_str(" | temps_c");
    for (i, v) in t.temps_c.iter().enumerate() {
        let v = if v.is_finite() {
            format!("{v:.2}")
        } else {
            "--".into()
        };
        line.push_str(&format!(" {}={v}", label(ins, i, "in")));
    }
    let flags = flag_names(t.flags);
    if !flags.is_empty() {
        line.push_str(&format!(" | flags {}", flags.join(",")));
    }
    let bad = faulty(t);
    if !bad.is_empty() {
        let bad: Vec<String> = bad.iter().map(|&i| label(ins, i, "in")).collect();
        line.push_str(&format!(" | faulty {}", bad.join(",")));
    }
    line
}

/// One JSON object (temperatures not read are `null`).
pub fn json_line(t: &Telemetry, names: Option<&Names>) -> Value {
    let num = |v: f32| {
        if v.is_finite() {
            json!(f64::from(v))
        } else {
            Value::Null
        }
    };
    let mut o = json!({
        "seq": t.seq,
        "state": state_name(t.state),
        "state_code": t.state,
        "flags": flag_names(t.flags),
        "flags_bits": t.flags,
        "offsets_um": offsets(t).iter().map(|&v| num(v)).collect::<Vec<_>>(),
        "temps_c": t.temps_c.iter().map(|&v| num(v)).collect::<Vec<_>>(),
        "faulty_channels": faulty(t),
    });
    if let (Some(n), Some(map)) = (names, o.as_object_mut()) {
        map.insert("outputs".into(), json!(n.outputs));
        map.insert("inputs".into(), json!(n.inputs));
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t() -> Telemetry {
        Telemetry {
            seq: 42,
            offsets_um: [12.3456, -3.2, 0.0, 0.0],
            n_outputs: 2,
            state: 1,
            flags: StatusFlags::SLEW_LIMITED | StatusFlags::SENSOR_FAULT | 1 << 12,
            faulty_channels: 0b10,
            temps_c: heapless::Vec::from_slice(&[21.5, f32::NAN]).unwrap(),
        }
    }

    #[test]
    fn text_without_and_with_names() {
        assert_eq!(
            text_line(&t(), None),
            "seq 42 Running | offsets_um out0=12.346 out1=-3.200 | temps_c in0=21.50 in1=-- \
             | flags SENSOR_FAULT,SLEW_LIMITED,bit 12 | faulty in1"
        );
        let names = Names {
            outputs: vec!["dx_um".into(), "dz_um".into()],
            inputs: vec!["T1".into(), "T2".into()],
        };
        let line = text_line(&t(), Some(&names));
        assert!(
            line.contains("dz_um=-3.200") && line.contains("faulty T2"),
            "{line}"
        );
    }

    #[test]
    fn json_object() {
        let v = json_line(&t(), None);
        assert_eq!(v["seq"], 42);
        assert_eq!(v["state"], "Running");
        assert_eq!(v["offsets_um"].as_array().unwrap().len(), 2);
        assert_eq!(v["temps_c"][1], Value::Null);
        assert_eq!(v["faulty_channels"], json!([1]));
        assert_eq!(v["flags"][1], "SLEW_LIMITED");
    }

    #[test]
    fn unknown_state() {
        assert_eq!(state_name(0), "NoModel");
        assert_eq!(state_name(77), "state 77");
    }
}
