//! The stabilization diagram's drawing moved to
//! [`crate::report::stabilization`] (issue 28: the numerical core does not
//! reach the report). This module stays empty until `ema/mod.rs` drops it.
