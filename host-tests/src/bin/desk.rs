//! `cargo desk [--db FILE|URL] [--port N] [--pod-serial SN|any | --pod-command-port TTY
//! --pod-stream-port TTY | --pod-usb PORT --pod-stream PORT]`: the technician's
//! desk — a local web page (loopback only) that keeps machines and their tolerances, runs tests
//! on a pod, draws the trace live, checks the pod's results against a replay of the recorded
//! stream, decides each figure with its U (ISO 14253-1) and keeps the history with a report
//! per run. Prints `{"url": …}` when it listens; open that in a browser.

use std::path::PathBuf;

use clap::Parser;

use ballpod_host::desk::pod::{Pod, find_usb};
use ballpod_host::desk::spool::Spool;
use ballpod_host::desk::store::StoreHandle;
use ballpod_host::desk::{Desk, web};

/// The technician's desk: tests, history and reports in the browser.
#[derive(Parser, Debug)]
#[command(name = "cargo desk", version)]
struct Args {
    /// The history: an SQLite file (created if missing) or a PostgreSQL server's URL
    /// (`postgres://user:password@host/database`).
    #[arg(long, default_value = "desk.sqlite")]
    db: String,
    /// Where runs wait while the history cannot take them (default: `<db>.spool` beside an
    /// SQLite file, `desk-spool` for a server).
    #[arg(long)]
    spool: Option<PathBuf>,
    /// Port on 127.0.0.1 for the page (0: any free port).
    #[arg(long, default_value_t = 8230)]
    port: u16,
    /// The pod on USB: its serial number (`*IDN?`'s third field), or `any` for the one pod
    /// attached (found by VID:PID 1209:0001).
    #[arg(long, conflicts_with_all = ["pod_usb", "pod_command_port"])]
    pod_serial: Option<String>,
    /// The pod's command port by path (e.g. /dev/ttyACM0), with --pod-stream-port.
    #[arg(long, requires = "pod_stream_port", conflicts_with = "pod_usb")]
    pod_command_port: Option<PathBuf>,
    /// The pod's stream port by path (e.g. /dev/ttyACM1), with --pod-command-port.
    #[arg(long, requires = "pod_command_port")]
    pod_stream_port: Option<PathBuf>,
    /// The pod's USB command port served on loopback TCP (`sim --serve`'s `usb_port`).
    #[arg(long, requires = "pod_stream")]
    pod_usb: Option<u16>,
    /// The pod's stream port served on loopback TCP (`sim --serve`'s `stream_port`).
    #[arg(long, requires = "pod_usb")]
    pod_stream: Option<u16>,
}

fn main() {
    let args: Args = ballpod_host::cli::parse();
    if let Err(e) = run(args) {
        eprintln!("desk: {e}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<(), String> {
    let spool = args.spool.clone().unwrap_or_else(|| {
        if args.db.contains("://") {
            PathBuf::from("desk-spool")
        } else {
            PathBuf::from(format!("{}.spool", args.db))
        }
    });
    let (store, first) = StoreHandle::spawn(args.db.clone());
    if let Some(e) = first {
        // the desk serves on: runs wait in the spool until the database takes them
        eprintln!(
            "desk: {e}; runs wait in {} until it can be reached",
            spool.display()
        );
    }
    let pod = if let (Some(u), Some(s)) = (args.pod_usb, args.pod_stream) {
        Some(Pod::connect_tcp(u, s)?)
    } else if let (Some(c), Some(s)) = (&args.pod_command_port, &args.pod_stream_port) {
        Some(Pod::connect_serial(c, s)?)
    } else if let Some(sn) = &args.pod_serial {
        let (c, s) = find_usb((sn != "any").then_some(sn.as_str()))?;
        Some(Pod::connect_serial(&c, &s)?)
    } else {
        None
    };
    let desk = Desk::new(store, Spool::new(spool), pod);
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|e| e.to_string())?
        .block_on(web::serve(desk, args.port))
        .map_err(|e| format!("serving on 127.0.0.1:{}: {e}", args.port))
}
