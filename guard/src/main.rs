//! The guard stage, in the first 2 KiB page of the STM32G474's flash (0x0800_0000), run at every
//! reset before the firmware: it checks the image at `APP_BASE` (`ballpod_guard::check`: header,
//! stack pointer, reset vector, CRC-32 with the hardware CRC unit, ~20 ms at the reset clock)
//! and starts it, or enters ST's ROM bootloader (USB DFU) so that an update cut by a power loss
//! can simply be run again. A double ECC error while it reads (a double-word cut mid-program)
//! raises an NMI, which is noted and makes the check fail; a fault of the guard itself marks
//! retained RAM and resets into the bootloader. A field update never writes this page (book:
//! Hardware, "Updating the firmware": write-protect it with the option bytes).
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use ballpod_guard::{APP_BASE, CRC_CR, CRC_INIT, CRC_POLY, CRC_XOR_OUT, Verdict, WordCrc, check};
use cortex_m_rt::{ExceptionFrame, entry, exception};

// Registers by address (RM0440 register maps): the guard touches seven, and a PAC would cost a
// long build for nothing this page needs.
/// RCC_AHB1ENR; CRCEN is bit 12.
const RCC_AHB1ENR: *mut u32 = 0x4002_1048 as *mut u32;
const CRCEN: u32 = 1 << 12;
/// RCC_APB2ENR; SYSCFGEN is bit 0.
const RCC_APB2ENR: *mut u32 = 0x4002_1060 as *mut u32;
const SYSCFGEN: u32 = 1;
/// CRC unit: data, control, initial value, polynomial.
const CRC_DR_REG: *mut u32 = 0x4002_3000 as *mut u32;
const CRC_CR_REG: *mut u32 = 0x4002_3008 as *mut u32;
const CRC_INIT_REG: *mut u32 = 0x4002_3010 as *mut u32;
const CRC_POL_REG: *mut u32 = 0x4002_3014 as *mut u32;
/// FLASH_ECCR; ECCD (bit 31) flags a double ECC error, cleared by writing 1.
const FLASH_ECCR: *mut u32 = 0x4002_2018 as *mut u32;
const ECCD: u32 = 1 << 31;
/// SYSCFG_MEMRMP; MEM_MODE (bits 2:0) = 0b001 maps the system flash at 0.
const SYSCFG_MEMRMP: *mut u32 = 0x4001_0000 as *mut u32;
const MEM_MODE_SYSTEM_FLASH: u32 = 0b001;
/// The system memory: ST's bootloader's vector table (AN2606).
const SYSTEM_MEMORY: u32 = 0x1FFF_0000;

/// Set by the NMI handler when a read met a double ECC error.
static ECC_SEEN: AtomicBool = AtomicBool::new(false);

/// "Go to the bootloader": written by a fault of the guard before it resets.
const BOOTLOADER_MARK: u32 = 0x6A4D_B007;
/// Retained across the reset (not initialised by cortex-m-rt). Power-on leaves noise, which
/// matches the mark with a chance of 2^-32 (and then only the bootloader waits).
#[unsafe(link_section = ".uninit.guard")]
static mut MARK: MaybeUninit<u32> = MaybeUninit::uninit();

#[entry]
fn main() -> ! {
    let mark = &raw mut MARK;
    // SAFETY: thread mode is the only reader; any bit pattern is a valid u32.
    let asked = unsafe { mark.cast::<u32>().read_volatile() } == BOOTLOADER_MARK;
    // SAFETY: as above.
    unsafe { mark.cast::<u32>().write_volatile(0) };
    if asked {
        enter_rom_bootloader();
    }
    // SAFETY: the RCC register enables clocks; the CRC unit is the guard's alone.
    let clocks = unsafe { RCC_AHB1ENR.read_volatile() };
    // SAFETY: as above; the read back makes sure the clock is on before the unit is written.
    unsafe {
        RCC_AHB1ENR.write_volatile(clocks | CRCEN);
        let _ = RCC_AHB1ENR.read_volatile();
    }
    let verdict = check(read_word, &mut HwCrc);
    // SAFETY: the clocks as the image expects them after a reset.
    unsafe { RCC_AHB1ENR.write_volatile(clocks) };
    match verdict {
        Verdict::Start => start_image(),
        Verdict::Refuse(_) => enter_rom_bootloader(),
    }
}

