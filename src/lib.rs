//! talus: a discrete element method engine for granular flow, checked case by
//! case against LIGGGHTS and YADE. See ARCHITECTURE.md for the layout.

pub mod analysis;
pub mod builder;
pub mod case;
pub mod checkpoint;
pub mod checks;
pub mod clump;
pub mod contact;
pub mod dim;
pub mod drag;
pub mod durable;
pub mod error;
pub mod export;
pub mod fields;
pub mod fixed;
pub mod forces;
pub mod generate;
pub mod insert;
pub mod integrate;
pub mod material;
pub mod neighbor;
pub mod parallel;
pub mod observe;
pub mod order;
pub mod output;
pub mod overrides;
pub mod particles;
pub mod prefetch;
pub mod run;
pub mod signals;
pub mod sim;
pub mod walls;

pub use error::TalusError;
