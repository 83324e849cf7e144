//! Experimental design: what a plan of observation points can estimate and how precisely,
//! before a single test is run, and exact optimal plans over the points the equipment can reach.

pub mod coordinate;
pub mod criteria;
pub mod error;
pub mod exchange;
pub mod models;
pub mod points;
pub mod predict;
pub mod search;
pub mod space;
pub mod stage_plans;
pub mod stages;

pub use error::Error;
