//! The SCPI server on arbitrary bytes in arbitrary chunks.
//! Invariants: no panic; the configuration is always valid and changes only with a
//! `ConfigChanged` action while the port is unlocked; the pod model stays consistent.
#![no_main]

use arbitrary::Unstructured;
use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::protocol::log::SampleLog;
use ballpod::protocol::pod::{PodModel, SessionCommand};
use ballpod::protocol::scpi::ScpiServer;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let mut scpi = ScpiServer::new();
    let pull = u.arbitrary::<bool>().unwrap_or(false);
    scpi.set_pull_download(pull);
    let mut pod = PodModel::default();
    let mut log: SampleLog<8> = SampleLog::new();
    for k in 0..3u32 {
        log.push(&Sample {
            seq: k,
            t_us: u64::from(k) * 1000,
            delta_l_um: k as f32 * 0.25,
            axes: [1.0; 5],
            temp_c: 20.0,
            flags: SampleFlags(0),
        });
    }
    while !u.is_empty() {
        let n = u.arbitrary_len::<u8>().unwrap_or(0).min(300);
        let Ok(chunk) = u.bytes(n) else { break };
        if u.arbitrary::<u8>().unwrap_or(0) == 0xA5 {
            scpi.connection_closed();
        }
        let unlocked = scpi.config_unlocked();
        let before = pod.config;
        let mut out_bytes = 0usize;
        let actions = scpi.feed(chunk, &mut pod, &log, &mut |b: &[u8]| out_bytes += b.len());
        assert!(pod.config.validate().is_ok(), "invalid configuration");
        if pod.config != before {
            assert!(actions.contains(&SessionCommand::ConfigChanged));
            assert!(
                unlocked || scpi.config_unlocked(),
                "config written while locked"
            );
        }
        for a in actions {
            pod.apply(a);
        }
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
