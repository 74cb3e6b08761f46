//! Settings persistence: two flash slots, power cut at every byte step of a save.
//!
//! The flash model (`ballpod_host::flash_model`) erases and programs one byte per step and can
//! lose power after any step. For each save we first count its steps on a copy, then repeat it
//! from the same flash contents with the power cut after 0, 1, …, all of them, power the flash
//! back on, and load: the result must be exactly the previous settings or the new ones — never
//! a mix, never an error, never the defaults once one save has completed. A double-word the
//! cut left part-way reads as a double ECC error (the pod's NMI, a failed read): that slot is
//! unreadable, the other one is used, and the boot says so.
use ballpod::config::{Config, ENCODED_LEN};

/// Two configurations equal bit for bit (their encodings; `==` fails on the set-up fields that
/// are not set, NaN).
fn same(a: &Config, b: &Config) -> bool {
    let (mut x, mut y) = ([0u8; ENCODED_LEN], [0u8; ENCODED_LEN]);
    a.encode(&mut x).unwrap();
    b.encode(&mut y).unwrap();
    x == y
}
use ballpod::settings::{
    self, CRC_AT, HEADER_LEN, RECORD_LEN, RECORD_MAGIC, SettingsFlash, Slot, SlotError,
};
use ballpod_host::flash_model::{EraseOrder, FlashFault, FlashModel, PAGE_BYTES};

/// Distinct valid configurations (the values are arbitrary points inside the ranges of
/// `config::FIELDS`).
fn configs() -> Vec<Config> {
    let edits: [fn(&mut Config); 4] = [
        |c| c.bar_length_mm = 100.0,
        |c| {
            c.bar_length_mm = 150.0;
            c.can_node_id = 42;
        },
        |c| {
            c.bar_length_mm = 300.0;
            c.bar_cte_ppm_per_k = 1.5;
        },
        |c| {
            c.bar_length_mm = 250.0;
            c.probe_debounce_us = 777;
        },
    ];
    edits
        .iter()
        .map(|e| {
            let mut c = Config::default();
            c.try_update(*e).unwrap();
            c
        })
        .collect()
}

/// Cuts power after every step of `store(new)` starting from `before` (whose newest settings are
/// `old`, or none); returns the number of cut points tried and of loads that met an ECC error.
fn cut_everywhere(before: &FlashModel, old: Option<&Config>, new: &Config) -> (usize, usize) {
    let mut full = before.power_on();
    settings::store(&mut full, new).unwrap();
    let total = full.steps;
    let mut seen_new = false;
    let mut ecc = 0;
    for cut in 0..=total {
        let mut f = before.power_on();
        f.budget = Some(cut);
        let r = settings::store(&mut f, new);
        if cut < total {
            assert_eq!(
                r.map_err(|_| ()),
                Err(()),
                "cut {cut} of {total}: save claims success"
            );
        } else {
            r.unwrap();
        }
        let mut back = f.power_on();
        let loaded = settings::load(&mut back);
        // a slot is unreadable exactly when the load met a torn double-word, and it is said
        assert_eq!(
            loaded.unreadable() as usize,
            back.ecc_reads,
            "cut {cut} of {total}"
        );
        ecc += back.ecc_reads;
        let is_new = same(&loaded.config, new) && !loaded.is_defaults();
        let is_old = match old {
            Some(o) => same(&loaded.config, o) && !loaded.is_defaults(),
            None => loaded.is_defaults() && same(&loaded.config, &Config::default()),
        };
        assert!(
            is_new || is_old,
            "cut {cut} of {total}: loaded neither old nor new ({:?})",
            loaded.from
        );
        // The switch is atomic: once the new settings are visible, a later cut cannot undo it.
        assert!(
            !seen_new || is_new,
            "cut {cut}: new settings vanished again"
        );
        seen_new |= is_new;
        // A save after power returns works from whatever the cut left.
        settings::store(&mut back, new).unwrap();
        assert!(same(&settings::load(&mut back.power_on()).config, new));
    }
    assert!(seen_new, "the complete save was never visible");
    (total + 1, ecc)
}

fn run_saves(order: EraseOrder) -> (usize, usize) {
    let cfgs = configs();
    let mut flash = FlashModel::erased();
    flash.erase_order = order;
    let (mut cuts, mut ecc) = (0, 0);
    let mut old: Option<Config> = None;
    for (k, new) in cfgs.iter().enumerate() {
        let (c, e) = cut_everywhere(&flash, old.as_ref(), new);
        cuts += c;
        ecc += e;
        let stored = settings::store(&mut flash, new).unwrap();
        // Alternating slots, sequence numbers 1, 2, 3, …
        let expected_slot = if k % 2 == 0 { Slot::A } else { Slot::B };
        assert_eq!(
            (stored.slot, stored.sequence),
            (expected_slot, k as u32 + 1)
        );
        old = Some(*new);
    }
    (cuts, ecc)
}

#[test]
fn power_cut_at_every_byte_of_a_save_leaves_old_or_new_settings() {
    let (forward, ecc_forward) = run_saves(EraseOrder::Forward);
    let (backward, ecc_backward) = run_saves(EraseOrder::Backward);
    let cuts = forward + backward;
    // a cut inside a double-word of the record (programming it, or erasing over an old one)
    // leaves an ECC error at 7 of every 8 byte steps there
    let ecc = ecc_forward + ecc_backward;
    assert!(ecc > 8 * RECORD_LEN / 2, "{ecc} loads met an ECC error");
    // Each save is one page erase (2048 byte steps) and the record's programmed bytes; every
    // one of them plus the completed save is a cut point, for 4 saves × 2 erase orders.
    let per_save = PAGE_BYTES + RECORD_LEN + 1;
    assert!(cuts >= 8 * (PAGE_BYTES + 1), "only {cuts} cut points");
    assert!(cuts <= 8 * per_save, "{cuts} cut points");
    println!("power-cut points checked: {cuts}, loads that met an ECC error: {ecc}");
}

