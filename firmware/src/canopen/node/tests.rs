//! The node end to end: NMT transitions (what each state accepts and
//! sends), PDOs against the `can_frames`/`can_rx` encoders, heartbeat
//! timing, EMCY, settings over SDO.

use super::*;
use crate::can_frames::{encode_report, RawFrame};
use crate::can_rx::{decode_rx, encode_spindle, encode_tool_position, Spindle, ToolPosition};
use crate::report::{HubState, StatusFlags};
use embedded_can::StandardId;
use std::string::{String, ToString};
use std::vec::Vec;

fn raw(id: u16, data: &[u8]) -> RawFrame {
    RawFrame::new(StandardId::new(id).unwrap(), data).unwrap()
}

fn hex(frames: &[RawFrame]) -> Vec<String> {
    frames.iter().map(ToString::to_string).collect()
}

fn booted(settings: Settings) -> Node {
    let mut n = Node::new(settings).unwrap();
    let up: RawFrame = n.boot(0).unwrap();
    assert_eq!(up.raw_id(), 0x700 + u16::from(settings.node_id));
    assert_eq!(up.data(), &[0x00]);
    n
}

fn report(seq: u32) -> Report {
    Report {
        seq,
        offsets: [1.0, -1.0, 12.34, 0.0],
        n_outputs: 3,
        state: HubState::Running,
        ..Report::default()
    }
}

fn send(n: &mut Node, id: u16, data: &[u8]) -> Reaction<RawFrame> {
    n.on_frame(&raw(id, data), 0)
}

const SDO_HB: [u8; 8] = [0x40, 0x17, 0x10, 0, 0, 0, 0, 0];

#[test]
fn tpdo1_is_the_documented_offsets_frame() {
    // docs/wire-format.md: dx 1.0, dy -1.0, dz 12.34 um, Running, sample 0x105.
    let mut n = booted(Settings::DEFAULT);
    let frames: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> =
        n.on_sample(&report(0x105), &StatusInfo::default());
    assert_eq!(frames[0].to_string(), "181#0A00F6FF7B000105");
    assert_eq!(frames[1].to_string(), "281#0000000000600005");
    assert_eq!(frames.len(), 2);
}

#[test]
fn tpdos_equal_the_can_frames_encoder() {
    let mut n = booted(Settings::DEFAULT);
    let cases = [
        Report {
            seq: 7,
            offsets: [500.0, -3300.0, 0.04, -0.06],
            slopes_um_per_m: [0.0, 123.4567, 0.0, -2.5],
            positional: 0b1010,
            n_outputs: 4,
            state: HubState::Holding,
            flags: StatusFlags(StatusFlags::SENSOR_FAULT | StatusFlags::STUCK),
            faulty_channels: 0x0180_0001,
        },
        Report {
            seq: 0x1FF,
            offsets: [f64::NAN, 1e9, -1e9, 0.0],
            n_outputs: 2,
            state: HubState::Ramping,
            flags: StatusFlags(StatusFlags::STALE),
            faulty_channels: 1 << 23,
            ..Report::default()
        },
        Report::default(),
    ];
    let info = StatusInfo {
        n_inputs: 32,
        consecutive_faults: 300,
    };
    for r in &cases {
        let ours: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> = n.on_sample(r, &info);
        let theirs = encode_report::<RawFrame>(r, &info);
        // EMCYs (0x081) come first; the rest is exactly the old frames.
        let pdos: Vec<RawFrame> = ours.into_iter().filter(|f| f.raw_id() != 0x81).collect();
        assert_eq!(hex(&pdos), hex(&theirs), "{r:?}");
    }
}

#[test]
fn rpdos_decode_as_the_can_rx_frames() {
    let mut n = booted(Settings::DEFAULT);
    let frames = [
        encode_spindle::<RawFrame>(&Spindle {
            speed_rpm: Some(12_000.0),
            power_kw: Some(15.5),
        })
        .unwrap(),
        encode_spindle::<RawFrame>(&Spindle {
            speed_rpm: Some(-800.25),
            power_kw: None,
        })
        .unwrap(),
        encode_tool_position::<RawFrame>(&ToolPosition {
            tool_mm: Some(123.456),
            position_mm: Some(-0.5),
        })
        .unwrap(),
        encode_tool_position::<RawFrame>(&ToolPosition {
            tool_mm: None,
            position_mm: Some(600.0),
        })
        .unwrap(),
    ];
    for f in &frames {
        let r = n.on_frame(f, 0);
        assert!(r.frames.is_empty());
        assert_eq!(r.event, Some(Event::Input(decode_rx(f).unwrap())), "{f}");
    }
    // The objects hold the raw values: 0x2200:01 = 1,200,000 - 80,025... the last spindle.
    assert_eq!(n.dictionary().get(od::SPINDLE, 1) as i32, -80_025);
    assert_eq!(n.dictionary().get(od::SPINDLE, 2), 0x7FFF);
    // 6 bytes: not processed, EMCY 0x8210 (CiA 301 §7.2.2.2).
    let r = send(&mut n, 0x201, &[1, 2, 3, 4, 5, 6]);
    assert_eq!(r.event, None);
    assert_eq!(hex(&r.frames), ["081#1082000000000000"]);
    assert_eq!(n.dictionary().get(od::SPINDLE, 1) as i32, -80_025);
}

