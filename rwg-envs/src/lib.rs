//! # rwg-envs
//!
//! Gymnasium's classic-control environments, reproducing Gymnasium 1.4's
//! numbers bit for bit (and gym 0.17.2's for Pendulum-v0). Each env lives in
//! its own module; [`registry`] builds them by id with Gymnasium's time limits.

pub mod acrobot;
pub mod cartpole;
pub mod mountain_car;
pub mod mountain_car_continuous;
pub mod pendulum;
pub mod registry;

pub use registry::{make, visit, EnvOptions, EnvVisitor, Registration, UnknownEnv, REGISTRY};
