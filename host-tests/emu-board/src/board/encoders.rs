//! The five encoder inputs: their counters arrive in the block records (16 bits, as the STM32
//! board reads its timers).

use ballpod::acquisition::MAX_AXES;

/// Width of every counter as the core sees it.
pub const COUNTER_BITS: [u32; MAX_AXES] = [16; MAX_AXES];

/// The encoder interfaces (nothing to keep alive here).
pub struct Encoders;
