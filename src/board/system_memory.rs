//! ST's bootloader in the G474's system memory (RM0440 §2.6, AN2606: USB DFU on PA11/PA12),
//! entered from a reset state (`rom_bootloader`).

/// The system memory: the bootloader's vector table first.
const SYSTEM_MEMORY: usize = 0x1FFF_0000;
/// SYSCFG_MEMRMP.MEM_MODE: system flash memory mapped at 0x0000_0000.
const MEM_MODE_SYSTEM_FLASH: u8 = 0b001;

/// Maps the system memory at address 0 and jumps into it with its own stack and reset vector.
pub fn enter() -> ! {
    use embassy_stm32::pac;
    pac::RCC.apb2enr().modify(|w| w.set_syscfgen(true));
    // (a read back: the clock is on before SYSCFG is written)
    let _ = pac::RCC.apb2enr().read();
    pac::SYSCFG
        .memrmp()
        .modify(|w| w.set_mem_mode(MEM_MODE_SYSTEM_FLASH));
    // SAFETY: the system memory starts with ST's bootloader's vector table (its initial stack
    // pointer and reset vector); nothing of this firmware runs after the jump.
    unsafe { cortex_m::asm::bootload(SYSTEM_MEMORY as *const u32) }
}
