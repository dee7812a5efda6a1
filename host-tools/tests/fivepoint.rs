//! Five-point compensation end to end (docs/fivepoint.md): `fivepoint`
//! reproduces the twin's own tool-tip drift from S1..S5 across tool
//! changes; a five-point model fitted on E and the tilts carries l_defl in
//! its blob, and the hub (replay) turns it into tip offsets that follow
//! each tool change by delta_tool x theta.

mod common;

use common::{fails_one_line, ok, ok_json, p, write};
use std::collections::HashMap;

/// The deflection centre of the twin's default machine, mm.
const L_DEFL_MM: f64 = 300.0;
/// Tool changes of the profile: (from t_s, tool_mm).
const TOOLS: [(f64, f64); 3] = [(0.0, 100.0), (2400.0, 250.0), (4800.0, 50.0)];

/// A CSV as a map column -> values (empty cells NaN).
fn read_csv(path: &str) -> HashMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut cols: HashMap<String, Vec<f64>> =
        header.iter().map(|h| (h.clone(), Vec::new())).collect();
    for line in lines {
        for (h, cell) in header.iter().zip(line.split(',')) {
            cols.get_mut(h)
                .unwrap()
                .push(cell.parse().unwrap_or(f64::NAN));
        }
    }
    cols
}

fn tool_at(t: f64) -> f64 {
    TOOLS
        .iter()
        .rev()
        .find(|(from, _)| t >= *from)
        .map_or(0.0, |(_, mm)| *mm)
}

/// A 2 h twin run at 1 s with the tool changes of [`TOOLS`], from the
/// default machine with noise-free probes (the twin writes dx/dy/dz from
/// the probes' raw readings, `fivepoint` from their change since the first
/// row: with probe noise the two differ by the first row's noise).
fn twin_run(dir: &std::path::Path) -> String {
    let (machine, _) = ok(&["simulate", "--print-machine"]);
    let machine = machine.replace("noise_um = 0.1", "noise_um = 0.0");
    assert!(
        machine.contains("noise_um = 0.0"),
        "probe noise switched off"
    );
    let machine = write(dir, "m.toml", &machine);
    let mut profile = String::from("t_s,speed_rpm,tool_mm\n");
    for k in 0..=7200 {
        let t = f64::from(k);
        let rpm = if k < 3600 { 6000 } else { 9000 };
        profile.push_str(&format!("{k},{rpm},{}\n", tool_at(t)));
    }
    let profile = write(dir, "profile.csv", &profile);
    let sim = dir.join("sim.csv");
    ok(&[
        "simulate",
        "--out",
        p(&sim),
        "--machine",
        &machine,
        "--profile",
        &format!("file:{profile}"),
        "--seed",
        "3",
    ]);
    p(&sim).to_string()
}

/// The run file `path` with its `tool_mm` cells emptied wherever the
/// length equals the row before's (a CNC log written on tool changes).
fn tool_only_on_change(path: &str) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let i = header.split(',').position(|h| h == "tool_mm").unwrap();
    let mut out = format!("{header}\n");
    let mut last = String::new();
    let mut emptied = 0;
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        if cells[i] == last {
            cells[i].clear();
            emptied += 1;
        } else {
            last = cells[i].clone();
        }
        out += &(cells.join(",") + "\n");
    }
    assert!(emptied > 7000, "{emptied} cells emptied");
    out
}

