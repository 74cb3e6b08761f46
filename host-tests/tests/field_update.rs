//! The guard stage (guard/) and the field update it makes power-fail safe (book: Hardware,
//! "Updating the firmware"). Independent sources: the STM32 CRC unit as RM0440 describes it
//! (a bit-serial model) against CRC-32/ISO-HDLC's published check value; a model of the flash
//! under a `dfu-util` download (dfu-util's order: every page erased, then the chunks written;
//! and the older page-by-page order), cut after every byte step; the repository's linker
//! scripts against the guard's layout. `.ci/check-image` checks the real sealed firmware
//! against zlib and llvm-objcopy.
use std::collections::BTreeSet;

use ballpod_guard::{
    APP_BASE, APP_LIMIT, CRC_CR, CRC_INIT, CRC_POLY, CRC_WORD, CRC_XOR_OUT, FLASH_BASE,
    LENGTH_WORD, Refusal, SoftCrc, Verdict, WordCrc, check, seal, word_at,
};
use ballpod_host::rng::Rng;

/// The CRC unit of RM0440 "Cyclic redundancy check calculation unit": a 32-bit shift register
/// loaded with CRC_INIT at RESET; each word written to CRC_DR is first bit-reversed as REV_IN
/// says (0b11: the whole word), then shifted in most significant bit first against CRC_POL;
/// CRC_DR reads the register, bit-reversed if REV_OUT.
struct CrcUnitModel {
    register: u32,
    rev_in_word: bool,
    rev_out: bool,
}

impl CrcUnitModel {
    fn configured(cr: u32) -> Self {
        assert_eq!(cr & 0b1_1000, 0, "POLYSIZE must be 32 bits");
        let rev_in = (cr >> 5) & 0b11;
        assert!(
            rev_in == 0 || rev_in == 0b11,
            "the model knows no reversal by byte or half-word"
        );
        Self {
            register: if cr & 1 != 0 { CRC_INIT } else { 0 },
            rev_in_word: rev_in == 0b11,
            rev_out: cr & (1 << 7) != 0,
        }
    }
    fn write_dr(&mut self, word: u32) {
        let data = if self.rev_in_word {
            word.reverse_bits()
        } else {
            word
        };
        for bit in (0..32).rev() {
            let top = (self.register >> 31) ^ ((data >> bit) & 1);
            self.register <<= 1;
            if top != 0 {
                self.register ^= CRC_POLY;
            }
        }
    }
    fn read_dr(&self) -> u32 {
        if self.rev_out {
            self.register.reverse_bits()
        } else {
            self.register
        }
    }
}

/// The guard's setting of the CRC unit gives CRC-32/ISO-HDLC (zlib's crc32): its published
/// check values, and the crc crate's value over random words.
#[test]
fn the_guards_crc_unit_setting_computes_crc32_iso_hdlc() {
    let unit_crc = |words: &[u32]| {
        let mut unit = CrcUnitModel::configured(CRC_CR);
        for &w in words {
            unit.write_dr(w);
        }
        unit.read_dr() ^ CRC_XOR_OUT
    };
    // zlib.crc32(b"12345678") and b"" (python3 -c 'import zlib; print(hex(zlib.crc32(...)))')
    assert_eq!(
        unit_crc(&[u32::from_le_bytes(*b"1234"), u32::from_le_bytes(*b"5678")]),
        0x9AE0_DAAF
    );
    assert_eq!(unit_crc(&[]), 0);
    // and without the reversals it would not be (the setting matters)
    let mut plain = CrcUnitModel::configured(1);
    plain.write_dr(u32::from_le_bytes(*b"1234"));
    plain.write_dr(u32::from_le_bytes(*b"5678"));
    assert_ne!(plain.read_dr() ^ CRC_XOR_OUT, 0x9AE0_DAAF);
    let mut rng = Rng::new(43);
    for n in [1, 7, 64, 1000] {
        let words: Vec<u32> = (0..n).map(|_| rng.next_u64() as u32).collect();
        let mut soft = SoftCrc::default();
        soft.start();
        words.iter().for_each(|&w| soft.feed(w));
        assert_eq!(unit_crc(&words), soft.value(), "{n} words");
    }
}

/// An image as the linker would give one: a vector table (stack in SRAM, reset vector inside),
/// then code; `len` bytes, sealed.
fn image(len: usize, seed: u64) -> Vec<u8> {
    let mut rng = Rng::new(seed);
    let mut bytes: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
    bytes[0..4].copy_from_slice(&0x2000_9A10u32.to_le_bytes());
    bytes[4..8].copy_from_slice(&(APP_BASE + 0x401).to_le_bytes());
    bytes[LENGTH_WORD * 4..CRC_WORD * 4 + 4].fill(0);
    seal(&mut bytes).expect("a sealable length");
    bytes
}

