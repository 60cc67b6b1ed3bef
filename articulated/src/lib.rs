//! # constraint-articulated
//!
//! Articulated rigid bodies in maximal coordinates (Otaduy 2010, "Sólidos articulados").
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]

extern crate alloc;
