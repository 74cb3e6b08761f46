//! The desk's link to one pod: its USB command port (SCPI lines) and its stream port (read
//! into memory in a thread from the moment the desk connects, so every run armed after that
//! arrives whole). A pod on USB offers them as two CDC-ACM serial ports (found by the pod's
//! VID/PID and serial number, [`find_usb`], or named); `sim --serve` as loopback TCP ports.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The pod's USB vendor and product ID (`src/board/usb.rs`: pid.codes' test pair).
pub const USB_VID_PID: (u16, u16) = (0x1209, 0x0001);

/// What the stream port has sent since the desk connected, and whether it is still open.
#[derive(Default)]
pub struct StreamBuffer {
    /// The port's bytes, as sent (text lines and sample records).
    pub bytes: Vec<u8>,
    /// The port closed (the pod went away).
    pub closed: bool,
}

/// One pod, held by this desk.
pub struct Pod {
    reader: BufReader<Box<dyn Read + Send>>,
    writer: Box<dyn Write + Send>,
    /// The stream port's bytes (shared with the reader thread and the live view).
    pub stream: Arc<Mutex<StreamBuffer>>,
    /// `*IDN?`: maker, model, serial, firmware.
    pub identity: String,
}

/// How long an answer may take (a configuration write's check included).
const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// Reads the stream port into `sink` until it closes.
fn record_stream(mut port: Box<dyn Read + Send>, sink: Arc<Mutex<StreamBuffer>>) {
    std::thread::spawn(move || {
        let mut buf = vec![0; 1 << 16];
        loop {
            match port.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => {
                    if let Ok(mut b) = sink.lock() {
                        b.bytes.extend_from_slice(&buf[..n]);
                    }
                }
                // a serial port's read times out while nothing comes: keep reading
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(_) => break,
            }
        }
        if let Ok(mut b) = sink.lock() {
            b.closed = true;
        }
    });
}

/// A serial port opened raw (the pod's CDC-ACM ignores the baud rate), DTR set: the pod
/// takes a port as open while its host holds DTR.
fn open_serial(path: &Path) -> Result<Box<dyn serialport::SerialPort>, String> {
    let mut p = serialport::new(path.to_string_lossy(), 115_200)
        .timeout(ANSWER_TIMEOUT)
        .open()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    // (a pseudo-terminal, as the tests use, has no modem lines)
    let _ = p.write_data_terminal_ready(true);
    Ok(p)
}

/// The pod's two ports among the USB serial ports, from Linux's sysfs (`/sys/class/tty`):
/// the CDC-ACM interfaces of a device with the pod's VID/PID — interface 0 the command port, 2
/// the stream port — and, when given, this serial number (`*IDN?`'s third field). Why sysfs:
/// `serialport`'s own enumeration needs libudev's development files, which a fresh machine
/// lacks.
pub fn find_usb(serial: Option<&str>) -> Result<(PathBuf, PathBuf), String> {
    let read = |p: PathBuf| {
        std::fs::read_to_string(p)
            .map(|s| s.trim().to_string())
            .unwrap_or_default()
    };
    let mut pods: std::collections::BTreeMap<String, [Option<PathBuf>; 2]> = Default::default();
    let ttys = std::fs::read_dir("/sys/class/tty").map_err(|e| format!("/sys/class/tty: {e}"))?;
    for tty in ttys.flatten() {
        let name = tty.file_name().to_string_lossy().into_owned();
        // …/ttyACMn/device is the USB interface; its parent is the device
        let Ok(iface) = std::fs::canonicalize(tty.path().join("device")) else {
            continue;
        };
        let Some(dev) = iface.parent() else { continue };
        let vid = u16::from_str_radix(&read(dev.join("idVendor")), 16).ok();
        let pid = u16::from_str_radix(&read(dev.join("idProduct")), 16).ok();
        if (vid, pid) != (Some(USB_VID_PID.0), Some(USB_VID_PID.1)) {
            continue;
        }
        let sn = read(dev.join("serial"));
        if serial.is_some_and(|s| !s.eq_ignore_ascii_case(&sn)) {
            continue;
        }
        let slot = match read(iface.join("bInterfaceNumber")).as_str() {
            "00" => 0,
            "02" => 1,
            _ => continue,
        };
        pods.entry(sn).or_default()[slot] = Some(PathBuf::from("/dev").join(name));
    }
    let mut whole = pods
        .into_iter()
        .filter_map(|(sn, [c, s])| Some((sn, c?, s?)));
    match (whole.next(), whole.next()) {
        (Some((_, c, s)), None) => Ok((c, s)),
        (None, _) => Err(match serial {
            Some(sn) => format!("no pod with serial number {sn} on USB"),
            None => "no pod on USB (VID:PID 1209:0001)".into(),
        }),
        (Some((a, ..)), Some((b, ..))) => Err(format!(
            "more than one pod on USB ({a}, {b}, …): name one with --pod-serial"
        )),
    }
}