fn verdict_of(flash: &[u8], torn: &BTreeSet<usize>) -> Verdict {
    check(
        |i| {
            (!torn.contains(&(i / 2)))
                .then(|| word_at(flash, i))
                .flatten()
        },
        &mut SoftCrc::default(),
    )
}

#[test]
fn a_sealed_image_starts_and_every_kind_of_damage_is_refused() {
    let good = image(6000, 1);
    let none = BTreeSet::new();
    assert_eq!(verdict_of(&good, &none), Verdict::Start);
    // the CRC word is zlib's over the image with it zeroed, computed here bit by bit
    let mut zeroed = good.clone();
    zeroed[32..36].fill(0);
    let mut unit = CrcUnitModel::configured(CRC_CR);
    zeroed
        .chunks(4)
        .for_each(|c| unit.write_dr(u32::from_le_bytes(c.try_into().unwrap())));
    assert_eq!(word_at(&good, CRC_WORD), Some(unit.read_dr() ^ CRC_XOR_OUT));

    // any single bit flipped anywhere in the image (but the CRC word's): refused
    let mut rng = Rng::new(2);
    for _ in 0..300 {
        let mut bad = good.clone();
        let bit = (rng.next_u64() as usize) % (good.len() * 8);
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(
            matches!(verdict_of(&bad, &none), Verdict::Refuse(_)),
            "bit {bit}"
        );
    }
    // erased flash, an unsealed image (cortex-m-rt leaves 0), an image linked for 0x0800_0000,
    // a stack pointer outside SRAM, a double ECC error anywhere
    assert_eq!(
        verdict_of(&vec![0xFF; 6000], &none),
        Verdict::Refuse(Refusal::BadLength(0xFFFF_FFFF))
    );
    let mut unsealed = good.clone();
    unsealed[28..36].fill(0);
    assert_eq!(
        verdict_of(&unsealed, &none),
        Verdict::Refuse(Refusal::BadLength(0))
    );
    let mut old_layout = good.clone();
    old_layout[4..8].copy_from_slice(&(FLASH_BASE + 0x401).to_le_bytes());
    seal(&mut old_layout).unwrap();
    assert_eq!(
        verdict_of(&old_layout, &none),
        Verdict::Refuse(Refusal::ResetOutsideImage(FLASH_BASE + 0x401))
    );
    let mut no_stack = good.clone();
    no_stack[0..4].copy_from_slice(&0x1000_8000u32.to_le_bytes());
    seal(&mut no_stack).unwrap();
    assert_eq!(
        verdict_of(&no_stack, &none),
        Verdict::Refuse(Refusal::StackOutsideRam(0x1000_8000))
    );
    for dword in [0, 3, 4, 700, 749] {
        assert_eq!(
            verdict_of(&good, &BTreeSet::from([dword])),
            Verdict::Refuse(Refusal::Unreadable),
            "double-word {dword}"
        );
    }
    // the guard reads nothing past the length it is given (the flash after it may be torn)
    assert_eq!(
        verdict_of(&good, &BTreeSet::from([750, 900])),
        Verdict::Start
    );
    // lengths seal refuses
    assert!(seal(&mut vec![0; 6001]).is_err());
    assert!(seal(&mut [0; 32]).is_err());
    assert!(seal(&mut vec![0; (APP_LIMIT - APP_BASE) as usize + 4]).is_err());
}

const PAGE: usize = 2048;
const DWORD: usize = 8;
/// dfu-util's transfer size with ST's ROM bootloader (its DFU functional descriptor).
const CHUNK: usize = 2048;

/// The flash from `APP_BASE` under a download, cut after `budget` byte steps: an erase sets one
/// byte to 0xFF per step, a program clears the bits of one byte per step (RM0440: programming
/// is per double-word, ECC with it); a double-word left part-way reads as a double ECC error.
struct Flash {
    bytes: Vec<u8>,
    torn: BTreeSet<usize>,
    budget: usize,
}

impl Flash {
    fn step(&mut self) -> bool {
        if self.budget == 0 {
            return false;
        }
        self.budget -= 1;
        true
    }
    fn erase(&mut self, page: usize) -> bool {
        for (done, i) in (page * PAGE..(page + 1) * PAGE).enumerate() {
            if !self.step() {
                if done % DWORD != 0 {
                    self.torn.insert(i / DWORD);
                }
                return false;
            }
            self.bytes[i] = 0xFF;
            if (done + 1) % DWORD == 0 {
                self.torn.remove(&(i / DWORD));
            }
        }
        true
    }
    fn program(&mut self, at: usize, dword: &[u8]) -> bool {
        assert!(
            self.bytes[at..at + DWORD].iter().all(|&b| b == 0xFF),
            "programmed twice"
        );
        for (k, &b) in dword.iter().enumerate() {
            if !self.step() {
                if k != 0 {
                    self.torn.insert(at / DWORD);
                }
                return false;
            }
            self.bytes[at + k] &= b;
        }
        true
    }
}

