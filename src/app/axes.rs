//! Where each machine axis is among the encoder inputs (the estimators see X, Y, Z first).

use crate::acquisition::MAX_AXES;
use crate::config::{AxisName, Config};

/// Where each machine axis is among the encoder inputs: the estimators see samples in the
/// canonical order X, Y, Z, then the other inputs in input order (the rotary axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct AxisMap {
    /// `order[k]` = the input read for canonical slot k.
    pub(super) order: [usize; MAX_AXES],
    pub(super) identity: bool,
    /// Canonical slots of the B and C axes, if configured.
    pub(super) b: Option<usize>,
    pub(super) c: Option<usize>,
}

impl AxisMap {
    pub(super) fn new(cfg: &Config) -> Self {
        let find = |n: AxisName| cfg.axes.iter().position(|a| a.name == n);
        let mut order = [0usize; MAX_AXES];
        let mut used = [false; MAX_AXES];
        let mut k = 0;
        for n in [AxisName::X, AxisName::Y, AxisName::Z] {
            // an unconfigured linear axis reads NaN (slot points at no input)
            let i = find(n).unwrap_or(MAX_AXES);
            if let Some(o) = order.get_mut(k) {
                *o = i;
            }
            if let Some(u) = used.get_mut(i) {
                *u = true;
            }
            k += 1;
        }
        for (i, u) in used.iter().enumerate() {
            if !u && k < MAX_AXES {
                if let Some(o) = order.get_mut(k) {
                    *o = i;
                }
                k += 1;
            }
        }
        let slot = |n: AxisName| {
            let i = find(n)?;
            order.iter().position(|&o| o == i)
        };
        Self {
            order,
            identity: order == [0, 1, 2, 3, 4],
            b: slot(AxisName::B),
            c: slot(AxisName::C),
        }
    }

    pub(super) fn canonical(&self, axes: &[f32; MAX_AXES]) -> [f32; MAX_AXES] {
        if self.identity {
            return *axes;
        }
        self.order.map(|i| axes.get(i).copied().unwrap_or(f32::NAN))
    }
}