#[test]
fn nmt_states_accept_and_send() {
    let mut s = Settings::DEFAULT;
    s.auto_start = false;
    let mut n = booted(s);
    let sample = |n: &mut Node| -> Vec<String> {
        let f: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> =
            n.on_sample(&report(1), &StatusInfo::default());
        hex(&f)
    };
    let spindle = [0x80, 0x4F, 0x12, 0x00, 0x0E, 0x06, 0x00, 0x00];

    // Pre-operational: SDO yes, PDOs no, heartbeat 0x7F.
    assert_eq!(n.state(), NmtState::PreOperational);
    assert_eq!(
        hex(&send(&mut n, 0x601, &SDO_HB).frames),
        ["581#4B171000E8030000"]
    );
    assert_eq!(send(&mut n, 0x201, &spindle).event, None);
    assert!(sample(&mut n).is_empty());
    let hb: Option<RawFrame> = n.poll_heartbeat(1000);
    assert_eq!(hb.unwrap().to_string(), "701#7F");

    // Start (to all nodes): operational, PDOs both ways, heartbeat 0x05.
    assert!(send(&mut n, 0x000, &[0x01, 0x00]).frames.is_empty());
    assert_eq!(n.state(), NmtState::Operational);
    assert!(matches!(
        send(&mut n, 0x201, &spindle).event,
        Some(Event::Input(_))
    ));
    assert_eq!(sample(&mut n).len(), 2);
    let hb: Option<RawFrame> = n.poll_heartbeat(2000);
    assert_eq!(hb.unwrap().to_string(), "701#05");

    // A command for node 2 is not ours.
    send(&mut n, 0x000, &[0x02, 0x02]);
    assert_eq!(n.state(), NmtState::Operational);

    // Stop: no SDO, no PDO, no EMCY; heartbeat 0x04; NMT still heard.
    send(&mut n, 0x000, &[0x02, 0x01]);
    assert_eq!(n.state(), NmtState::Stopped);
    assert!(send(&mut n, 0x601, &SDO_HB).frames.is_empty());
    assert_eq!(send(&mut n, 0x201, &spindle).event, None);
    let mut faulty = report(2);
    faulty.flags = StatusFlags(StatusFlags::MODEL_FAULT);
    let f: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> =
        n.on_sample(&faulty, &StatusInfo::default());
    assert!(f.is_empty());
    let hb: Option<RawFrame> = n.poll_heartbeat(3000);
    assert_eq!(hb.unwrap().to_string(), "701#04");

    // Enter pre-operational.
    send(&mut n, 0x000, &[0x80, 0x01]);
    assert_eq!(n.state(), NmtState::PreOperational);

    // Reset communication: boot-up again, heartbeat time back to the
    // stored 1000 ms, pre-operational.
    send(
        &mut n,
        0x601,
        &[0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0x00, 0x00],
    );
    assert_eq!(n.dictionary().get(0x1017, 0), 500);
    let r = n.on_frame(&raw(0x000, &[0x82, 0x01]), 10_000);
    assert_eq!(hex(&r.frames), ["701#00"]);
    assert_eq!(n.state(), NmtState::PreOperational);
    assert_eq!(n.dictionary().get(0x1017, 0), 1000);
    assert_eq!(n.poll_heartbeat::<RawFrame>(10_999), None);
    assert!(n.poll_heartbeat::<RawFrame>(11_000).is_some());

    // Reset node: the application's job.
    assert_eq!(
        send(&mut n, 0x000, &[0x81, 0x00]).event,
        Some(Event::ResetNode)
    );
    // Malformed NMT (1 byte, unknown specifier): ignored.
    assert_eq!(send(&mut n, 0x000, &[0x01]), Reaction::none());
    assert_eq!(send(&mut n, 0x000, &[0x05, 0x01]), Reaction::none());
    assert_eq!(n.state(), NmtState::PreOperational);
}

