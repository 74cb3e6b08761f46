//! What a boot finds (`ballpod::boot`): the reset cause from RCC_CSR's flags and the option
//! bytes from FLASH_OPTR, against the bit positions of the reference manual (RM0440 §7.4.30
//! RCC_CSR: OBLRSTF 25, PINRSTF 26, BORRSTF 27, SFTRSTF 28, IWDGRSTF 29, WWDGRSTF 30, LPWRRSTF
//! 31; FLASH_OPTR: DBANK 22, nSWBOOT0 26, nBOOT0 27), and what the pod reports of them
//! over CANopen and SCPI.

use ballpod::acquisition::MAX_AXES;
use ballpod::app::App;
use ballpod::app::log::SampleLog;
use ballpod::boot::{OptionBytes, ResetCause};
use ballpod::config::Config;
use ballpod::pod::{BootReport, Pod};
use ballpod::protocol::canopen::{CanFrame, CanOpenNode, emcy};
use ballpod::protocol::scpi::ScpiServer;
use ballpod::protocol::stream::SampleStream;

const OBLRSTF: u32 = 1 << 25;
const PINRSTF: u32 = 1 << 26;
const BORRSTF: u32 = 1 << 27;
const SFTRSTF: u32 = 1 << 28;
const IWDGRSTF: u32 = 1 << 29;
const WWDGRSTF: u32 = 1 << 30;
const LPWRRSTF: u32 = 1 << 31;

/// Every reset drives the reset pin, so PINRSTF comes with each (RM0440, reset circuit); a power-on
/// sets BORRSTF too. The most specific flag names the cause, and only the watchdogs and a
/// low-power reset are faults.
#[test]
fn the_reset_cause_is_the_most_specific_flag_and_only_a_watchdog_or_low_power_is_a_fault() {
    let cases = [
        (BORRSTF | PINRSTF, ResetCause::PowerOnOrBrownOut, None),
        (PINRSTF, ResetCause::Pin, None),
        (
            IWDGRSTF | PINRSTF,
            ResetCause::Watchdog,
            Some((emcy::SOFTWARE_ERROR, emcy::REASON_WATCHDOG)),
        ),
        (
            WWDGRSTF | PINRSTF,
            ResetCause::WindowWatchdog,
            Some((emcy::SOFTWARE_ERROR, emcy::REASON_WATCHDOG)),
        ),
        (SFTRSTF | PINRSTF, ResetCause::Software, None),
        (
            LPWRRSTF | PINRSTF,
            ResetCause::LowPower,
            Some((emcy::DEVICE_HARDWARE, emcy::REASON_LOW_POWER_RESET)),
        ),
        (OBLRSTF | PINRSTF, ResetCause::Pin, None),
        (OBLRSTF, ResetCause::OptionByteLoad, None),
        (0, ResetCause::Unknown, None),
        // a watchdog reset after a brown-out that was not cleared yet is still the watchdog's
        (
            IWDGRSTF | BORRSTF | PINRSTF,
            ResetCause::Watchdog,
            Some((emcy::SOFTWARE_ERROR, emcy::REASON_WATCHDOG)),
        ),
    ];
    for (csr, cause, fault) in cases {
        // the flags' neighbours (RMVF at 23, reserved and LSI bits below) do not count
        let csr = csr | 0x0080_0001;
        assert_eq!(ResetCause::from_rcc_csr(csr), cause, "{csr:#010x}");
        assert_eq!(
            cause.fault().map(|(code, reason, _)| (code, reason)),
            fault,
            "{cause:?}"
        );
    }
}

/// FLASH_OPTR as a G474 leaves the factory (0xFFEF_F8AA: RDP level 0, dual bank, BOOT0 from
/// the pin) is reported for its nSWBOOT0; with nSWBOOT0 = 0 and nBOOT0 = 1 it is right; a
/// single-bank chip is the first thing said, the ROM bootloader selected the next.
#[test]
fn the_option_bytes_the_firmware_needs_are_checked_bit_by_bit() {
    let factory = OptionBytes(0xFFEF_F8AA);
    assert!(factory.dual_bank() && factory.boot0_from_pin());
    assert!(factory.fault().is_some_and(|f| f.contains("nSWBOOT0 = 1")));
    let right = OptionBytes(0xFFEF_F8AA & !(1 << 26));
    assert_eq!(right.fault(), None);
    let single = OptionBytes(right.0 & !(1 << 22));
    assert!(single.fault().is_some_and(|f| f.contains("DBANK = 0")));
    let single_and_pin = OptionBytes(factory.0 & !(1 << 22));
    assert!(
        single_and_pin
            .fault()
            .is_some_and(|f| f.contains("DBANK = 0"))
    );
    let rom = OptionBytes(right.0 & !(1 << 27));
    assert!(rom.fault().is_some_and(|f| f.contains("nBOOT0 = 0")));
}

/// A boot that found the option bytes wrong says so on both ports: EMCY 0x5000 with byte 3 =
/// 5 right after the boot-up (CiA 301 table 21: device hardware), and -300 with the text in
/// `SYSTem:ERRor?`.
#[test]
fn wrong_option_bytes_are_reported_over_canopen_and_scpi() {
    let fault = OptionBytes(0xFFEF_F8AA).fault();
    let node_id = Config::default().can_node_id;
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let mut node = CanOpenNode::new(node_id, 1);
    let mut scpi = ScpiServer::new();
    let mut log = SampleLog::<32>::new();
    let mut stream = SampleStream::<256>::new();
    let boot = BootReport {
        option_bytes: fault,
        ..BootReport::default()
    };
    let _ = Pod::boot(
        &mut app,
        &mut node,
        &mut scpi,
        &mut log,
        &mut stream,
        1,
        &boot,
    );
    let mut frames: Vec<CanFrame> = Vec::new();
    node.poll(0, &app, &mut |f| frames.push(f));
    let ids: Vec<u16> = frames.iter().map(|f| f.id).collect();
    let emcy_id = 0x80 + u16::from(node_id);
    assert_eq!(
        ids,
        [0x700 + u16::from(node_id), emcy_id],
        "boot-up, then the EMCY"
    );
    let data = frames[1].payload();
    assert_eq!(data[..2], emcy::DEVICE_HARDWARE.to_le_bytes());
    assert_eq!(data[3], emcy::REASON_OPTION_BYTES);
    let mut out = Vec::new();
    scpi.feed(b"SYST:ERR?\n", &mut app, &log, &mut |b: &[u8]| {
        out.extend_from_slice(b)
    });
    let answer = String::from_utf8(out).unwrap();
    assert!(
        answer.starts_with("-300,") && answer.contains("nSWBOOT0 = 1"),
        "{answer}"
    );
}
