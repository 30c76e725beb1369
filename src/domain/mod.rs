//! Where samples start: planar slices (axis-aligned or arbitrary), later volumes and cameras.
pub mod slice;
pub use slice::{Axis, Plane};
