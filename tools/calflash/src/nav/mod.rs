//! In flight, on the host: what only the host does around the firmware crate's navigator and
//! filter ([`spincal::nav`]): reading the flight's files, the forward pass with its launch,
//! levelling and heading, the Rauch-Tung-Striebel smoother, and the verdict on the
//! calibration with the filter's own consistency.

pub mod check;
pub mod consistency;
pub mod diagnosis;
pub mod frame;
pub mod input;
pub mod launch;
mod line;
pub mod prior;
pub mod run;
pub mod select;
pub mod smooth;
pub mod track;
pub mod unmodelled;
pub mod verdict;
