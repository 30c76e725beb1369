//! The developer tools against builds of this tree: `cargo xtask converge --baseline` and `cargo
//! xtask efficiency`, each comparing this tree's ftpd3d with itself.
mod converge;
mod efficiency;
mod support;
