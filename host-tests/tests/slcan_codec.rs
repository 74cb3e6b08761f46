//! SLCAN framing against the Lawicel format as python-can writes and reads it
//! (can/interfaces/slcan.py: `t{id:03X}{dlc:d}{data hex upper}`, `T{id:08X}…`, `S6` = 500 k).
use ballpod_host::slcan::{
    Line, LineSplitter, SlcanCommand, SlcanError, SlcanFrame, format_frame, parse_line,
};

#[test]
fn parses_python_can_lines() {
    assert_eq!(parse_line(b"O"), Ok(SlcanCommand::Open));
    assert_eq!(parse_line(b"C"), Ok(SlcanCommand::Close));
    assert_eq!(parse_line(b"S6"), Ok(SlcanCommand::Bitrate(500_000)));
    assert_eq!(parse_line(b"S8"), Ok(SlcanCommand::Bitrate(1_000_000)));
    let f = parse_line(b"t61084000100000000000").unwrap();
    assert_eq!(
        f,
        SlcanCommand::Transmit(SlcanFrame {
            id: 0x610,
            extended: false,
            remote: false,
            dlc: 8,
            data: [0x40, 0x00, 0x10, 0, 0, 0, 0, 0]
        })
    );
    let f = parse_line(b"T1ABCDEF02BEEF").unwrap();
    assert_eq!(
        f,
        SlcanCommand::Transmit(SlcanFrame {
            id: 0x1ABC_DEF0,
            extended: true,
            remote: false,
            dlc: 2,
            data: [0xBE, 0xEF, 0, 0, 0, 0, 0, 0]
        })
    );
    assert!(matches!(
        parse_line(b"r7010"),
        Ok(SlcanCommand::Transmit(SlcanFrame {
            remote: true,
            id: 0x701,
            ..
        }))
    ));
}

#[test]
fn formats_what_python_can_parses() {
    let f = SlcanFrame {
        id: 0x710,
        extended: false,
        remote: false,
        dlc: 1,
        data: [0x7F, 0, 0, 0, 0, 0, 0, 0],
    };
    assert_eq!(format_frame(&f), "t71017F\r");
    let f = SlcanFrame {
        id: 0x18FF_0001,
        extended: true,
        remote: false,
        dlc: 0,
        data: [0; 8],
    };
    assert_eq!(format_frame(&f), "T18FF00010\r");
}

#[test]
fn malformed_lines_are_errors() {
    assert_eq!(parse_line(b""), Err(SlcanError::Empty));
    assert!(matches!(
        parse_line(b"X"),
        Err(SlcanError::UnknownCommand(b'X'))
    ));
    assert!(matches!(
        parse_line(b"t8001"),
        Err(SlcanError::Malformed(_))
    )); // id > 0x7FF… and short
    assert!(matches!(
        parse_line(b"t1239"),
        Err(SlcanError::Malformed(_))
    )); // dlc 9
    assert!(matches!(
        parse_line(b"t12330011"),
        Err(SlcanError::Malformed(_))
    )); // length 3, two data bytes
    assert!(matches!(
        parse_line(b"t1231GG"),
        Err(SlcanError::Malformed(_))
    )); // not hex
    assert!(matches!(parse_line(b"S9"), Err(SlcanError::Malformed(_))));
}

/// Regression (issue 16): a non-ASCII byte among the data digits was sliced off a character
/// boundary and killed the server; on bytes it is just not a hex digit.
#[test]
fn a_non_ascii_byte_is_malformed_not_a_crash() {
    assert!(matches!(
        parse_line(b"t6102A\xe9B"),
        Err(SlcanError::Malformed(_))
    ));
    let mut split = LineSplitter::default();
    let lines = split.push(b"t6102A\xe9B\rO\r");
    assert_eq!(lines.len(), 2);
    assert!(lines[0].parse().is_err());
    assert_eq!(lines[1].parse(), Ok(SlcanCommand::Open));
}

/// Every field is validated: identifier digits (11-bit range), length, data digits; an
/// over-long line is one error, and the splitter's buffer stays bounded.
#[test]
fn every_field_is_validated_and_garbage_stays_bounded() {
    for bad in [
        &b"t80000"[..], // 11-bit identifier above 0x7FF
        b"T200000000",  // 29-bit identifier above 0x1FFFFFFF
        b"t12",         // identifier too short
        b"t123",        // no length
        b"t123x",       // length not hex
        b"t12310",      // one data digit for length 1
        b"t1230AB",     // data for length 0
        b"r1232AB",     // data in a remote frame
        b"S",           // no bit rate code
        b"S123456789",  // far too many digits
        b"\xff",        // not a command
    ] {
        assert!(parse_line(bad).is_err(), "{bad:?}");
    }
    let mut split = LineSplitter::default();
    let garbage = vec![b'7'; 100_000];
    assert!(split.push(&garbage).is_empty());
    let lines = split.push(b"\rC\r");
    assert_eq!(lines, [Line::TooLong, Line::Bytes(b"C".to_vec())]);
    assert!(lines[0].parse().is_err());
}