impl Pod {
    /// Connects to a served pod's USB command and stream ports on loopback.
    pub fn connect_tcp(usb_port: u16, stream_port: u16) -> Result<Self, String> {
        let s = TcpStream::connect(("127.0.0.1", stream_port))
            .map_err(|e| format!("pod stream port {stream_port}: {e}"))?;
        let w = TcpStream::connect(("127.0.0.1", usb_port))
            .map_err(|e| format!("pod command port {usb_port}: {e}"))?;
        w.set_read_timeout(Some(ANSWER_TIMEOUT))
            .map_err(|e| e.to_string())?;
        let _ = w.set_nodelay(true);
        let r = w.try_clone().map_err(|e| e.to_string())?;
        Self::connect(Box::new(r), Box::new(w), Box::new(s))
    }

    /// Connects to a pod's two serial ports (its command port, its stream port).
    pub fn connect_serial(command: &Path, stream: &Path) -> Result<Self, String> {
        let s = open_serial(stream)?;
        let w = open_serial(command)?;
        let r = w
            .try_clone()
            .map_err(|e| format!("{}: {e}", command.display()))?;
        Self::connect(Box::new(r), Box::new(w), Box::new(s))
    }

    fn connect(
        reader: Box<dyn Read + Send>,
        writer: Box<dyn Write + Send>,
        stream_port: Box<dyn Read + Send>,
    ) -> Result<Self, String> {
        let stream = Arc::new(Mutex::new(StreamBuffer::default()));
        record_stream(stream_port, stream.clone());
        let mut pod = Self {
            reader: BufReader::new(reader),
            writer,
            stream,
            identity: String::new(),
        };
        // the served pod takes a stream reader on its next loop turn; a refusal is one line
        std::thread::sleep(Duration::from_millis(300));
        if let Ok(b) = pod.stream.lock()
            && b.bytes.starts_with(b"# port in use")
        {
            return Err("the pod's stream port is held by another program (another desk?)".into());
        }
        let idn = pod.query("*IDN?")?;
        if idn.contains("in use by another client") {
            return Err("the pod's command port is held by another program (another desk?)".into());
        }
        pod.identity = idn;
        Ok(pod)
    }

    /// Sends one line and reads its one-line answer.
    pub fn query(&mut self, q: &str) -> Result<String, String> {
        self.send(q)?;
        let mut line = String::new();
        match self.reader.read_line(&mut line) {
            Ok(0) => Err("the pod closed its command port".into()),
            Ok(_) => Ok(line.trim_end().to_string()),
            Err(e) => Err(format!("no answer from the pod to {q:?}: {e}")),
        }
    }

    fn send(&mut self, line: &str) -> Result<(), String> {
        self.writer
            .write_all(format!("{line}\n").as_bytes())
            .and_then(|()| self.writer.flush())
            .map_err(|e| format!("the pod's command port: {e}"))
    }

    /// Sends a command line, then checks the pod's error queue is empty (`SYST:ERR?`), else the
    /// pod's first error is the error.
    pub fn command(&mut self, c: &str) -> Result<(), String> {
        self.send(c)?;
        let e = self.query("SYST:ERR?")?;
        if e.starts_with("0,") {
            Ok(())
        } else {
            // empty the queue: the next command's check reads its own errors
            while !self.query("SYST:ERR?")?.starts_with("0,") {}
            Err(format!("the pod refused {c:?}: {e}"))
        }
    }

    /// Forgets what the stream port sent before now (a test keeps its own runs' bytes: the
    /// buffer does not grow over a day of tests); what it sends from now on starts at 0.
    pub fn stream_restart(&self) {
        if let Ok(mut b) = self.stream.lock() {
            b.bytes.clear();
        }
    }

    /// Bytes the stream port has sent so far.
    pub fn stream_len(&self) -> usize {
        self.stream.lock().map_or(0, |b| b.bytes.len())
    }

    /// The stream's bytes from `at` on, and whether the port has closed.
    pub fn stream_since(&self, at: usize) -> (Vec<u8>, bool) {
        self.stream.lock().map_or((Vec::new(), true), |b| {
            (b.bytes.get(at..).unwrap_or(&[]).to_vec(), b.closed)
        })
    }
}
