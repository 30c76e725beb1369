//! The scene as data: triangles (f32, as Embree sees them), per-triangle geometric normals and
//! materials, optional shading normals and texture coordinates, lights, cameras, bounds and the
//! feature set. A reader builds it from a file ([`obj`], [`gltf`], with a [`sidecar`] scene file
//! around either; [`load`] picks one), then it is immutable but for the lights a run adds and its
//! flatland preparation.
//!
//! # Module order
//!
//! Imports between the submodules run one way: a module imports only modules on lines above
//! its own (those on one line import none of each other), and the readers build the scene model
//! without the model knowing them. `tests/layers.rs` reads this list and holds the sources to it.
//!
//! - `files`, `geometry`, `pbr`, `error` — leaves shared by the rest: file extensions and URIs;
//!   boxes, triangle normals, barycentrics; the albedo and lobe maths of materials and readers;
//!   the errors of loading
//! - `texture`, `env` — decoded images: textures, the environment map
//! - `material` — scattering models, texture references, cut-out coverage
//! - `light` — lights and the power tables that choose among them
//! - `mirror`, `features` — planar mirrors; which effects a scene has
//! - `instance` — prototypes and their instances (instanced geometry)
//! - `flat` — the flatland plane and the 2D forms of lights and materials
//! - `model` — the [`Scene`] type and its per-triangle records
//! - `hit` — rays against the scene, hits in f64 with their error bound
//! - `shading`, `cutout` — what a hit sees of its material; where cut-outs let rays through
//! - `offset` — points moved off the surfaces they lie on
//! - `build` — a scene built from a reader's parts
//! - `flatland`, `dimmer` — a scene prepared for a flatland run; its file's lights by name,
//!   switched off and scaled
//! - `obj`, `gltf`, `sidecar` — the readers
//! - `load` — the reader for a file's extension
//!
//! Methods of [`Scene`] live beside the concern they serve (`impl Scene` blocks in `build`, `hit`,
//! `shading`, `cutout`, `offset`, `flatland`); they call only methods of modules above their own.

pub mod build;
pub mod cutout;
pub mod dimmer;
pub mod env;
pub mod error;
pub mod features;
pub mod files;
pub mod flat;
pub mod flatland;
pub mod geometry;
pub mod gltf;
pub mod hit;
pub mod instance;
pub mod light;
pub mod load;
pub mod material;
pub mod mirror;
pub mod model;
pub mod obj;
pub mod offset;
pub mod pbr;
pub mod shading;
pub mod sidecar;
pub mod texture;

pub use error::{CameraError, ImageError, LoadError};
pub use features::Features;
pub use geometry::{Aabb, barycentric, closest_point_on_triangle, interpolate_uv, triangle_normal};
pub use hit::Hit;
pub use instance::{Instance, Instancing, Prototype};
pub use light::{DEFAULT_SUN_DIAMETER_DEG, Light, LightSet};
pub use load::LoadOptions;
pub use material::Material;
pub use model::{Camera, LoadReport, Scene, Shading, TexCoords};
