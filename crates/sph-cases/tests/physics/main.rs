//! Physics tests of the three ISPH schemes and of the paper's Section 3 analysis.

mod cavity;
mod drop_runs;
mod effects;
mod flows;
mod measures;
mod multigrid;
mod section3;
mod step_one;
mod support;
mod walls;
