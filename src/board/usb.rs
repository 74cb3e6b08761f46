//! USB FS device (PA11/PA12) with one CDC-ACM interface running the core's SCPI server
//! (`ballpod::protocol::scpi`): received bytes go to the server, its responses go back in
//! 64-byte packets, its session commands go to the compute task, and a `DATA:LOG?` download is
//! pulled from the sample log packet by packet.

use embassy_futures::join::join;
use embassy_stm32::peripherals::USB;
use embassy_stm32::usb::Driver;
use embassy_usb::Builder;
use embassy_usb::class::cdc_acm::{CdcAcmClass, State};
use static_cell::StaticCell;

use ballpod::protocol::scpi::ScpiServer;

use super::{Overruns, state};

/// The pod's USB identity (pid.codes test VID/PID until an allocation exists).
const VID: u16 = 0x1209;
const PID: u16 = 0x0001;
/// Bulk packet size of the CDC data endpoints.
const PACKET: usize = 64;
/// Response bytes one command line can produce before they are sent (the longest, the result
/// catalogue, is well below this).
const RESPONSE: usize = 1024;

/// Response bytes dropped because one line produced more than `RESPONSE` bytes.
pub static RESPONSE_OVERRUNS: Overruns = Overruns::new();

/// Runs the USB device and the SCPI command line.
#[embassy_executor::task]
pub async fn usb_task(driver: Driver<'static, USB>, boot_report: Option<&'static str>) {
    let mut config = embassy_usb::Config::new(VID, PID);
    config.manufacturer = Some("ballpod");
    config.product = Some("ballpod measurement pod");
    config.serial_number = Some("0");
    config.max_packet_size_0 = 64;

    static CONFIG_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static STATE: StaticCell<State> = StaticCell::new();
    let mut builder = Builder::new(
        driver,
        config,
        CONFIG_DESC.init([0; 256]),
        BOS_DESC.init([0; 256]),
        &mut [],
        CONTROL_BUF.init([0; 64]),
    );
    let mut class = CdcAcmClass::new(&mut builder, STATE.init(State::new()), PACKET as u16);
    let mut usb = builder.build();

    let lines = async {
        let mut scpi = ScpiServer::new();
        scpi.set_pull_download(true);
        if let Some(text) = boot_report {
            // The previous run's panic / watchdog reset, for SYSTem:ERRor?.
            scpi.push_device_error(text);
        }
        loop {
            class.wait_connection().await;
            let mut rx = [0u8; PACKET];
            while let Ok(n) = class.read_packet(&mut rx).await {
                let mut response: heapless::Vec<u8, RESPONSE> = heapless::Vec::new();
                let chunk = rx.get(..n).unwrap_or(&[]);
                state::POD.lock(|pod| {
                    state::LOG.lock(|log| {
                        let (mut pod, log) = (pod.borrow_mut(), log.borrow());
                        let Some(pod) = pod.as_mut() else { return };
                        let cmds = scpi.feed(chunk, pod, &*log, &mut |b: &[u8]| {
                            if response.extend_from_slice(b).is_err() {
                                RESPONSE_OVERRUNS.count();
                            }
                        });
                        for c in cmds {
                            pod.apply(c);
                            state::submit(c);
                        }
                        // Inside the lock: no sample can be logged between the announced
                        // length and the pause.
                        state::set_download_active(scpi.download_pending());
                    })
                });
                if send(&mut class, &response).await.is_err() {
                    break;
                }
                // A pulled log download: the compute task pauses logging meanwhile.
                while scpi.download_pending() {
                    let mut packet = [0u8; PACKET];
                    let k = state::LOG.lock(|log| scpi.pull_download(&*log.borrow(), &mut packet));
                    if class
                        .write_packet(packet.get(..k).unwrap_or(&[]))
                        .await
                        .is_err()
                    {
                        break;
                    }
                }
                if !scpi.download_pending() {
                    state::set_download_active(false);
                }
            }
            // Disconnected: configuration writes lock again (issue 7); a download cut short is
            // dropped, counted and reported as -410 on the next connection.
            scpi.connection_closed();
            state::set_download_active(false);
        }
    };
    join(usb.run(), lines).await;
}

/// Sends bytes in packets; a full last packet is followed by a zero-length one so the host
/// sees the end of the transfer.
async fn send<'d, D: embassy_usb::driver::Driver<'d>>(
    class: &mut CdcAcmClass<'d, D>,
    bytes: &[u8],
) -> Result<(), embassy_usb::driver::EndpointError> {
    for p in bytes.chunks(PACKET) {
        class.write_packet(p).await?;
    }
    if !bytes.is_empty() && bytes.len().is_multiple_of(PACKET) {
        class.write_packet(&[]).await?;
    }
    Ok(())
}
