//! Deformation of each working region (2021 Sec. 5 and 7; Algorithm Part 2): 1D
//! parametrization, direction field, amplitude and slope fields, the B-spline profile curve,
//! the exact volume solve and the bulge map.

pub mod bulge;
pub mod profile;
pub mod region;
pub mod volume;

pub use region::{
    deform_region, DeformError, DeformParams, DeformStats, DeformTimings, RegionDeformation,
    RegionFrame, WorkingRegion,
};
