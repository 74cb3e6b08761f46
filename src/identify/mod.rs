//! Identification: test results → machine geometric deviations and NC corrections.