#[test]
fn fivepoint_reproduces_the_twin_tip_and_a_hub_model_follows_tool_changes() {
    let dir = tempfile::tempdir().unwrap();
    let sim = twin_run(dir.path());
    let fp = dir.path().join("fp.csv");
    let j = ok_json(&["fivepoint", "--data", &sim, "--out", p(&fp), "--json"]);
    assert_eq!(j["rows"], 7201);
    assert_eq!(j["tip_rows"], 7201);
    assert_eq!(j["tool_from"], "tool_mm");
    let c = read_csv(p(&fp));
    // 1. The tip from S1..S5 is the twin's own, within 0.1 um (the twin
    //    writes S and dx with 4 decimals: 1e-4 um per probe, times
    //    (l_defl + tool) / a <= 5 for the angles: ~1e-3 um in fact).
    let mut worst: f64 = 0.0;
    for axis in ["dx_um", "dy_um", "dz_um"] {
        for (ours, twin) in c[axis].iter().zip(&c[&format!("{axis}_run")]) {
            worst = worst.max((ours - twin).abs());
        }
    }
    assert!(worst < 0.1, "worst |fivepoint - twin| = {worst} um");
    eprintln!("fivepoint vs twin tip: worst {worst:.2e} um over 3 x 7201 rows");
    // The twin's radial drift does jump at each tool change.
    let k = 2400;
    let jump = c["dx_um"][k] - c["dx_um"][k - 1];
    let theta = c["theta_x_urad"][k] * 1e-6;
    assert!(
        (jump - 150_000.0 * theta).abs() < 0.01,
        "{jump} vs {}",
        150_000.0 * theta
    );

    // 2. A five-point model: MLR of E and the tilts on the temperatures.
    let blob = dir.path().join("fp.bin");
    let fit = ok_json(&[
        "fit",
        "--data",
        p(&fp),
        "--target",
        "e_um,theta_x_urad,theta_y_urad",
        "--model",
        "mlr",
        "--out",
        p(&blob),
        "--json",
    ]);
    assert_eq!(fit["l_defl_mm"], L_DEFL_MM);
    let show = ok_json(&["model", "show", "--model", p(&blob), "--json"]);
    assert_eq!(show["five_point"]["l_defl_mm"], L_DEFL_MM);
    assert_eq!(show["format_version"], 3);

    // predict writes the tip from each row's tool_mm; eval scores it.
    let pred = dir.path().join("pred.csv");
    ok(&[
        "predict",
        "--model",
        p(&blob),
        "--data",
        p(&fp),
        "--out",
        p(&pred),
    ]);
    let pr = read_csv(p(&pred));
    // Each row's tip uses that row's tool: dx = (l_defl + tool) theta_x
    // within 0.01 um (the exact geometry adds E theta_x, ~1e-4 um).
    for k in (0..7201).step_by(7) {
        let l_um = (L_DEFL_MM + c["tool_mm"][k]) * 1e3;
        let dx = l_um * pr["theta_x_urad_pred"][k] * 1e-6;
        assert!((pr["dx_um_pred"][k] - dx).abs() < 0.01, "row {k}");
        assert!(
            (pr["dz_um_pred"][k] + pr["e_um_pred"][k]).abs() < 0.01,
            "row {k}"
        );
    }
    let ev = ok_json(&["eval", "--model", p(&blob), "--data", p(&fp), "--json"]);
    for key in ["e_um", "theta_x_urad", "dx_um", "dy_um", "dz_um"] {
        assert_eq!(ev[key]["n"], 7201, "{key} scored on every row");
    }
    // The tool logged only where it changes: predict holds the last length
    // logged, so every tip is the one from the full column, to the bit.
    let sparse = dir.path().join("sparse.csv");
    std::fs::write(&sparse, tool_only_on_change(p(&fp))).unwrap();
    let pred_sparse = dir.path().join("pred_sparse.csv");
    ok(&[
        "predict",
        "--model",
        p(&blob),
        "--data",
        p(&sparse),
        "--out",
        p(&pred_sparse),
    ]);
    let ps = read_csv(p(&pred_sparse));
    for axis in ["dx_um_pred", "dy_um_pred", "dz_um_pred"] {
        assert_eq!(ps[axis], pr[axis], "{axis}");
    }

    // 3. The hub: replay sends tool_mm in TOOL_POSITION frames; its lanes
    //    are dx, dy, dz.
    let (log, trace) = (dir.path().join("out.log"), dir.path().join("trace.csv"));
    let r = ok_json(&[
        "replay",
        "--model",
        p(&blob),
        "--data",
        p(&fp),
        "--candump",
        p(&log),
        "--trace",
        p(&trace),
        "--json",
    ]);
    assert_eq!(r["outputs"], serde_json::json!(["dx_um", "dy_um", "dz_um"]));
    let tr = read_csv(p(&trace));
    let sent = |axis: &str, k: usize| tr[&format!("{axis}_sent")][k];
    // predict on the inputs as the hub read them (after the converter's
    // quantisation) and the tool length it used: after the slew-limited
    // start (offsets start at 0), every sent value is that tip within half
    // a frame LSB (0.05 um).
    let hub_pred = dir.path().join("hub_pred.csv");
    ok(&[
        "predict",
        "--model",
        p(&blob),
        "--data",
        p(&trace),
        "--out",
        p(&hub_pred),
    ]);
    let pr = read_csv(p(&hub_pred));
    for axis in ["dx_um", "dy_um", "dz_um"] {
        let want = &pr[&format!("{axis}_pred")];
        let got = &tr[&format!("{axis}_sent")];
        assert_eq!(got.len(), 7201);
        for (k, (g, w)) in got.iter().zip(want).enumerate().skip(600) {
            assert!(
                (g - w).abs() <= 0.05 + 1e-9,
                "{axis} at {k}: sent {g} pred {w}"
            );
        }
    }
    // At each tool change the radial offsets move by delta_tool x theta
    // at once (under one 2 um slew step here). On the hub's tip before the
    // frame's rounding (predict on the hub's own inputs, equal to the sent
    // value within 0.05 um above), the jump less the model's own change
    // over that second, (l_defl + old tool)(theta(k) - theta(k-1)), is
    // delta_tool x theta(k) within 1e-3 um (the exact geometry's E x theta
    // terms are ~1e-4 um). The sent offsets are (l_defl + tool) x theta
    // within 0.1 um (0.05 um rounding, plus E x theta).
    for w in TOOLS.windows(2) {
        let (k, d_tool_um) = (w[1].0 as usize, (w[1].1 - w[0].1) * 1e3);
        let l_old_um = (L_DEFL_MM + w[0].1) * 1e3;
        let theta = |axis: &str, k: usize| pr[&format!("theta_{axis}_urad_pred")][k] * 1e-6;
        let (tx, ty) = (theta("x", k), theta("y", k));
        let tool_part = |tip: &str, axis: &str| {
            pr[tip][k] - pr[tip][k - 1] - l_old_um * (theta(axis, k) - theta(axis, k - 1))
        };
        let (jx, jy) = (tool_part("dx_um_pred", "x"), tool_part("dy_um_pred", "y"));
        assert!(
            (jx - d_tool_um * tx).abs() <= 1e-3,
            "dx jump {jx} vs {}",
            d_tool_um * tx
        );
        assert!(
            (jy - d_tool_um * ty).abs() <= 1e-3,
            "dy jump {jy} vs {}",
            d_tool_um * ty
        );
        assert!(jx.abs() > 0.2, "the change is visible: {jx}");
        let l_um = (L_DEFL_MM + w[1].1) * 1e3;
        let (sx, sy) = (sent("dx_um", k), sent("dy_um", k));
        assert!((sx - l_um * tx).abs() <= 0.1, "dx {sx} vs {}", l_um * tx);
        assert!((sy - l_um * ty).abs() <= 0.1, "dy {sy} vs {}", l_um * ty);
        eprintln!(
            "tool change at {k} s to {} mm: dx {jx:+.4} um (delta_tool theta_x {:+.4}), dy {jy:+.4} um ({:+.4}); sent dx {sx:.1} vs (l+tool) theta_x {:.4}",
            w[1].1, d_tool_um * tx, d_tool_um * ty, l_um * tx
        );
    }
}

