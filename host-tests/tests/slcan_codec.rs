//! SLCAN framing against the Lawicel format as python-can writes and reads it
//! (can/interfaces/slcan.py: `t{id:03X}{dlc:d}{data hex upper}`, `T{id:08X}…`, `S6` = 500 k).
use ballpod_host::slcan::{SlcanCommand, SlcanError, SlcanFrame, format_frame, parse_line};

#[test]
fn parses_python_can_lines() {
    assert_eq!(parse_line("O"), Ok(SlcanCommand::Open));
    assert_eq!(parse_line("C"), Ok(SlcanCommand::Close));
    assert_eq!(parse_line("S6"), Ok(SlcanCommand::Bitrate(500_000)));
    assert_eq!(parse_line("S8"), Ok(SlcanCommand::Bitrate(1_000_000)));
    let f = parse_line("t61084000100000000000").unwrap();
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
    let f = parse_line("T1ABCDEF02BEEF").unwrap();
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
        parse_line("r7010"),
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
    assert_eq!(parse_line(""), Err(SlcanError::Empty));
    assert!(matches!(
        parse_line("X"),
        Err(SlcanError::UnknownCommand('X'))
    ));
    assert!(matches!(parse_line("t8001"), Err(SlcanError::Malformed(_)))); // id > 0x7FF… and short
    assert!(matches!(parse_line("t1239"), Err(SlcanError::Malformed(_)))); // dlc 9
    assert!(matches!(
        parse_line("t12330011"),
        Err(SlcanError::Malformed(_))
    )); // length 3, two data bytes
    assert!(matches!(
        parse_line("t1231GG"),
        Err(SlcanError::Malformed(_))
    )); // not hex
    assert!(matches!(parse_line("S9"), Err(SlcanError::Malformed(_))));
}
