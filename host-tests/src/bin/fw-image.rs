//! `fw-image`: seals the linked firmware for the guard stage — writes the image header (length,
//! CRC-32; `ballpod_guard`) into the ELF in place, so a debug probe flashes a sealed image, and
//! with `--bin` writes the binary a field update downloads (`dfu-util … -s 0x08000800:leave -D
//! ballpod.bin`; book: Hardware, "Updating the firmware"). The probe-rs runner
//! (`.cargo/probe-run`) calls it before every flash.
use std::path::PathBuf;

use clap::Parser;

use ballpod_host::fw_image::{image_of, patch_elf};

/// Seals the firmware ELF for the guard stage and optionally writes its DFU binary.
#[derive(Parser, Debug)]
#[command(name = "fw-image", version)]
struct Args {
    /// The firmware ELF (target/thumbv7em-none-eabihf/release/ballpod), patched in place.
    elf: PathBuf,
    /// Also write the image as a raw binary for `dfu-util` (load address 0x08000800).
    #[arg(long)]
    bin: Option<PathBuf>,
}

fn run(args: &Args) -> Result<String, Box<dyn std::error::Error>> {
    let mut elf = std::fs::read(&args.elf)?;
    let image = image_of(&elf)?;
    patch_elf(&mut elf, &image)?;
    std::fs::write(&args.elf, &elf)?;
    let mut said = format!(
        "fw-image: {} bytes at {:#010x}, CRC-32 {:#010x}; header sealed into {}",
        image.bytes.len(),
        ballpod_guard::APP_BASE,
        image.crc,
        args.elf.display()
    );
    if let Some(bin) = &args.bin {
        std::fs::write(bin, &image.bytes)?;
        said += &format!("; binary {}", bin.display());
    }
    Ok(said)
}

fn main() {
    match run(&Args::parse()) {
        Ok(said) => println!("{said}"),
        Err(e) => {
            eprintln!("fw-image: {e}");
            std::process::exit(1);
        }
    }
}
