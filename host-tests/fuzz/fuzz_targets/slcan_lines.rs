//! The simulated pod's SLCAN codec (`ballpod_host::slcan`) on arbitrary bytes in arbitrary
//! chunks. Invariants: no panic; the splitter's buffer stays bounded (every line it returns is
//! at most `MAX_LINE` bytes); a frame that parses formats back to the line it came from (upper
//! case hex), and its identifier and length are in range.
#![no_main]

use arbitrary::Unstructured;
use ballpod_host::slcan::{Line, LineSplitter, MAX_LINE, SlcanCommand, format_frame, parse_line};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let mut split = LineSplitter::default();
    while !u.is_empty() {
        let n = u.arbitrary_len::<u8>().unwrap_or(0).min(200);
        let Ok(chunk) = u.bytes(n) else { break };
        for line in split.push(chunk) {
            let Line::Bytes(bytes) = &line else {
                assert!(line.parse().is_err());
                continue;
            };
            assert!(bytes.len() <= MAX_LINE);
            if let Ok(SlcanCommand::Transmit(f)) = parse_line(bytes) {
                assert!(f.dlc <= 8);
                assert!(if f.extended {
                    f.id <= 0x1FFF_FFFF
                } else {
                    f.id <= 0x7FF
                });
                // the command letter as sent, the hex digits in upper case
                let (letter, digits) = bytes.split_at(1);
                let expected = [letter, digits.to_ascii_uppercase().as_slice(), b"\r"].concat();
                assert_eq!(format_frame(&f).as_bytes(), expected.as_slice());
            }
        }
    }
});
