//! The device's own counters and figures, beside the run's: what the shell's queues dropped,
//! the watchdog, the excitation DMA, the longest interrupt-masked section and the stack's
//! high-water mark. The shell (the firmware's board layer, the simulated pod) sets them; the
//! application holds them so that both protocols report one table: SCPI `SYSTem:COUNt?`
//! (comma-separated, [`DEVICE_COUNTERS`] order) and CANopen 0x2110:k (k = 1…).

/// The value of a figure the shell cannot measure (the simulated pod has no interrupts or
/// stack of its own to watch): SCPI answers 9.91E+37 (NaN), CANopen 0xFFFF_FFFF.
pub const NOT_MEASURED: u32 = u32::MAX;

/// One device counter (its index in [`DEVICE_COUNTERS`] is `as usize`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum DeviceCounter {
    /// Sample periods lost before demodulation (the LVDT task fell behind the ADC DMA ring),
    /// counted from the gaps between the blocks' times.
    AdcBlocksLost = 0,
    /// Demodulated blocks dropped because the application task was behind.
    BlockQueueOverruns,
    /// Probe edges dropped because the application task was behind.
    ProbeQueueOverruns,
    /// Thermistor readings dropped because the application task was behind.
    ThermistorQueueOverruns,
    /// Received CAN frames dropped because the application task was behind.
    CanRxOverruns,
    /// CAN frames the node produced that did not fit the transmit queue.
    CanTxOverruns,
    /// CAN frames given up after the controller's transmit buffers stayed full.
    CanTxDropped,
    /// USB events (packets, port changes) dropped because the application task was behind.
    UsbRxOverruns,
    /// Response bytes dropped because the command port's host did not read them.
    UsbTxOverruns,
    /// Sample-stream lines dropped because the stream port's host did not read them.
    StreamLinesDropped,
    /// Samples not logged because a log download was in progress.
    LogPausedSamples,
    /// Settings saves that failed (driver error or read-back mismatch).
    SettingsStoreFailures,
    /// Watchdog looks that found a task not checked in (the dog was not petted).
    WatchdogMisses,
    /// Excitation DAC DMA underruns (the sine stalled; the samples around it are suspect).
    DacUnderruns,
    /// Longest interrupt-masked section since boot, ns.
    MaskedMaxNs,
    /// Deepest stack use since boot, bytes.
    StackHighWaterBytes,
    /// Settings slots found unreadable at boot (0–2: a double ECC error in flash, a save cut by
    /// a power loss).
    SettingsSlotsUnreadable,
    /// Received CAN frames the controller lost (its receive FIFO or the driver's buffer full,
    /// counted in the interrupt); each loss is also EMCY 0x8110.
    CanRxLost,
    /// Times the CAN controller went bus-off, however briefly (counted in the interrupt).
    CanBusOffEntries,
    /// Times the CAN controller went error passive (counted in the interrupt).
    CanErrorPassiveEntries,
}

/// Number of device counters.
pub const DEVICE_COUNTER_COUNT: usize = DeviceCounter::CanErrorPassiveEntries as usize + 1;

/// The counters' names (SCPI documentation, CANopen sub-index names in the EDS), in order.
pub const DEVICE_COUNTERS: [&str; DEVICE_COUNTER_COUNT] = [
    "adc_blocks_lost",
    "block_queue_overruns",
    "probe_queue_overruns",
    "thermistor_queue_overruns",
    "can_rx_overruns",
    "can_tx_overruns",
    "can_tx_dropped",
    "usb_rx_overruns",
    "usb_tx_overruns",
    "stream_lines_dropped",
    "log_paused_samples",
    "settings_store_failures",
    "watchdog_misses",
    "dac_underruns",
    "masked_max_ns",
    "stack_high_water_bytes",
    "settings_slots_unreadable",
    "can_rx_lost",
    "can_bus_off_entries",
    "can_error_passive_entries",
];

/// The device counters' values, [`DEVICE_COUNTERS`] order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceCounters(pub [u32; DEVICE_COUNTER_COUNT]);

impl DeviceCounters {
    /// Every counter zero, every figure [`NOT_MEASURED`].
    #[allow(
        clippy::indexing_slicing,
        reason = "const evaluation: an index out of range fails the build"
    )]
    pub const START: Self = {
        let mut c = [0; DEVICE_COUNTER_COUNT];
        c[DeviceCounter::MaskedMaxNs as usize] = NOT_MEASURED;
        c[DeviceCounter::StackHighWaterBytes as usize] = NOT_MEASURED;
        Self(c)
    };

    /// Sets one counter.
    pub fn set(&mut self, c: DeviceCounter, v: u32) {
        if let Some(x) = self.0.get_mut(c as usize) {
            *x = v;
        }
    }

    /// One counter.
    pub fn get(&self, c: DeviceCounter) -> u32 {
        self.0.get(c as usize).copied().unwrap_or(NOT_MEASURED)
    }
}