#[test]
fn empty_flash_loads_defaults_with_the_flag() {
    let mut f = FlashModel::erased();
    let l = settings::load(&mut f);
    assert!(l.is_defaults());
    assert!(same(&l.config, &Config::default()));
    assert_eq!(l.scan.a, Err(SlotError::Erased));
    assert_eq!(l.scan.b, Err(SlotError::Erased));
}

#[test]
fn a_corrupted_newest_slot_falls_back_to_the_previous_settings() {
    let cfgs = configs();
    let mut f = FlashModel::erased();
    settings::store(&mut f, &cfgs[0]).unwrap(); // slot A, seq 1
    settings::store(&mut f, &cfgs[1]).unwrap(); // slot B, seq 2
    assert_eq!(settings::load(&mut f).from, Some((Slot::B, 2)));
    // Flip one bit in every byte of the record in turn: the load falls back to slot A.
    for i in 0..CRC_AT + 4 {
        let mut g = f.power_on();
        g.pages[1][i] ^= 0x10;
        let l = settings::load(&mut g);
        assert_eq!(l.from, Some((Slot::A, 1)), "byte {i}");
        assert!(same(&l.config, &cfgs[0]));
    }
    // Both damaged: defaults, flagged, with the reasons.
    let mut g = f.power_on();
    g.pages[0][HEADER_LEN + 5] ^= 1;
    g.pages[1][0] = 0;
    let l = settings::load(&mut g);
    assert!(l.is_defaults());
    assert_eq!(l.scan.a, Err(SlotError::BadCrc));
    assert_eq!(l.scan.b, Err(SlotError::BadMagic));
}

#[test]
fn record_layout_is_the_documented_one() {
    let cfg = configs()[2];
    let mut f = FlashModel::erased();
    settings::store(&mut f, &cfg).unwrap();
    let page = &f.pages[0];
    assert_eq!(&page[0..4], &RECORD_MAGIC);
    assert_eq!(&page[0..4], b"BPSL");
    assert_eq!(u16::from_le_bytes([page[4], page[5]]), 1);
    let n = usize::from(u16::from_le_bytes([page[6], page[7]]));
    assert_eq!(n, ENCODED_LEN);
    assert_eq!(u32::from_le_bytes(page[8..12].try_into().unwrap()), 1);
    assert!(same(&Config::decode(&page[12..12 + n]).unwrap(), &cfg));
    // The record CRC: CRC-32/ISO-HDLC (the zlib CRC) over header + payload, computed here by
    // a bitwise implementation independent of the `crc` crate.
    assert_eq!(
        u32::from_le_bytes(page[12 + n..16 + n].try_into().unwrap()),
        ballpod_host::oracle::crc32_bitwise(&page[..12 + n])
    );
    // Programmed in whole double-words; the rest of the page stays erased.
    assert!(RECORD_LEN.is_multiple_of(8) && RECORD_LEN >= 16 + n);
    assert!(page[RECORD_LEN..].iter().all(|&b| b == 0xFF));
    // Slot B untouched.
    assert!(f.pages[1].iter().all(|&b| b == 0xFF));
}

#[test]
fn a_double_word_cut_mid_program_reads_as_an_ecc_error_until_erased() {
    let cfgs = configs();
    let mut f = FlashModel::erased();
    settings::store(&mut f, &cfgs[0]).unwrap(); // slot A, seq 1
    // the next save (slot B) cut 3 bytes into its second double-word
    let mut g = f.power_on();
    g.budget = Some(PAGE_BYTES + 8 + 3);
    assert!(settings::store(&mut g, &cfgs[1]).is_err());
    let mut back = g.power_on();
    let mut buf = [0u8; 8];
    assert_eq!(back.read(Slot::B, 8, &mut buf), Err(FlashFault::Ecc));
    // the double-words either side read
    back.read(Slot::B, 0, &mut buf).unwrap();
    back.read(Slot::B, 16, &mut buf).unwrap();
    // the boot uses slot A and counts slot B unreadable
    let l = settings::load(&mut back);
    assert_eq!(l.from, Some((Slot::A, 1)));
    assert_eq!(l.scan.b, Err(SlotError::Read));
    assert_eq!(l.unreadable(), 1);
    // the torn double-word cannot be programmed over; the next save erases it and works
    assert_eq!(
        back.program(Slot::B, 8, &[0; 8]),
        Err(FlashFault::NotErased)
    );
    settings::store(&mut back, &cfgs[1]).unwrap();
    let l = settings::load(&mut back.power_on());
    assert_eq!((l.from, l.unreadable()), (Some((Slot::B, 2)), 0));
}

#[test]
fn flash_model_refuses_programming_a_non_erased_double_word() {
    let mut f = FlashModel::erased();
    f.program(Slot::A, 0, &[0; 8]).unwrap();
    assert_eq!(f.program(Slot::A, 0, &[0; 8]), Err(FlashFault::NotErased));
    assert_eq!(f.program(Slot::A, 4, &[0; 8]), Err(FlashFault::BadAddress));
}

#[test]
fn invalid_configuration_is_not_stored() {
    let mut f = FlashModel::erased();
    let bad = Config {
        bar_length_mm: 1.0,
        ..Config::default()
    };
    assert!(matches!(
        settings::store(&mut f, &bad),
        Err(settings::StoreError::Config(_))
    ));
    assert_eq!(f.erases, 0);
}
