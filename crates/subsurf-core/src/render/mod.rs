//! Rendering translucent objects: the seed's eq. (1.10),
//! L_o(x_o, ω_o) = ∫_A ∫_2π S(x_i, ω_i; x_o, ω_o) L_i(x_i, ω_i) (n·ω_i) dω_i dA(x_i),
//! on triangle meshes, with three ways to compute the translucent term:
//!
//! - [`hierarchical`]: Jensen & Buhler (2002), irradiance samples and an octree ([`tree`]);
//! - [`probe`]: pbrt-v4's probe-ray importance sampling of the profile (unbiased);
//! - [`random_walk`]: volumetric path tracing inside the closed mesh (no diffusion assumption).
//!
//! The BSSRDF methods use any profile behind [`crate::bssrdf::RadialProfile`], one per colour
//! channel ([`material`]). Scenes ([`scene`]) hold meshes ([`mesh`], [`shapes`]), lights
//! ([`light`]), a constant environment and a pinhole [`camera`]; rays are traced with a BVH
//! ([`accel`]). [`driver`] renders progressively, reproducibly for any thread count;
//! [`walk`] is the one random-walk transport core inside closed meshes, used by
//! [`random_walk`] and by [`walk_sim`], the random walk as a simulation (pencil beam or
//! illumination on a mesh, exitance per triangle, absorption on a voxel grid).

pub mod accel;
pub mod adaptive;
pub mod beams;
pub mod camera;
pub mod cells;
pub mod convex;
pub mod distance;
pub mod driver;
pub mod env_walk;
pub mod facet_nee;
pub mod fastmath;
pub mod flight;
pub mod fresnel_control;
pub mod grid;
pub mod guide;
pub mod hierarchical;
pub mod irradiance;
pub mod light;
pub mod material;
pub mod math;
pub mod mesh;
pub mod pixel;
pub mod primary;
pub mod probe;
pub mod random_walk;
pub mod scene;
pub mod shade;
pub mod shapes;
pub mod texture;
pub mod tree;
pub mod walk;
pub mod walk_alloc;
pub mod walk_sim;

#[cfg(test)]
mod flow_tests;
#[cfg(test)]
mod grid_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod texture_tests;
#[cfg(test)]
mod walk_tests;

pub use camera::Camera;
pub use driver::{with_threads, Control, Method, Renderer};
pub use hierarchical::HierarchicalParams;
pub use light::{Light, LightKind};
pub use material::{Material, Translucent, TranslucentSpec};
pub use mesh::Mesh;
pub use scene::{Object, Scene};
