//! The two secondaries' ADC rings after an overrun (`ballpod::acquisition::rings::realign`, the
//! firmware's `board::lvdt`), against a cycle model of the STM32's DMA: ADC1 and ADC2 convert on
//! the same TIM6 edge and their DMA channels store a few cycles apart; a channel's NDTR counts
//! down from the ring length; a cleared ring (embassy's `RingBufferedAdc::clear`) takes the
//! DMA's position at the moment it reads NDTR and reads from the next half-ring boundary on.
//! The model is written here from the reference manual's description of circular DMA, not
//! from the pod's code.
use std::cell::Cell;
use std::rc::Rc;

use ballpod::acquisition::rings::{DmaRing, realign};

/// Samples per ring (one block at 1 kHz: 5 periods × 20 points); reads restart at its halves.
const RING: u64 = 100;
const HALF: u64 = RING / 2;

/// The CPU's clock, cycles, shared by the two rings; `preempt` adds an interrupt's cycles once,
/// at the `n`-th register access.
#[derive(Default)]
struct Cpu {
    cycle: Cell<u64>,
    accesses: Cell<u32>,
    preempt: Cell<Option<(u32, u64)>>,
}

impl Cpu {
    /// One register access of `cost` cycles (after an interrupt, if one is due here).
    fn access(&self, cost: u64) -> u64 {
        let n = self.accesses.get() + 1;
        self.accesses.set(n);
        if let Some((at, cycles)) = self.preempt.get()
            && at == n
        {
            self.cycle.set(self.cycle.get() + cycles);
        }
        self.cycle.set(self.cycle.get() + cost);
        self.cycle.get()
    }
}

/// One ADC's ring: its DMA stores a conversion at `k × period + delay` cycles.
struct Ring {
    cpu: Rc<Cpu>,
    period: u64,
    delay: u64,
    /// The first sample the task reads after the last clear (a count of transfers since start).
    read_from: Option<u64>,
}

impl Ring {
    /// Transfers done by cycle `t`.
    fn transfers(&self, t: u64) -> u64 {
        if t < self.delay {
            0
        } else {
            (t - self.delay) / self.period + 1
        }
    }
}

impl DmaRing for Ring {
    fn remaining(&mut self) -> u16 {
        let t = self.cpu.access(4);
        (RING - self.transfers(t) % RING) as u16
    }

    fn clear(&mut self) {
        // embassy reads the completion count, then NDTR, then sets its indices
        self.cpu.access(12);
        let at = self.transfers(self.cpu.access(4));
        self.cpu.access(20);
        self.read_from = Some(at.div_ceil(HALF) * HALF);
    }
}

/// Both rings of one CPU, conversions `period` cycles apart, ADC2's store `skew` cycles after
/// ADC1's; the CPU starts at `start`.
fn rings(period: u64, skew: u64, start: u64) -> (Rc<Cpu>, Ring, Ring) {
    let cpu = Rc::new(Cpu::default());
    cpu.cycle.set(start);
    let ring = |delay| Ring {
        cpu: cpu.clone(),
        period,
        delay,
        read_from: None,
    };
    (cpu.clone(), ring(200), ring(200 + skew))
}

#[test]
fn both_rings_restart_at_one_boundary_at_every_phase_of_the_conversions() {
    // 10 µs between conversions (1 kHz samples) and 2.5 µs (20 kHz excitation), 170 MHz;
    // ADC2's DMA request served after ADC1's (same priority, lower channel first)
    for period in [1700, 425] {
        for skew in [2, 6] {
            // every cycle of ten conversions, ten ring laps in: the clears meet a store at some
            let mut retried = 0;
            for start in (10 * RING * period)..(10 * RING * period + 10 * period) {
                let (cpu, mut a, mut b) = rings(period, skew, start);
                assert!(realign(&mut a, &mut b));
                assert_eq!(a.read_from, b.read_from, "period {period} start {start}");
                // one attempt is 10 accesses
                retried += u32::from(cpu.accesses.get() > 10);
            }
            assert!(
                retried > 0,
                "the phases must include a store between the reads"
            );
        }
    }
}

#[test]
fn an_interrupt_between_the_two_clears_is_caught() {
    // 1.5 conversions of an interrupt after ADC1's clear, at a half-ring boundary: ADC2 is
    // cleared one conversion later — the second attempt finds both at one position
    let period = 1700;
    let start = 10 * RING * period + (HALF - 1) * period + 300;
    let (cpu, mut a, mut b) = rings(period, 2, start);
    // accesses: 2 positions, then A's clear (3), then B's clear
    cpu.preempt.set(Some((6, 2550)));
    assert!(realign(&mut a, &mut b));
    assert_eq!(a.read_from, b.read_from);
    assert!(cpu.accesses.get() > 14, "a second attempt was made");
    // the same interrupt without the check: B starts half a ring after A
    let (cpu, mut a, mut b) = rings(period, 2, start);
    cpu.preempt.set(Some((4, 2550)));
    a.clear();
    b.clear();
    assert_eq!(b.read_from.unwrap() - a.read_from.unwrap(), HALF);
}

#[test]
fn rings_cleared_each_when_found_lapped_restart_half_a_ring_apart() {
    // what the task did before: ADC1's ring, found lapped, was cleared at once; ADC2's only
    // when the task next read it, after ADC1's next half had arrived — each restarts at its own
    // boundary, and a later half of one is paired with another half of the other until a
    // read happens to clear them again
    let period = 1700;
    let (cpu, mut a, mut b) = rings(period, 2, 10 * RING * period + 7 * period);
    a.clear();
    let a_from = a.read_from.unwrap();
    cpu.cycle.set(200 + (a_from + HALF - 1) * period + 100);
    b.clear();
    assert_eq!(b.read_from.unwrap() - a_from, HALF);
    // both together
    let (_, mut a, mut b) = rings(period, 2, 10 * RING * period + 7 * period);
    assert!(realign(&mut a, &mut b));
    assert_eq!(a.read_from, b.read_from);
}
