use thiserror::Error;

/// Errors raised while indexing points for neighbour search.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum NeighborError {
    /// The search radius is not a positive finite number.
    #[error("neighbour search radius must be positive and finite, got {0}")]
    InvalidRadius(f64),
    /// A point has a NaN or infinite coordinate.
    #[error("point {index} has a non-finite coordinate")]
    NonFinitePoint {
        /// Index of the first offending point.
        index: usize,
    },
    /// More points than a `u32` index can address.
    #[error("{0} points exceed the u32 index range of neighbour lists")]
    TooManyPoints(usize),
    /// The cloud spans too many search radii for integer cell coordinates.
    #[error("the point cloud spans {span_over_radius:e} search radii along an axis (limit 2^50)")]
    DomainTooWide {
        /// Extent of the bounding box divided by the radius.
        span_over_radius: f64,
    },
    /// The periodic description does not fit the points or the radius.
    #[error("periodic search: {0}")]
    Periodic(String),
    /// The kd-tree backend refused the input.
    #[error("kd-tree construction failed: {0}")]
    KdTree(String),
}
