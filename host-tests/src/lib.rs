//! Host side of ballpod: independent f64 oracles, the virtual machine tool and the simulator.

pub mod oracle;
