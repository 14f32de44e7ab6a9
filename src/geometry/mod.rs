//! The lecture's ray–primitive intersection formulas, shared by the native backend and the
//! Embree user-geometry callbacks so that both trace exactly the same spheres and planes, and
//! the native backend's watertight triangle test.

pub mod plane;
pub mod sphere;
pub mod triangle;

pub use plane::Plane;
pub use sphere::Sphere;
