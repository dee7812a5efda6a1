//! SDO transfers byte by byte (CiA 301 §7.2.4.3): every request and
//! response below is worked out by hand from the protocol's bit layout,
//! not produced by this code.

use super::*;
use crate::canopen::od::Dictionary;

fn server() -> (SdoServer, Dictionary) {
    (SdoServer::new(), Dictionary::new(1))
}

/// One request; the write closure stores what the dictionary accepted.
fn ask(s: &mut SdoServer, od: &mut Dictionary, req: [u8; 8]) -> Option<[u8; 8]> {
    s.on_request(&req, od, |od, pos, raw| {
        od.store(pos, raw);
        Ok(())
    })
}

#[test]
fn expedited_upload() {
    let (mut s, mut od) = server();
    // 0x1017 UNSIGNED16 = 1000: scs 2, n = 2, e = 1, s = 1 -> 0x4B.
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x17, 0x10, 0, 0, 0, 0, 0]),
        Some([0x4B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00])
    );
    // 0x1000 UNSIGNED32 = 0: n = 0 -> 0x43.
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x00, 0x10, 0, 0, 0, 0, 0]),
        Some([0x43, 0x00, 0x10, 0x00, 0, 0, 0, 0])
    );
    // 0x1001 UNSIGNED8: n = 3 -> 0x4F. 0x2104 UNSIGNED24: n = 1 -> 0x47.
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x01, 0x10, 0, 0, 0, 0, 0]).map(|r| r[0]),
        Some(0x4F)
    );
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x04, 0x21, 0, 0, 0, 0, 0]).map(|r| r[0]),
        Some(0x47)
    );
    // 0x1800:01 = 0x181 (COB-ID of TPDO1 for node 1).
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x00, 0x18, 0x01, 0, 0, 0, 0]),
        Some([0x43, 0x00, 0x18, 0x01, 0x81, 0x01, 0x00, 0x00])
    );
    // REAL32 clamp 500.0 = 0x43FA0000.
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x00, 0x20, 0x01, 0, 0, 0, 0]),
        Some([0x43, 0x00, 0x20, 0x01, 0x00, 0x00, 0xFA, 0x43])
    );
}

#[test]
fn expedited_download() {
    let (mut s, mut od) = server();
    // 0x1017 = 500 (0x01F4), 2 bytes: ccs 1, n = 2, e = 1, s = 1 -> 0x2B.
    assert_eq!(
        ask(
            &mut s,
            &mut od,
            [0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0x00, 0x00]
        ),
        Some([0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0])
    );
    assert_eq!(od.get(0x1017, 0), 500);
    // Size not indicated (0x22): the entry's own size is taken.
    assert_eq!(
        ask(
            &mut s,
            &mut od,
            [0x22, 0x17, 0x10, 0x00, 0x64, 0x00, 0xAA, 0xBB]
        ),
        Some([0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0])
    );
    assert_eq!(od.get(0x1017, 0), 100);
    // Node id 0x7F via 0x2F (1 byte).
    assert_eq!(
        ask(&mut s, &mut od, [0x2F, 0x06, 0x20, 0x00, 0x7F, 0, 0, 0]),
        Some([0x60, 0x06, 0x20, 0x00, 0, 0, 0, 0])
    );
    assert_eq!(od.get(0x2006, 0), 0x7F);
}

#[test]
fn segmented_upload_with_toggle_and_last_segment() {
    let (mut s, mut od) = server();
    // 0x1008 "thermcomp hub", 13 bytes: scs 2, s = 1, e = 0 -> 0x41, size 13.
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
        Some([0x41, 0x08, 0x10, 0x00, 0x0D, 0x00, 0x00, 0x00])
    );
    assert!(s.busy());
    // Upload segment, toggle 0 (0x60): 7 bytes, n = 0, c = 0 -> 0x00.
    assert_eq!(
        ask(&mut s, &mut od, [0x60, 0, 0, 0, 0, 0, 0, 0]),
        Some([0x00, b't', b'h', b'e', b'r', b'm', b'c', b'o'])
    );
    // Toggle 1 (0x70): 6 bytes left, n = 1, c = 1 -> 0x10 | 0x02 | 0x01.
    assert_eq!(
        ask(&mut s, &mut od, [0x70, 0, 0, 0, 0, 0, 0, 0]),
        Some([0x13, b'm', b'p', b' ', b'h', b'u', b'b', 0x00])
    );
    assert!(!s.busy());
    // The transfer is over: another segment request is a protocol error.
    assert_eq!(
        ask(&mut s, &mut od, [0x60, 0, 0, 0, 0, 0, 0, 0]),
        Some([0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05])
    );
}

