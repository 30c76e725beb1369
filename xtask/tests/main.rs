//! The developer tools against builds of this tree: `cargo xtask converge --baseline`, `cargo xtask
//! efficiency`, `equal-time` and `first-command`, each comparing this tree's ftpd3d with itself.
mod converge;
mod efficiency;
mod equal_time;
mod support;