#[test]
fn heartbeat_timing_and_period_change() {
    let mut n = booted(Settings::DEFAULT); // boot at 0 ms, operational
    assert_eq!(n.poll_heartbeat::<RawFrame>(999), None);
    assert_eq!(
        n.poll_heartbeat::<RawFrame>(1000).unwrap().to_string(),
        "701#05"
    );
    assert_eq!(n.poll_heartbeat::<RawFrame>(1999), None);
    assert!(n.poll_heartbeat::<RawFrame>(2000).is_some());
    // 0x1017 = 0 turns it off at once.
    send(&mut n, 0x601, &[0x2B, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(n.poll_heartbeat::<RawFrame>(60_000), None);
    // 250 ms: due at the next poll, then every 250 ms.
    send(&mut n, 0x601, &[0x2B, 0x17, 0x10, 0x00, 0xFA, 0, 0, 0]);
    assert!(n.poll_heartbeat::<RawFrame>(60_001).is_some());
    assert_eq!(n.poll_heartbeat::<RawFrame>(60_250), None);
    assert!(n.poll_heartbeat::<RawFrame>(60_251).is_some());
    // Before boot-up nothing is sent.
    let mut fresh = Node::new(Settings::DEFAULT).unwrap();
    assert_eq!(fresh.poll_heartbeat::<RawFrame>(5000), None);
}

#[test]
fn emcy_before_the_tpdos_and_its_reset() {
    let mut n = booted(Settings::DEFAULT);
    let mut r = report(3);
    r.state = HubState::Holding;
    r.flags = StatusFlags(StatusFlags::SENSOR_FAULT);
    r.faulty_channels = 0b10;
    let f: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> = n.on_sample(&r, &StatusInfo::default());
    assert_eq!(f[0].to_string(), "081#0050810100020000");
    assert_eq!(f[1].raw_id(), 0x181);
    assert_eq!(n.dictionary().get(0x1001, 0), 0x81);
    let f: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> =
        n.on_sample(&report(4), &StatusInfo::default());
    assert_eq!(f[0].to_string(), "081#0000000000000000");
    assert_eq!(n.dictionary().get(0x1001, 0), 0);
    // The error register by SDO.
    assert_eq!(
        hex(&send(&mut n, 0x601, &[0x40, 0x01, 0x10, 0, 0, 0, 0, 0]).frames),
        ["581#4F01100000000000"]
    );
}

#[test]
fn settings_over_sdo_checked_and_stored() {
    let mut n = booted(Settings::DEFAULT);
    // Ramp 3 um/s is faster than the 2 um/s slew: 0x06040043, unchanged.
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x03, 0x20, 0x00, 0x00, 0x00, 0x40, 0x40],
    );
    assert_eq!(hex(&r.frames), ["581#8003200043000406"]);
    assert_eq!(n.dictionary().get_f32(od::RAMP_RATE, 0), 1.0);
    // Plausible max below min: refused the same way.
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x05, 0x20, 0x02, 0x00, 0x00, 0xA0, 0xC1],
    );
    assert_eq!(hex(&r.frames), ["581#8005200243000406"]);
    // Clamp of output 2 = 100 um (0x42C80000): accepted, not yet running.
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x00, 0x20, 0x02, 0x00, 0x00, 0xC8, 0x42],
    );
    assert_eq!(hex(&r.frames), ["581#6000200200000000"]);
    assert_eq!(r.event, None);
    assert_eq!(n.settings().clamp_um[1], 500.0);
    // "save" (73 61 76 65) to 0x1010:01: the settings to store.
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'e'],
    );
    assert_eq!(hex(&r.frames), ["581#6010100100000000"]);
    let mut want = Settings::DEFAULT;
    want.clamp_um[1] = 100.0;
    assert_eq!(r.event, Some(Event::Store(want)));
    // Anything else: 0x08000020.
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'E'],
    );
    assert_eq!(hex(&r.frames), ["581#8010100120000008"]);
    assert_eq!(r.event, None);
    // "load" to 0x1011:01: store the defaults.
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x11, 0x10, 0x01, b'l', b'o', b'a', b'd'],
    );
    assert_eq!(r.event, Some(Event::Store(Settings::DEFAULT)));
    // An axis position by RPDO2 (tool length "not available")...
    let r = send(
        &mut n,
        0x301,
        &[0xFF, 0xFF, 0xFF, 0x7F, 0xE8, 0x03, 0x00, 0x00],
    );
    assert_eq!(
        r.event,
        Some(Event::Input(RxMessage::ToolPosition(ToolPosition {
            tool_mm: None,
            position_mm: Some(1.0),
        })))
    );
    // ...then the tool length by SDO: the same input as RPDO2, delivered
    // alone (the position the dictionary still holds is not re-delivered
    // as if it had just arrived).
    let r = send(
        &mut n,
        0x601,
        &[0x23, 0x01, 0x22, 0x01, 0x40, 0xE2, 0x01, 0x00],
    );
    assert_eq!(
        r.event,
        Some(Event::Input(RxMessage::ToolPosition(ToolPosition {
            tool_mm: Some(123.456),
            position_mm: None,
        })))
    );
}

#[test]
fn another_node_id_moves_every_cob_id() {
    let mut s = Settings::DEFAULT;
    s.node_id = 0x25;
    let mut n = booted(s);
    assert_eq!(n.rx_ids(), [0x000, 0x625, 0x225, 0x325]);
    assert_eq!(
        hex(&send(&mut n, 0x625, &SDO_HB).frames),
        ["5A5#4B171000E8030000"]
    );
    assert!(send(&mut n, 0x601, &SDO_HB).frames.is_empty());
    let f: heapless::Vec<RawFrame, SAMPLE_FRAMES_MAX> =
        n.on_sample(&report(0x105), &StatusInfo::default());
    assert_eq!(f[0].to_string(), "1A5#0A00F6FF7B000105");
    assert_eq!(
        n.poll_heartbeat::<RawFrame>(1000).unwrap().to_string(),
        "725#05"
    );
    let mut bad = Settings::DEFAULT;
    bad.node_id = 128;
    assert!(Node::new(bad).is_err());
}
