//! The desk's link to one pod: its USB command port (SCPI lines) and its stream port (read
//! into memory in a thread from the moment the desk connects, so every run armed after that
//! arrives whole). `sim --serve` offers both as loopback TCP ports; a pod on USB offers them
//! as two serial ports (not yet: the desk takes TCP ports).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::sync::{Arc, Mutex};
use std::time::Duration;

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
    reader: BufReader<TcpStream>,
    writer: TcpStream,
    /// The stream port's bytes (shared with the reader thread and the live view).
    pub stream: Arc<Mutex<StreamBuffer>>,
    /// `*IDN?`: maker, model, serial, firmware.
    pub identity: String,
}

/// How long an answer may take (a configuration write's check included).
const ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

impl Pod {
    /// Connects to a served pod's USB command and stream ports on loopback.
    pub fn connect_tcp(usb_port: u16, stream_port: u16) -> Result<Self, String> {
        let mut s = TcpStream::connect(("127.0.0.1", stream_port))
            .map_err(|e| format!("pod stream port {stream_port}: {e}"))?;
        let stream = Arc::new(Mutex::new(StreamBuffer::default()));
        let sink = stream.clone();
        std::thread::spawn(move || {
            let mut buf = vec![0; 1 << 16];
            loop {
                match s.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => {
                        if let Ok(mut b) = sink.lock() {
                            b.bytes.extend_from_slice(&buf[..n]);
                        }
                    }
                }
            }
            if let Ok(mut b) = sink.lock() {
                b.closed = true;
            }
        });
        let writer = TcpStream::connect(("127.0.0.1", usb_port))
            .map_err(|e| format!("pod command port {usb_port}: {e}"))?;
        writer
            .set_read_timeout(Some(ANSWER_TIMEOUT))
            .map_err(|e| e.to_string())?;
        let _ = writer.set_nodelay(true);
        let reader = BufReader::new(writer.try_clone().map_err(|e| e.to_string())?);
        let mut pod = Self {
            reader,
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
