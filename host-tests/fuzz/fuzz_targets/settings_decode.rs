//! The settings decoders on arbitrary bytes: `Config::decode` on the bytes, and the two-slot
//! loader on an arbitrary two-page flash image.
//! Invariants: no panic; whatever is accepted is a valid configuration that encodes back to
//! the same bytes; the loader always returns a valid configuration.
#![no_main]

use ballpod::config::{Config, ENCODED_LEN};
use ballpod::settings::{self, RECORD_LEN, SettingsFlash, Slot, WRITE_SIZE};
use libfuzzer_sys::fuzz_target;

/// A read-only flash image of two slots.
struct Image<'a>(&'a [u8], &'a [u8]);

impl SettingsFlash for Image<'_> {
    type Error = ();
    fn read(&mut self, slot: Slot, offset: usize, buf: &mut [u8]) -> Result<(), ()> {
        let page = if slot == Slot::A { self.0 } else { self.1 };
        // Bytes past the image read as erased flash.
        for (k, b) in buf.iter_mut().enumerate() {
            *b = page.get(offset + k).copied().unwrap_or(0xFF);
        }
        Ok(())
    }
    fn erase(&mut self, _: Slot) -> Result<(), ()> {
        Err(())
    }
    fn program(&mut self, _: Slot, _: usize, _: &[u8; WRITE_SIZE]) -> Result<(), ()> {
        Err(())
    }
}

fuzz_target!(|data: &[u8]| {
    if let Ok(c) = Config::decode(data) {
        assert!(c.validate().is_ok());
        let mut again = [0u8; ENCODED_LEN];
        assert_eq!(c.encode(&mut again), Ok(ENCODED_LEN));
        assert_eq!(
            &again[..],
            data,
            "accepted bytes do not re-encode identically"
        );
    }
    if let Ok(r) = settings::decode_record(data) {
        assert!(r.config.validate().is_ok());
        let again = settings::encode_record(&r.config, r.sequence).unwrap();
        assert_eq!(&again[..RECORD_LEN - 8], &data[..RECORD_LEN - 8]);
    }
    let (a, b) = data.split_at(data.len() / 2);
    let loaded = settings::load(&mut Image(a, b));
    assert!(loaded.config.validate().is_ok());
    assert_eq!(loaded.is_defaults(), loaded.scan.newest().is_none());
});