/// The i-th word of the image; `None` once a read met a double ECC error.
fn read_word(i: usize) -> Option<u32> {
    // SAFETY: `check` reads below APP_BASE + MAX_LENGTH, which is flash; an ECC error there
    // raises the NMI, which returns.
    let w = unsafe { (APP_BASE as *const u32).add(i).read_volatile() };
    (!ECC_SEEN.load(Ordering::Relaxed)).then_some(w)
}

/// The hardware CRC unit set up for CRC-32/ISO-HDLC (`ballpod_guard::CRC_CR`).
struct HwCrc;

impl WordCrc for HwCrc {
    fn start(&mut self) {
        // SAFETY: the CRC unit's registers, its clock on.
        unsafe {
            CRC_POL_REG.write_volatile(CRC_POLY);
            CRC_INIT_REG.write_volatile(CRC_INIT);
            CRC_CR_REG.write_volatile(CRC_CR);
        }
    }
    fn feed(&mut self, word: u32) {
        // SAFETY: as above.
        unsafe { CRC_DR_REG.write_volatile(word) }
    }
    fn value(&mut self) -> u32 {
        // SAFETY: as above.
        unsafe { CRC_DR_REG.read_volatile() ^ CRC_XOR_OUT }
    }
}

/// Starts the image: its vector table, stack pointer and reset vector.
fn start_image() -> ! {
    // SAFETY: `check` found a stack pointer in SRAM and a reset vector inside the whole image.
    unsafe {
        (*cortex_m::peripheral::SCB::PTR).vtor.write(APP_BASE);
        cortex_m::asm::bootload(APP_BASE as *const u32)
    }
}

/// Maps the system memory at 0 and jumps into ST's bootloader (clocks and peripherals as
/// after a reset, but for SYSCFG's clock).
fn enter_rom_bootloader() -> ! {
    // SAFETY: SYSCFG's clock, then its memory remap; the system memory begins with the
    // bootloader's vector table; nothing of the guard runs after the jump.
    unsafe {
        RCC_APB2ENR.write_volatile(RCC_APB2ENR.read_volatile() | SYSCFGEN);
        let _ = RCC_APB2ENR.read_volatile();
        SYSCFG_MEMRMP
            .write_volatile((SYSCFG_MEMRMP.read_volatile() & !0b111) | MEM_MODE_SYSTEM_FLASH);
        cortex_m::asm::bootload(SYSTEM_MEMORY as *const u32)
    }
}

/// Marks retained RAM and resets: the next run of the guard enters the bootloader.
fn mark_and_reset() -> ! {
    // SAFETY: a u32 write to the guard's retained word; the reset follows.
    unsafe {
        (&raw mut MARK)
            .cast::<u32>()
            .write_volatile(BOOTLOADER_MARK)
    };
    cortex_m::peripheral::SCB::sys_reset()
}

/// A double ECC error is noted for `read_word` and cleared; any other NMI is a fault.
#[exception]
unsafe fn NonMaskableInt() {
    // SAFETY: FLASH_ECCR; its flags are cleared by writing back the 1s read.
    let eccr = unsafe { FLASH_ECCR.read_volatile() };
    if eccr & ECCD != 0 {
        // SAFETY: as above.
        unsafe { FLASH_ECCR.write_volatile(eccr) };
        ECC_SEEN.store(true, Ordering::Relaxed);
        return;
    }
    mark_and_reset()
}

#[exception]
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    mark_and_reset()
}

#[exception]
unsafe fn DefaultHandler(_irqn: i16) {
    mark_and_reset()
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    mark_and_reset()
}
