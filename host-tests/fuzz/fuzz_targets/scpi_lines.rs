//! The SCPI server, over the pod's application, on arbitrary bytes in arbitrary chunks, with
//! samples between the chunks and a log holding a run. Invariants: no panic; the configuration
//! is always valid and changes only while the port is unlocked; a pulled download ends.
#![no_main]

use arbitrary::Unstructured;
use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::log::SampleLog;
use ballpod::app::{App, JobSlot, Recorder, RunMeta};
use ballpod::config::{Config, ENCODED_LEN};
use ballpod::protocol::scpi::ScpiServer;
use libfuzzer_sys::fuzz_target;

/// The configuration's bytes (set-up fields not set are NaN: compared as bits).
fn bytes(c: &Config) -> [u8; ENCODED_LEN] {
    let mut b = [0u8; ENCODED_LEN];
    c.encode(&mut b).expect("a valid configuration encodes");
    b
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let mut scpi = ScpiServer::new();
    let pull = u.arbitrary::<bool>().unwrap_or(false);
    scpi.set_pull_download(pull);
    let mut app = App::new(Config::default(), [16; MAX_AXES]);
    let mut jobs = Box::new(JobSlot::new());
    let mut log: SampleLog<8> = SampleLog::new();
    log.begin_run(&RunMeta {
        config: Config::default(),
        ..RunMeta::ZERO
    });
    let mut seq = 0u32;
    let mut sample = |app: &mut App, log: &mut SampleLog<8>, dl: f32| {
        seq += 1;
        let s = Sample {
            seq,
            t_us: u64::from(seq) * 1000,
            delta_l_um: dl,
            axes: [1.0 + seq as f32 * 0.01; MAX_AXES],
            temp_c: 20.0,
            flags: SampleFlags(0),
        };
        app.on_sample(&s, log);
    };
    for _ in 0..3 {
        sample(&mut app, &mut log, 0.25);
    }
    while !u.is_empty() {
        let n = u.arbitrary_len::<u8>().unwrap_or(0).min(300);
        let Ok(chunk) = u.bytes(n) else { break };
        match u.arbitrary::<u8>().unwrap_or(0) {
            0xA5 => scpi.connection_closed(),
            k if k < 0x40 => sample(&mut app, &mut log, f32::from(k) * 0.5),
            _ => {}
        }
        let unlocked = scpi.config_unlocked();
        let before = bytes(app.config());
        scpi.feed(chunk, &mut app, &log, &mut |_: &[u8]| {});
        assert!(app.config().validate().is_ok(), "invalid configuration");
        if bytes(app.config()) != before {
            assert!(
                unlocked || scpi.config_unlocked(),
                "config written while locked"
            );
        }
        app.flush(&mut log);
        app.run_jobs(&mut jobs);
        let mut buf = [0u8; 64];
        let mut guard = 0;
        while scpi.download_pending() {
            let k = scpi.pull_download(&log, &mut buf);
            assert!(k <= buf.len());
            guard += 1;
            assert!(guard < 10_000, "download never ends");
        }
    }
});
