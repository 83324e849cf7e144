//! Reports: they only read results.

pub mod accuracy;
pub mod allan;
pub mod axis;
pub mod design;
pub mod engineering;
pub mod error;
pub mod flight;
pub mod health;
pub mod html;
pub mod json;
pub mod lot;
pub mod mission;
pub(crate) mod page;
pub mod plot;
pub mod provenance;
pub mod selfcal;
pub mod spin;
pub mod terminal;
pub mod thermal;
pub mod written;

pub use error::Error;