#[test]
fn toggle_not_alternated_aborts() {
    let (mut s, mut od) = server();
    ask(&mut s, &mut od, [0x40, 0x09, 0x10, 0x00, 0, 0, 0, 0]);
    ask(&mut s, &mut od, [0x60, 0, 0, 0, 0, 0, 0, 0]);
    // Toggle 0 again: abort 0x05030000 for 0x1009:00.
    assert_eq!(
        ask(&mut s, &mut od, [0x60, 0, 0, 0, 0, 0, 0, 0]),
        Some([0x80, 0x09, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05])
    );
    assert!(!s.busy());
}

#[test]
fn segmented_download_one_and_two_segments() {
    let (mut s, mut od) = server();
    // 0x2000:01 REAL32 = 250.0 (0x437A0000), size indicated 4: 0x21.
    assert_eq!(
        ask(
            &mut s,
            &mut od,
            [0x21, 0x00, 0x20, 0x01, 0x04, 0x00, 0x00, 0x00]
        ),
        Some([0x60, 0x00, 0x20, 0x01, 0, 0, 0, 0])
    );
    // Segment, toggle 0, n = 3 (4 bytes used), c = 1 -> 0x07.
    assert_eq!(
        ask(&mut s, &mut od, [0x07, 0x00, 0x00, 0x7A, 0x43, 0, 0, 0]),
        Some([0x20, 0, 0, 0, 0, 0, 0, 0])
    );
    assert_eq!(od.get_f32(0x2000, 1), 250.0);
    // 0x1017 = 500 in two 1-byte segments, size not indicated (0x20).
    assert_eq!(
        ask(&mut s, &mut od, [0x20, 0x17, 0x10, 0x00, 0, 0, 0, 0]),
        Some([0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0])
    );
    // t = 0, n = 6, c = 0 -> 0x0C; response scs 1, t = 0 -> 0x20.
    assert_eq!(
        ask(&mut s, &mut od, [0x0C, 0xF4, 0, 0, 0, 0, 0, 0]),
        Some([0x20, 0, 0, 0, 0, 0, 0, 0])
    );
    assert_eq!(od.get(0x1017, 0), 1000); // not written before the last segment
                                         // t = 1, n = 6, c = 1 -> 0x1D; response t = 1 -> 0x30.
    assert_eq!(
        ask(&mut s, &mut od, [0x1D, 0x01, 0, 0, 0, 0, 0, 0]),
        Some([0x30, 0, 0, 0, 0, 0, 0, 0])
    );
    assert_eq!(od.get(0x1017, 0), 500);
    // Too many bytes: abort 0x06070012 at the segment that overflows.
    ask(&mut s, &mut od, [0x20, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(
        ask(&mut s, &mut od, [0x00, 1, 2, 3, 4, 5, 6, 7]),
        Some([0x80, 0x17, 0x10, 0x00, 0x12, 0x00, 0x07, 0x06])
    );
    // Fewer than announced: 0x06070010 at the last segment.
    ask(&mut s, &mut od, [0x21, 0x00, 0x20, 0x01, 0x04, 0, 0, 0]);
    assert_eq!(
        ask(&mut s, &mut od, [0x0B, 0x00, 0x00, 0, 0, 0, 0, 0]),
        Some([0x80, 0x00, 0x20, 0x01, 0x10, 0x00, 0x07, 0x06])
    );
    assert_eq!(od.get_f32(0x2000, 1), 250.0);
}

#[test]
fn abort_codes() {
    let (mut s, mut od) = server();
    let abort = |i: u16, sub: u8, code: u32| Some(abort_frame(i, sub, code_of(code)));
    fn code_of(code: u32) -> SdoAbort {
        [
            SdoAbort::Toggle,
            SdoAbort::Command,
            SdoAbort::ReadOnly,
            SdoAbort::NoObject,
            SdoAbort::Incompatible,
            SdoAbort::Length,
            SdoAbort::LengthTooHigh,
            SdoAbort::LengthTooLow,
            SdoAbort::NoSubindex,
            SdoAbort::InvalidValue,
            SdoAbort::ValueTooHigh,
            SdoAbort::ValueTooLow,
            SdoAbort::General,
            SdoAbort::CannotStore,
            SdoAbort::DeviceState,
        ]
        .into_iter()
        .find(|a| a.code() == code)
        .unwrap()
    }
    // Write to the read-only device type: 80 00 10 00 02 00 01 06.
    assert_eq!(
        ask(&mut s, &mut od, [0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4]),
        Some([0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06])
    );
    // No object 0x1234, no subindex 0x1018:09.
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x34, 0x12, 0x00, 0, 0, 0, 0]),
        Some([0x80, 0x34, 0x12, 0x00, 0x00, 0x00, 0x02, 0x06])
    );
    assert_eq!(
        ask(&mut s, &mut od, [0x40, 0x18, 0x10, 0x09, 0, 0, 0, 0]),
        Some([0x80, 0x18, 0x10, 0x09, 0x11, 0x00, 0x09, 0x06])
    );
    // Node id 200 (> 127): too high 0x06090031; 0: too low 0x06090032.
    assert_eq!(
        ask(&mut s, &mut od, [0x2F, 0x06, 0x20, 0x00, 200, 0, 0, 0]),
        Some([0x80, 0x06, 0x20, 0x00, 0x31, 0x00, 0x09, 0x06])
    );
    assert_eq!(
        ask(&mut s, &mut od, [0x2F, 0x06, 0x20, 0x00, 0, 0, 0, 0]),
        abort(0x2006, 0, 0x0609_0032)
    );
    // A NaN clamp: invalid value 0x06090030.
    let nan = f32::NAN.to_le_bytes();
    assert_eq!(
        ask(
            &mut s,
            &mut od,
            [0x23, 0x00, 0x20, 0x02, nan[0], nan[1], nan[2], nan[3]]
        ),
        Some([0x80, 0x00, 0x20, 0x02, 0x30, 0x00, 0x09, 0x06])
    );
    // 4 bytes into UNSIGNED16 0x1017: length too high 0x06070012; announced
    // segmented size 1: too low 0x06070013.
    assert_eq!(
        ask(&mut s, &mut od, [0x23, 0x17, 0x10, 0x00, 1, 0, 0, 0]),
        abort(0x1017, 0, 0x0607_0012)
    );
    assert_eq!(
        ask(&mut s, &mut od, [0x21, 0x17, 0x10, 0x00, 1, 0, 0, 0]),
        abort(0x1017, 0, 0x0607_0013)
    );
    // Block upload (ccs 5): command specifier not valid 0x05040001.
    assert_eq!(
        ask(&mut s, &mut od, [0xA0, 0x08, 0x10, 0x00, 0, 0, 0, 0]),
        Some([0x80, 0x08, 0x10, 0x00, 0x01, 0x00, 0x04, 0x05])
    );
    // A download segment with no download open.
    assert_eq!(
        ask(&mut s, &mut od, [0x00, 0, 0, 0, 0, 0, 0, 0]),
        abort(0, 0, 0x0504_0001)
    );
    // The client aborts a segmented upload: no answer, the server is idle.
    ask(&mut s, &mut od, [0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]);
    assert_eq!(
        ask(&mut s, &mut od, [0x80, 0x08, 0x10, 0x00, 0, 0, 0, 0x08]),
        None
    );
    assert!(!s.busy());
    // Not 8 bytes: ignored.
    assert_eq!(
        s.on_request(&[0x40, 0x17, 0x10], &mut od, |_, _, _| Ok(())),
        None
    );
    // The application's own refusal passes through.
    assert_eq!(
        s.on_request(&[0x2B, 0x17, 0x10, 0, 1, 0, 0, 0], &mut od, |_, _, _| Err(
            SdoAbort::DeviceState
        )),
        Some([0x80, 0x17, 0x10, 0x00, 0x22, 0x00, 0x00, 0x08])
    );
    assert_eq!(
        SdoAbort::ValueTooHigh.to_string(),
        "SDO abort 0x06090031: value too high"
    );
}