/// The order dfu-util's DfuSe download follows.
#[derive(Clone, Copy, Debug)]
enum Order {
    /// dfu-util ≥ 0.10: every page the image covers erased, then the chunks written.
    EraseAllFirst,
    /// older dfu-util: each chunk's page erased just before the chunk is written.
    PageByPage,
}

/// Downloads `new` over `old` (both from APP_BASE) with `budget` byte steps of power; the flash
/// as the cut (or the end) leaves it.
fn download(old: &[u8], new: &[u8], order: Order, budget: usize) -> (Flash, bool) {
    let pages = new.len().div_ceil(PAGE);
    let mut flash = Flash {
        bytes: old.to_vec(),
        torn: BTreeSet::new(),
        budget,
    };
    flash
        .bytes
        .resize(flash.bytes.len().max(pages * PAGE), 0xFF);
    let chunk_writes = |flash: &mut Flash, chunk: usize| {
        let from = chunk * CHUNK;
        let data = &new[from..(from + CHUNK).min(new.len())];
        // the bootloader programs double-words; the last one padded with erased bytes
        for (k, d) in data.chunks(DWORD).enumerate() {
            let mut dword = [0xFF; DWORD];
            dword[..d.len()].copy_from_slice(d);
            if !flash.program(from + k * DWORD, &dword) {
                return false;
            }
        }
        true
    };
    let chunks = new.len().div_ceil(CHUNK);
    let done = match order {
        Order::EraseAllFirst => {
            (0..pages).all(|p| flash.erase(p)) && (0..chunks).all(|c| chunk_writes(&mut flash, c))
        }
        Order::PageByPage => {
            (0..chunks).all(|c| flash.erase(c * CHUNK / PAGE) && chunk_writes(&mut flash, c))
        }
    };
    (flash, done)
}

/// A power loss at any byte step of a `dfu-util` download: the guard starts the old image only
/// if nothing was touched, the new one only once it is completely written, and otherwise enters
/// the ROM bootloader (so `dfu-util` can be run again) — never a part-written image.
#[test]
fn a_download_cut_by_a_power_loss_at_any_step_is_never_started() {
    for (old_len, new_len) in [(12_000, 9_996), (7_000, 10_244)] {
        let old = image(old_len, 3);
        let new = image(new_len, 4);
        for order in [Order::EraseAllFirst, Order::PageByPage] {
            let (whole, done) = download(&old, &new, order, usize::MAX);
            assert!(done);
            assert_eq!(&whole.bytes[..new.len()], &new[..]);
            let steps = usize::MAX - whole.budget;
            let mut refused = 0;
            for budget in 0..=steps {
                let (flash, done) = download(&old, &new, order, budget);
                let verdict = verdict_of(&flash.bytes, &flash.torn);
                if budget == 0 {
                    assert_eq!(verdict, Verdict::Start, "nothing touched: the old image");
                    assert_eq!(&flash.bytes[..old.len()], &old[..]);
                } else if done {
                    assert_eq!(
                        verdict,
                        Verdict::Start,
                        "{order:?}: complete after {budget} steps"
                    );
                    assert_eq!(&flash.bytes[..new.len()], &new[..]);
                } else {
                    assert!(
                        matches!(verdict, Verdict::Refuse(_)),
                        "{order:?}, {old_len} → {new_len} B, cut after {budget} of {steps} steps: {verdict:?}"
                    );
                    refused += 1;
                }
            }
            assert_eq!(refused, steps - 1, "{order:?}");
        }
    }
}

/// The linker scripts place the guard and the image where the guard's layout says.
#[test]
fn the_linker_scripts_follow_the_guards_layout() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let flash_of = |path: &str| {
        let text = std::fs::read_to_string(format!("{root}/{path}")).expect(path);
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with("FLASH :"))
            .unwrap_or_else(|| panic!("{path}: no FLASH region"))
            .to_string();
        let field = |name: &str| {
            let v = line
                .split(name)
                .nth(1)
                .unwrap()
                .trim_start_matches([' ', '=']);
            let v = v.split([',', ' ']).next().unwrap();
            match v.strip_suffix('K') {
                Some(k) => k.parse::<u32>().unwrap() * 1024,
                None => u32::from_str_radix(v.trim_start_matches("0x"), 16).unwrap(),
            }
        };
        (field("ORIGIN"), field("LENGTH"))
    };
    assert_eq!(
        flash_of("guard/memory.x"),
        (FLASH_BASE, APP_BASE - FLASH_BASE)
    );
    assert_eq!(flash_of("memory.x"), (APP_BASE, APP_LIMIT - APP_BASE));
}
