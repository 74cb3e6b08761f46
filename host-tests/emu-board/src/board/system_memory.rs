//! The STM32's system memory bootloader (`src/board/system_memory.rs`) on the emulated board:
//! QEMU's mps2 has none, so an entry is counted ([`Figure::RomBootloaderEntries`]) and the boot
//! goes on, as a pod whose bootloader was left without an update (`dfu-util -e`).

use super::shared::{Figure, add_figure};

/// Counts the entry and returns to the boot.
pub fn enter() {
    add_figure(Figure::RomBootloaderEntries, 1);
}
