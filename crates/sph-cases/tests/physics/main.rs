//! Physics tests of the three ISPH schemes on the paper's drops.

mod step_one;
