//! ballpod firmware (placeholder until the board layer lands).
#![no_std]
#![no_main]
