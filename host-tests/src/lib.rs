//! Host side of ballpod: independent f64 oracles, the virtual machine tool and the simulator.

pub mod forward_seed003;
pub mod forward_seed004;