#[test]
fn fivepoint_keeps_empty_cells_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let run = write(
        dir.path(),
        "run.csv",
        "t_s,S1,S2,S3,S4,S5,note\n0,10,20,30,40,50,cold\n1,22,20,,40,70,\n2,22,20,30,40,70,warm\n",
    );
    let out = dir.path().join("out.csv");
    ok(&[
        "fivepoint",
        "--data",
        &run,
        "--out",
        p(&out),
        "--tool-mm",
        "100",
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 4, "every row kept: {text}");
    assert_eq!(
        lines[0],
        "t_s,e_um,theta_x_urad,theta_y_urad,dx_um,dy_um,dz_um,S1,S2,S3,S4,S5,note"
    );
    // Row 1 has no S3: theta_x and the tip empty, E = 20 and theta_y = 0 kept.
    assert!(
        lines[2].starts_with("1,20,,0,,,,22,20,,40,70,"),
        "{}",
        lines[2]
    );
    assert!(
        lines[3].ends_with(",warm"),
        "text columns are copied: {}",
        lines[3]
    );
    // No tool length anywhere: a clear error. Output = input: refused.
    let e = fails_one_line(&["fivepoint", "--data", &run, "--out", p(&out)]);
    assert!(e.contains("tool_mm"), "{e}");
    let e = fails_one_line(&["fivepoint", "--data", &run, "--out", &run, "--tool-mm", "1"]);
    assert!(e.contains("--out"), "{e}");
    let bad = write(
        dir.path(),
        "bad.csv",
        "t_s,S1,S2,S3,S4,S5\n0,1,2,3,4,5\n1,1,2,x,4,5\n",
    );
    let e = fails_one_line(&[
        "fivepoint",
        "--data",
        &bad,
        "--out",
        p(&out),
        "--tool-mm",
        "1",
    ]);
    assert!(e.contains("bad.csv:3:4"), "file:line:column: {e}");
    let e = fails_one_line(&[
        "fivepoint",
        "--data",
        &run,
        "--out",
        p(&out),
        "--a-mm",
        "0",
        "--tool-mm",
        "1",
    ]);
    assert!(e.contains("--a-mm"), "{e}");
}
